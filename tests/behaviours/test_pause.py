"""The pause gate over real mission trees, against the scripted fleet: an emergency stop or
the rider's pause holds the whole mission for as long as it lasts, no limit runs meanwhile,
and the mission goes on where it was."""

from __future__ import annotations

import py_trees
import pytest
from py_trees.common import Status

from behaviours.mission import EntryParams, create_plan_tree, create_route_tree
from behaviours.safety import PauseGate
from behaviours.timeouts import Timeout
from shared.config import NavigatorConfig
from shared.messages import Checkpoint, DoorMode, FollowStatus, Pose2D
from tests.behaviours.fleet_fake import ScriptedFleet, door, route
from tests.behaviours.test_mission_tree import blackboard, to_the_door

STOPPED = "held: emergency stop by test"


class Paused:
    """The gate's reason, set by the test."""

    def __init__(self) -> None:
        self.why = ""

    def __call__(self) -> str:
        return self.why


@pytest.fixture(autouse=True)
def fresh_blackboard():
    py_trees.blackboard.Blackboard.clear()
    yield
    py_trees.blackboard.Blackboard.clear()


def paused_route(
    fleet: ScriptedFleet, reason: Paused, cp: Checkpoint | None = None, **nav
) -> py_trees.trees.BehaviourTree:
    params = EntryParams(NavigatorConfig(**nav), 0.2, 0.76, 0.35)
    child = create_route_tree(route(cp or door()), fleet.now, params)
    root = PauseGate("Pause", child, reason, fleet.now)
    tree = py_trees.trees.BehaviourTree(root)
    tree.setup(fleet=fleet)
    return tree


def hold(tree, fleet: ScriptedFleet, seconds: float, step: float = 1.0) -> None:
    """Tick the held tree from now for ``seconds`` of fleet time: it stays RUNNING."""
    end = fleet.t + seconds
    while True:
        tree.tick()
        assert tree.root.status == Status.RUNNING
        if fleet.t >= end:
            return
        fleet.t += step


def test_a_hold_stops_the_chair_and_outlasts_every_limit_then_the_leg_goes_on() -> None:
    blackboard()
    fleet = ScriptedFleet(None)
    reason = Paused()
    tree = paused_route(fleet, reason, follow_timeout_s=30.0, safety_timeout_s=10.0)
    tree.tick()
    assert fleet.commands == ["r.0"]
    fleet.follow = FollowStatus(fleet.t, "r.0", "following", 0.3, 2.0, 0.0)
    fleet.t = 20.0
    tree.tick()
    reason.why = STOPPED
    fleet.follow = FollowStatus(fleet.t, "r.0", "estop", 0.3, 2.0, 0.0)  # unsafe, but held
    hold(tree, fleet, 100.0)  # past the leg's 30 s and the safety gate's 10 s
    assert fleet.events == [("hold", STOPPED)]
    assert tree.root.feedback_message == STOPPED
    assert fleet.commands == ["r.0", "stop"]  # nothing below was ticked
    reason.why = ""
    fleet.follow = FollowStatus(fleet.t, "", "idle", 0.0, 0.0, 0.0)
    tree.tick()
    assert fleet.commands == ["r.0", "stop", "stop", "r.0"]  # the leg sent again
    kind, detail = fleet.events[-1]
    assert kind == "hold_over" and detail.startswith("after 100.0 s (held: emergency stop")
    leg = next(b for b in tree.root.iterate() if isinstance(b, Timeout) and b.name == "Leg 0")
    assert leg.started == pytest.approx(100.0)  # began at 0, held 100 s: counts from 100
    fleet.t += 9.0  # 29 s of the leg's 30 s used, not counting the hold
    fleet.follow = FollowStatus(fleet.t, "r.0", "following", 0.5, 1.0, 0.0)
    tree.tick()
    assert tree.root.status == Status.RUNNING
    fleet.arrive()
    tree.tick()
    assert fleet.sent[-1].path_id == "Correct d1 #1"  # on to the door, where it was


