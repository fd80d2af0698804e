"""A restarted navigator takes up the mission it saved, unless it should not."""

from __future__ import annotations

import pytest

from services.navigator.resume import MissionRecord, resume_goal

RUNNING = MissionRecord(40.0, "g7", (10.5, 2.7, 0.0, "1"), "", "running", "pass", ["lift_b"])


def test_the_record_round_trips_and_bad_ones_are_named() -> None:
    assert MissionRecord.from_dict(RUNNING.to_dict()) == RUNNING
    by_place = MissionRecord(1.0, "g8", None, "room_b", "running")
    assert MissionRecord.from_dict(by_place.to_dict()) == by_place
    for broken in (
        {},
        {**RUNNING.to_dict(), "goal": [1, "x", 0, "1"]},
        {**RUNNING.to_dict(), "stamp": "nan"},
    ):
        with pytest.raises(ValueError, match="saved mission"):
            MissionRecord.from_dict(broken)


def test_a_running_mission_of_this_run_is_planned_again_with_its_goal() -> None:
    goal, why = resume_goal(RUNNING, 41.5, 30.0)
    assert why == "" and goal.goal_id == "g7" and (goal.goal.x, goal.goal.floor) == (10.5, "1")
    by_place, _ = resume_goal(MissionRecord(1.0, "g8", None, "room_b", "running"), 2.0, 30.0)
    assert by_place.place == "room_b" and by_place.goal is None


@pytest.mark.parametrize(
    "record, now, why",
    [
        (None, 1.0, "no saved mission"),
        (MissionRecord(40.0, "g7", None, "b", "succeeded"), 41.0, "had ended"),
        (RUNNING, 0.5, "earlier run"),
        (RUNNING, 100.0, "60.0 s old"),
        (MissionRecord(40.0, "g7", None, "b", "running", "ride"), 41.0, "in a lift car"),
    ],
)
def test_what_is_not_taken_up_says_why(record, now, why) -> None:
    goal, text = resume_goal(record, now, 30.0)
    assert goal is None and why in text


def test_in_a_car_with_its_route_saved_it_rides_on() -> None:
    from services.navigator.resume import in_car

    riding = MissionRecord(40.0, "g7", None, "b", "running", "ride", [], "cm91dGU=", 3)
    assert in_car(riding) and resume_goal(riding, 41.0, 30.0)[0] is not None
    leaving = MissionRecord(40.0, "g7", None, "b", "running", "exit", [], "cm91dGU=", 3)
    assert not in_car(leaving) and resume_goal(leaving, 41.0, 30.0)[0] is not None  # re-plan
