"""The fleet bench's CPU table: readings of real child processes, and the bound they set."""

from __future__ import annotations

import subprocess
import sys
import time

import pytest

from shared.messages import LockstepProfile
from wheelnav.bench.cpu import PROC, cpu_seconds
from wheelnav.bench.fleet import cpu_rows, summarise

BURN = "import time\nt = time.process_time()\nwhile time.process_time() - t < 0.6: pass\n"


@pytest.mark.skipif(not PROC.is_dir(), reason="reads Linux's /proc")
def test_a_busy_child_is_named_by_its_module_and_charged_its_cpu(tmp_path) -> None:
    (tmp_path / "burner.py").write_text(BURN + "time.sleep(30)\n")
    child = subprocess.Popen([sys.executable, "-m", "burner"], cwd=tmp_path)
    try:
        deadline = time.monotonic() + 30
        while time.monotonic() < deadline:
            used = cpu_seconds().get("burner", 0.0)
            if used >= 0.5:
                break
            time.sleep(0.1)
        assert used >= 0.5
        assert "runner" in cpu_seconds()  # this process itself
    finally:
        child.kill()
        child.wait()


def test_cpu_rows_divide_by_the_ticks_between_readings_and_bound_the_factor() -> None:
    first = (100, {"sim": 1.0, "controller": 2.0})
    last = (600, {"sim": 2.0, "controller": 4.0, "router": 0.5})
    rows = cpu_rows(first, last, dt=0.02, cores=2)
    assert rows["cpu_ms"] == {"controller": 4.0, "sim": 2.0, "router": 1.0}
    assert rows["cpu_total_ms"] == 7.0
    assert rows["cpu_bound_factor"] == pytest.approx(2 * 20.0 / 7.0, abs=0.01)
    assert cpu_rows(first, None, 0.02, 2) is None
    assert cpu_rows(first, (100, {"sim": 1.0}), 0.02, 2) is None


def three_stages() -> tuple[LockstepProfile, list[list[str]]]:
    """500 ticks of 20 ms in 5 s: localisation and building in stage 0, the controller
    every other tick in stage 1, the navigator every fifth in stage 2."""
    profile = LockstepProfile(
        stamp=10.0,
        dt=0.02,
        ticks=500,
        wall_s=5.0,
        physics_s=0.5,
        publish_s=0.4,
        pacing_s=0.0,
        stage_wait_s=[1.5, 2.0, 0.3],
        participants=["localisation", "building", "controller", "navigator"],
        compute_s=[1.0, 0.25, 1.5, 0.1],
        steps=[500, 500, 250, 100],
    )
    return profile, [["localisation", "building", "mission"], ["controller"], ["navigator"]]


def test_the_compute_in_series_takes_each_stages_slowest_participant() -> None:
    profile, stages = three_stages()
    figures = summarise(profile, stages)
    # 0.5 s of steps + 1.0 (localisation, not building) + 1.5 + 0.1 over 500 ticks
    assert figures["serial_compute_ms"] == pytest.approx(6.2)
    assert figures["compute_bound_factor"] == pytest.approx(10.0 / 3.1, abs=0.01)
    assert figures["realtime_factor"] == pytest.approx(2.0)
    assert figures["share_of_bound"] == pytest.approx(2.0 / (10.0 / 3.1), abs=0.001)


def test_in_process_a_stages_participants_are_counted_one_after_another() -> None:
    profile, stages = three_stages()
    figures = summarise(profile, stages, side_by_side=False)
    # one interpreter runs localisation and building in turn: 0.5 + 1.25 + 1.5 + 0.1 s
    assert figures["serial_compute_ms"] == pytest.approx(6.7)
    assert figures["stage_compute"] == "participants in turn"
    assert figures["compute_bound_factor"] == pytest.approx(10.0 / 3.35, abs=0.01)