def test_a_door_wait_does_not_count_the_hold() -> None:
    bb = blackboard()
    fleet = ScriptedFleet(None)
    reason = Paused()
    tree = paused_route(fleet, reason)
    to_the_door(tree, fleet)  # Phase 2 from t = 0: the door's 60 s wait
    fleet.t = 50.0
    tree.tick()
    reason.why = "paused: the rider took the joystick"
    hold(tree, fleet, 200.0)
    reason.why = ""
    tree.tick()
    fleet.t += 5.0
    tree.tick()  # 55 s of the wait used
    assert tree.root.status == Status.RUNNING and bb.blocked == ""
    fleet.t += 6.0
    tree.tick()
    assert tree.root.status == Status.FAILURE
    assert bb.failure == "door d1 did not open within 60 s" and bb.blocked == "d1"


def test_a_safety_spell_under_way_does_not_count_the_hold() -> None:
    bb = blackboard()
    fleet = ScriptedFleet(None)
    reason = Paused()
    tree = paused_route(fleet, reason, safety_timeout_s=10.0, max_recoveries=0)
    tree.tick()
    fleet.follow = FollowStatus(fleet.t, "r.0", "stale_scan", 0.2, 1.8, 0.0)
    fleet.t = 8.0
    tree.tick()  # held by the safety gate since t = 8
    fleet.t = 16.0
    tree.tick()
    reason.why = STOPPED
    hold(tree, fleet, 60.0)
    reason.why = ""
    tree.tick()
    fleet.t += 1.0
    tree.tick()  # 9 s of the spell's 10 s, not counting the 60 s held
    assert tree.root.status == Status.RUNNING
    fleet.t += 2.0
    tree.tick()
    assert tree.root.status == Status.FAILURE
    assert bb.failure == "safety stop (stale_scan) for more than 10 s"


def test_the_controller_holding_a_stop_the_navigator_does_not_know_is_unsafe() -> None:
    blackboard()
    fleet = ScriptedFleet(None)
    tree = paused_route(fleet, Paused())
    tree.tick()
    fleet.follow = FollowStatus(fleet.t, "r.0", "estop", 0.2, 1.8, 0.0)
    fleet.t = 1.0
    tree.tick()
    assert fleet.events == [("safety_stop", "estop")]


def test_a_hold_before_the_first_tick_holds_planning_too() -> None:
    bb = blackboard()
    fleet = ScriptedFleet(route(door()))
    reason = Paused()
    reason.why = STOPPED
    root = PauseGate("Pause", create_plan_tree(fleet.now, 5.0), reason, fleet.now)
    tree = py_trees.trees.BehaviourTree(root)
    tree.setup(fleet=fleet)
    hold(tree, fleet, 30.0)  # six times the plan's limit
    assert not fleet.route_requests and fleet.events == [("hold", STOPPED)]
    reason.why = ""
    tree.tick()
    assert tree.root.status == Status.SUCCESS and bb.route is fleet.answer
    assert fleet.events[-1] == ("hold_over", f"after 30.0 s ({STOPPED}): nothing was running again")


def test_a_door_seen_open_after_the_hold_needs_its_scans_again() -> None:
    blackboard()
    fleet = ScriptedFleet(None)
    reason = Paused()
    cp = door()
    cp.centre = Pose2D(2.0, 0.0, 0.0, "1")  # the LiDAR checks it too
    tree = paused_route(fleet, reason, cp, locate_door=False)
    to_the_door(tree, fleet)
    fleet.doors["d1"] = DoorMode.OPEN
    tree.tick()  # two of the three scans agree (the first came as Phase 2 began)
    assert not any(p.path_id == "r.door.d1" for p in fleet.sent)
    reason.why = STOPPED
    hold(tree, fleet, 5.0)
    reason.why = ""
    tree.tick()
    tree.tick()  # the wait started afresh: two scans again, not yet through
    assert not any(p.path_id == "r.door.d1" for p in fleet.sent)
    tree.tick()
    assert fleet.sent[-1].path_id == "r.door.d1"
