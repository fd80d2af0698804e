"""The simulator node on the hardware path refuses settings it cannot run with, in one
line naming the key, before it links a port (over a real router)."""

from __future__ import annotations

import subprocess
from pathlib import Path

from tests.conftest import PYTHON, ROOT


def test_the_node_refuses_the_hardware_path_on_simulation_time(router, tmp_path: Path) -> None:
    _bus, endpoint = router
    link = tmp_path / "whill"
    args = ["--connect", endpoint, "--set", "sim.hardware_path=true"]
    args += ["--set", f"whill.port={link}"]
    done = subprocess.run(
        [PYTHON, "-m", "services.sim.node", *args],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 2, done.stderr
    assert "config error: clock: must be 'wall' with sim.hardware_path" in done.stderr
    assert not link.is_symlink()  # nothing linked, nothing left behind
