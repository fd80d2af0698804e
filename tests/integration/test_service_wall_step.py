"""On wall time a step that raises ends its service (exit code 3, which the launcher
restarts) instead of leaving a live process whose step thread is dead."""

from __future__ import annotations

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
