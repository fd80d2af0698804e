"""The navigator holding its mission: the emergency stop, the rider's pause, resume.

Real mission trees under the navigator's core, against the scripted fleet
(tests/behaviours/fleet_fake.py); the holds' own rules on their own first.
"""

from __future__ import annotations

import logging
import math

import py_trees
import pytest

from services.navigator.holds import RIDER, Holds, moved_m
from services.navigator.node import Saver
from services.navigator.resume import MissionRecord
from shared.messages import DriverStatus, FollowStatus, NavGoal, NavResume, Phase, Pose2D
from shared.state_store import StateStore
from tests.behaviours.fleet_fake import ScriptedFleet, door, route
from tests.services.navigator.test_navigator import navigator, step

STOP = "emergency stop by wheelnav stop (laptop): a person on the ramp"


@pytest.fixture(autouse=True)
def fresh_blackboard():
    py_trees.blackboard.Blackboard.clear()
    yield
    py_trees.blackboard.Blackboard.clear()


def rider(on: bool) -> DriverStatus:
    return DriverStatus(0.0, 80, 4, 0, joystick_active=on, serial_ok=True)


# -- the rules -----------------------------------------------------------------------------


def test_the_pause_lasts_until_resumed_and_not_while_the_rider_holds_on() -> None:
    holds = Holds()
    assert holds.reason() == "" and not holds.pause_for_rider()
    holds.rider = True
    assert holds.pause_for_rider() and not holds.pause_for_rider()  # one pause, not two
    assert holds.reason() == f"paused: {RIDER}"
    assert holds.resume() == "the rider still holds the joystick"
    holds.rider = False
    assert holds.reason() == f"paused: {RIDER}"  # letting go is no resume
    holds.estop = STOP
    assert holds.reason() == f"held: {STOP}; paused: {RIDER}"
    assert holds.resume() == ""
    assert holds.reason() == f"held: {STOP}"  # the stop is not the pause's to end
    assert holds.resume() == "the mission is not paused"


def test_moved_counts_a_floor_change_as_far() -> None:
    a = Pose2D(1.0, 1.0, 0.0, "1")
    assert moved_m(a, Pose2D(4.0, 5.0, 2.0, "1")) == pytest.approx(5.0)
    assert moved_m(a, Pose2D(1.0, 1.0, 0.0, "2")) == math.inf
    assert moved_m(None, a) == 0.0


# -- the navigator -------------------------------------------------------------------------


def following(fleet: ScriptedFleet, path_id: str = "r.0") -> None:
    fleet.follow = FollowStatus(fleet.t, path_id, "following", 0.3, 2.0, 0.0)


def test_an_emergency_stop_holds_the_mission_past_its_limits_and_it_goes_on_when_cleared() -> None:
    fleet = ScriptedFleet(route(door()))
    nav, out = navigator(fleet, follow_timeout_s=30.0)
    nav.on_goal(NavGoal(0.0, "g1", place="room_b"))
    step(nav, fleet)
    assert fleet.commands == ["r.0"]
    following(fleet)
    nav.set_estop(STOP)
    for t in range(1, 121):  # two minutes held: four times the leg's limit
        fleet.t = float(t)
        status = step(nav, fleet)
        assert (status.state, status.reason) == ("running", f"held: {STOP}")
    assert fleet.commands == ["r.0", "stop"]
    assert ("hold", f"held: {STOP}") in fleet.events
    assert out.statuses[-1].reason == f"held: {STOP}"
    nav.set_estop("")
    fleet.follow = FollowStatus(fleet.t, "", "idle", 0.0, 0.0, 0.0)
    step(nav, fleet)
    assert fleet.commands[-1] == "r.0"  # the leg again, from where the chair stands
    assert fleet.events[-1][0] == "hold_over"
    for expected in (Phase.CORRECT, Phase.TURN, Phase.VERIFY):
        fleet.arrive()
        assert step(nav, fleet).phase == expected
    assert nav.status.state == "running"


