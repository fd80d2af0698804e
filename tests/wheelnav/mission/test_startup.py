"""Why a mission failed to start, and when a mission that ended while its fleet came up
keeps its own result (wheelnav/mission/run.py)."""

from __future__ import annotations

from wheelnav.mission.run import startup_failure


def test_services_that_never_came_up_fail_the_start() -> None:
    assert startup_failure(["planner"], ended=False, errors={}) == "services not up: planner"


def test_a_service_that_exited_is_named_with_its_error() -> None:
    reason = startup_failure(["planner"], ended=False, errors={"planner": "bad key x"})
    assert reason == "planner: bad key x"


def test_a_mission_that_ended_while_the_fleet_came_up_keeps_its_result() -> None:
    """Campaign seeds 8200-8211, b8200.m06 (every lift out of service, in process): the
    navigator failed the mission at tick 0 with its reason, before the planner's token
    was seen; the runner then replaced that reason by "services not up: planner", and
    the campaign counted the mission as not as expected."""
    assert startup_failure(["planner"], ended=True, errors={}) == ""


def test_all_up_is_no_failure() -> None:
    assert startup_failure([], ended=False, errors={}) == ""
