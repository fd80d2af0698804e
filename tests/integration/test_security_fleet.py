"""End to end, secured: `wheelnav security init`, then `wheelnav up --security`, then the
mission from a terminal with an operator's credentials; the same client without them is
refused, and a viewer's goal starts nothing (beside the operator's, which does)."""

from __future__ import annotations

import signal

import pytest

from tests.conftest import start_up, wheelnav
from wheelnav.mission.run import free_port

pytestmark = pytest.mark.e2e


def test_a_secured_fleet_runs_an_operators_mission_and_refuses_others(tmp_path) -> None:
    keys = str(tmp_path / "keys")
    made = wheelnav("security", "init", keys)
    assert made.returncode == 0, made.stdout + made.stderr
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    up, lines, reader = start_up("--listen", endpoint, "--security", keys)
    try:
        assert any("fleet up" in ln for ln in lines), "".join(lines)
        assert any("secured: mutual TLS" in ln for ln in lines)
        assert not any("insecure" in ln for ln in lines)

        bare = wheelnav("status", "--connect", endpoint, "--duration", "5")
        assert bare.returncode == 1 and "cannot open a Zenoh client session" in bare.stderr

        viewer = ["--connect", endpoint, "--security", keys, "--user", "viewer"]
        sent = wheelnav("go", "room_b", *viewer)
        assert sent.returncode == 0, sent.stderr  # sent, and dropped by the router
        goal_id = sent.stdout.split()[1]
        watched = wheelnav("status", "--follow", "--duration", "10", *viewer)
        assert watched.returncode == 0, watched.stdout + watched.stderr  # the viewer reads
        assert goal_id not in watched.stdout

        operator = ["--connect", endpoint, "--security", keys, "--user", "operator"]
        go = wheelnav("go", "room_b", "--wait", "--timeout", "900", *operator, timeout=960)
        assert go.returncode == 0 and "succeeded" in go.stdout, go.stdout + go.stderr
    finally:
        up.send_signal(signal.SIGINT)
        code = up.wait(timeout=60)
        reader.join(timeout=5)
    text = "".join(lines)
    assert code == 0, text
    assert "config error" not in text and "Traceback" not in text