def test_the_rider_pauses_the_mission_until_asked_to_resume() -> None:
    fleet = ScriptedFleet(route(door()))
    nav, out = navigator(fleet)
    nav.on_goal(NavGoal(0.0, "g1", place="room_b"))
    step(nav, fleet)
    following(fleet)
    nav.on_driver_status(rider(True))
    fleet.t = 1.0
    status = step(nav, fleet)
    assert (status.state, status.reason) == ("running", f"paused: {RIDER}")
    assert fleet.commands == ["r.0", "stop"]
    nav.on_resume(NavResume(1.5, "wheelnav resume (laptop)"))
    assert fleet.events[-1] == (
        "resume_refused",
        "asked by wheelnav resume (laptop): the rider still holds the joystick",
    )
    nav.on_driver_status(rider(False))  # the rider lets go: the mission stays paused
    for t in range(2, 30):
        fleet.t = float(t)
        assert step(nav, fleet).reason == f"paused: {RIDER}"
    assert fleet.commands == ["r.0", "stop"]
    nav.on_resume(NavResume(30.0, "wheelnav resume (laptop)", goal_id="g0"))
    assert fleet.events[-1][0] == "resume_refused" and "not the running one" in fleet.events[-1][1]
    nav.on_resume(NavResume(30.0, "wheelnav resume (laptop)", goal_id="g1"))
    assert fleet.events[-1] == ("resume", "mission g1 resumed by wheelnav resume (laptop)")
    fleet.t = 30.0
    status = step(nav, fleet)
    assert status.reason != f"paused: {RIDER}" and fleet.commands[-1] == "r.0"
    assert out.statuses[-1].state == "running"


def test_a_mission_started_while_the_rider_drives_starts_paused() -> None:
    fleet = ScriptedFleet(route(door()))
    nav, _out = navigator(fleet)
    nav.on_driver_status(rider(True))
    nav.on_goal(NavGoal(0.0, "g1", place="room_b"))
    status = step(nav, fleet)
    assert status.reason == f"paused: {RIDER}" and not fleet.route_requests


def test_driven_elsewhere_while_paused_the_route_is_planned_again_from_there() -> None:
    fleet = ScriptedFleet(route(door()))
    nav, _out = navigator(fleet)
    nav.on_goal(NavGoal(0.0, "g1", place="room_b"))
    step(nav, fleet)
    following(fleet)
    nav.on_driver_status(rider(True))
    step(nav, fleet)
    fleet.x, fleet.y = 3.0, 2.0  # the rider drove it into the next room
    nav.on_driver_status(rider(False))
    nav.on_resume(NavResume(5.0, "test"))
    fleet.t = 5.0
    status = step(nav, fleet)
    assert fleet.events[-1] == ("hold_over", "moved 3.6 m while held: planning again from here")
    assert len(fleet.route_requests) == 2  # from where it stands, to the same goal
    assert (status.state, status.action) == ("running", "Leg 0 (1/3)")  # the new route


def test_a_cancel_or_a_new_goal_ends_the_pause() -> None:
    fleet = ScriptedFleet(route(door()))
    nav, _out = navigator(fleet)
    nav.on_goal(NavGoal(0.0, "g1", place="room_b"))
    nav.on_driver_status(rider(True))
    step(nav, fleet)
    nav.on_goal(NavGoal(1.0, "", cancel=True))
    assert nav.status.state == "cancelled" and nav.holds.paused == ""
    nav.on_driver_status(rider(False))
    nav.on_goal(NavGoal(2.0, "g2", place="room_b"))
    status = step(nav, fleet)
    assert status.reason == "" and nav.holds.paused == "" and fleet.route_requests


def test_a_restarted_navigator_takes_a_paused_mission_up_paused(tmp_path) -> None:
    store = StateStore(tmp_path, "navigator")
    record = MissionRecord(5.0, "g1", None, "room_b", "running", "follow", [], paused=RIDER)
    assert MissionRecord.from_dict(record.to_dict()) == record
    store.save(record.to_dict())
    fleet = ScriptedFleet(route(door()))
    nav, _out = navigator(fleet)
    saver = Saver(nav, store, 30.0, logging.getLogger("test"))
    saver.take_up(6.0)
    fleet.t = 6.0
    status = step(nav, fleet)
    assert (status.goal_id, status.reason) == ("g1", f"paused: {RIDER}")
    assert "still paused" in fleet.events[0][1]
    saver.save(6.0)
    assert StateStore(tmp_path, "navigator").load()["paused"] == RIDER
