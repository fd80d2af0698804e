"""On wall time a step that raises ends its service (exit code 3, which the launcher
restarts) instead of leaving a live process whose step thread is dead."""

from __future__ import annotations

import threading
import time

import pytest

from shared.messages import Clock
from shared.service import EXIT_STEP_FAILED, Service


def test_a_failing_wall_step_stops_the_service_with_exit_code_3(router) -> None:
    _bus, endpoint = router
    steps: list[int] = []

    def step(clock: Clock) -> None:
        steps.append(clock.tick)
        if len(steps) == 3:
            raise RuntimeError("boom")

    argv = ["--connect", endpoint, "--set", "clock=wall"]
    with pytest.raises(SystemExit) as ended, Service("probe", argv=argv) as svc:
        svc.every(50.0, step)
        assert svc.stop_event.wait(10.0), "the failing step did not stop the service"
        svc.wait()
    assert ended.value.code == EXIT_STEP_FAILED
    assert steps == [0, 1, 2]  # no step after the failure


def test_a_healthy_wall_step_keeps_running(router) -> None:
    _bus, endpoint = router
    steps: list[int] = []
    with Service("probe", argv=["--connect", endpoint, "--set", "clock=wall"]) as svc:
        svc.every(50.0, lambda clock: steps.append(clock.tick))
        svc.stop_event.wait(0.5)
        assert not svc.step_failed and len(steps) >= 3
        svc.stop_event.set()


def test_after_a_stalled_wall_step_the_missed_steps_are_skipped_not_run_in_a_burst(router) -> None:
    """A step that takes 0.6 s (a manoeuvre search on a busy machine) leaves a 50 Hz loop
    30 periods behind. Run back to back, the missed steps would each take a tick's worth
    of limits (speed ramps, stall watches counted in ticks) within milliseconds of wall
    time on a real chair; the loop takes up the rate from where it is instead."""
    _bus, endpoint = router
    starts: list[float] = []
    stalled = threading.Event()

    def step(clock: Clock) -> None:
        starts.append(time.monotonic())
        if len(starts) == 3:
            time.sleep(0.6)
            stalled.set()

    with Service("probe", argv=["--connect", endpoint, "--set", "clock=wall"]) as svc:
        svc.every(50.0, step)
        assert stalled.wait(10.0)
        end = time.monotonic()
        svc.stop_event.wait(0.5)
        svc.stop_event.set()
    after = [t for t in starts[3:] if t < end + 0.1]
    assert len(after) <= 8, f"{len(after)} steps in the 0.1 s after the stall"  # 30 before
