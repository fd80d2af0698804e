"""The mission trees ticked for real, against a scripted fleet (the trees are pure logic)."""

from __future__ import annotations

import numpy as np
import py_trees
from py_trees.common import Status

from behaviours.mission import create_plan_tree, create_route_tree
from shared.messages import (
    Checkpoint,
    DoorMode,
    FollowStatus,
    LiftDoor,
    LiftMotion,
    LiftState,
    Path,
    Pose2D,
    PoseEstimate,
    RouteReply,
)


class ScriptedFleet:
    """Answers route requests at once (or never); door modes and follow states as told."""

    def __init__(self, answer: RouteReply | None) -> None:
        self.t = 0.0
        self.answer = answer
        self.sent: list[Path] = []
        self.stops = 0
        self.follow: FollowStatus | None = None
        self.doors: dict[str, int] = {}
        self.door_requests: list[tuple[str, int]] = []
        self.lifts: dict[str, LiftState] = {}
        self.lift_requests: list[tuple[str, str]] = []
        self.released: list[str] = []
        self.floor: str | None = None
        self.scan_stamp = 0.0
        self.lidar = "open"

    def now(self) -> float:
        return self.t

    def request_route(self, goal, place, on_done) -> None:
        if self.answer is not None:
            on_done(self.answer, "")

    def send_path(self, path: Path) -> None:
        self.sent.append(path)

    def stop(self) -> None:
        self.stops += 1

    def follow_status(self) -> FollowStatus | None:
        return self.follow

    def pose(self) -> PoseEstimate | None:
        return PoseEstimate(self.t, Pose2D(0, 0, 0), np.eye(3))

    def door_mode(self, door_id: str) -> int | None:
        return self.doors.get(door_id)

    def request_door(self, door_id: str, mode: int) -> None:
        self.door_requests.append((door_id, mode))

    def lidar_door_state(self, x: float, y: float) -> tuple[float, str]:
        self.scan_stamp += 0.1
        return self.scan_stamp, self.lidar

    def lift_state(self, lift_id: str):
        return self.lifts.get(lift_id)

    def session_id(self) -> str:
        return "s1"

    def request_lift(self, lift_id: str, floor: str) -> None:
        self.lift_requests.append((lift_id, floor))

    def release_lift(self, lift_id: str) -> None:
        self.released.append(lift_id)

    def set_floor(self, floor: str) -> None:
        self.floor = floor

    def arrive(self) -> None:
        self.follow = FollowStatus(self.t, self.sent[-1].path_id, "arrived", 1.0, 0.0, 0.0)


def grow(root, fleet):
    tree = py_trees.trees.BehaviourTree(root)
    tree.setup(fleet=fleet)
    return tree


def blackboard():
    bb = py_trees.blackboard.Client(name="test", namespace="/mission")
    for key in ("goal", "place", "failure", "phase", "route", "blocked"):
        bb.register_key(key, access=py_trees.common.Access.WRITE)
    bb.goal, bb.place, bb.failure, bb.phase = None, "room_b", "", ""
    return bb


def leg(path_id: str) -> Path:
    return Path(0.0, path_id, "1", np.array([[0.0, 0.0], [1.0, 0.0]]), np.array([0.5, 0.0]))


def door(kind: str = "manual") -> Checkpoint:
    return Checkpoint(
        "door", "d1", "1", Pose2D(1, 0, 0, "1"), Pose2D(3.2, 0, 0, "1"), 2.2, kind, 1.0
    )


ROUTE = RouteReply(True, leg("r"), legs=[leg("r.0"), leg("r.1")], checkpoints=[door()])


def test_plan_tree_writes_the_route() -> None:
    bb = blackboard()
    fleet = ScriptedFleet(ROUTE)
    tree = grow(create_plan_tree(fleet.now, 5.0), fleet)
    tree.tick()
    assert tree.root.status == Status.SUCCESS and bb.route is ROUTE


def test_planner_refusal_stops_safely_with_its_reason() -> None:
    bb = blackboard()
    fleet = ScriptedFleet(RouteReply(False, None, "GOAL_OCCUPIED", "goal is inside a wall"))
    tree = grow(create_plan_tree(fleet.now, 5.0), fleet)
    tree.tick()
    assert tree.root.status == Status.FAILURE and fleet.stops == 1
    assert "GOAL_OCCUPIED" in bb.failure


def test_silent_planner_times_out_on_fleet_time() -> None:
    bb = blackboard()
    fleet = ScriptedFleet(None)
    tree = grow(create_plan_tree(fleet.now, 5.0), fleet)
    for t in range(5):
        fleet.t = float(t)
        tree.tick()
        assert tree.root.status == Status.RUNNING
    fleet.t = 5.5
    tree.tick()
    assert tree.root.status == Status.FAILURE
    assert bb.failure == "ComputeRoute: timed out after 5 s"


def test_route_waits_for_the_door_never_taking_unknown_for_open() -> None:
    blackboard()
    fleet = ScriptedFleet(None)
    tree = grow(create_route_tree(ROUTE, fleet.now, 100.0, 60.0, 0.2), fleet)
    tree.tick()
    assert fleet.sent[-1].path_id == "r.0"
    fleet.arrive()
    for mode in (None, DoorMode.UNKNOWN, DoorMode.CLOSED, DoorMode.MOVING):  # not open
        if mode is not None:
            fleet.doors["d1"] = mode
        fleet.t += 1
        tree.tick()
        assert fleet.sent[-1].path_id == "r.0" and tree.root.status == Status.RUNNING
    fleet.doors["d1"] = DoorMode.OPEN
    tree.tick()
    through = fleet.sent[-1]
    assert through.path_id == "r.door0" and np.allclose(through.waypoints[-1], (3.2, 0))
    assert through.v_ref[0] == 0.2
    fleet.arrive()
    tree.tick()
    assert fleet.sent[-1].path_id == "r.1"
    fleet.arrive()
    tree.tick()
    assert tree.root.status == Status.SUCCESS


def test_door_that_never_opens_times_out_and_stops() -> None:
    bb = blackboard()
    fleet = ScriptedFleet(None)
    tree = grow(create_route_tree(ROUTE, fleet.now, 100.0, 60.0, 0.2), fleet)
    tree.tick()
    fleet.arrive()
    tree.tick()
    fleet.t = 61.0
    tree.tick()
    assert tree.root.status == Status.FAILURE
    assert bb.failure == "WaitForDoorOpen d1: timed out after 60 s"
    assert fleet.sent[-1].path_id == "r.0"  # never drove towards the closed door


def test_powered_door_is_requested_open_then_released() -> None:
    blackboard()
    fleet = ScriptedFleet(None)
    route = RouteReply(True, leg("r"), legs=[leg("r.0"), leg("r.1")], checkpoints=[door("powered")])
    tree = grow(create_route_tree(route, fleet.now, 100.0, 60.0, 0.2), fleet)
    tree.tick()
    fleet.arrive()
    tree.tick()
    assert fleet.door_requests == [("d1", DoorMode.OPEN)]
    fleet.doors["d1"] = DoorMode.OPEN
    tree.tick()
    fleet.arrive()
    tree.tick()
    assert fleet.door_requests[-1] == ("d1", DoorMode.CLOSED)


def lift_at(floor: str, session: str = "s1", mode: int = 2) -> LiftState:
    return LiftState(
        0.0, "lift_a", ["1", "2"], floor, floor, LiftDoor.OPEN, LiftMotion.STOPPED, mode, session
    )


LIFT = Checkpoint(
    "elevator", "lift_a", "1", Pose2D(1, 0, 0, "1"), Pose2D(1, 0, 0, "2"), 2.6, to_floor="2"
)
LIFT_ROUTE = RouteReply(True, leg("r"), legs=[leg("r.0"), leg("r.1")], checkpoints=[LIFT])


def test_elevator_ride_follows_the_lift_protocol() -> None:
    blackboard()
    fleet = ScriptedFleet(None)
    tree = grow(create_route_tree(LIFT_ROUTE, fleet.now, 100.0, 60.0, 0.2), fleet)
    tree.tick()
    fleet.arrive()
    tree.tick()
    assert fleet.lift_requests == [("lift_a", "1")]
    fleet.lifts["lift_a"] = lift_at("1", session="someone-else")
    tree.tick()
    assert fleet.sent[-1].path_id == "r.0"  # busy: waits
    fleet.lifts["lift_a"] = lift_at("1")
    tree.tick()
    enter = fleet.sent[-1]
    assert enter.path_id == "r.lift0.in" and not enter.reverse
    assert np.allclose(enter.waypoints[-1], (1 + 2.6 - 0.205, 0))  # body centred in the car
    fleet.arrive()
    tree.tick()
    assert fleet.lift_requests[-1] == ("lift_a", "2")
    tree.tick()  # car still reported at floor 1: keeps waiting
    assert fleet.floor is None
    fleet.lifts["lift_a"] = lift_at("2")
    tree.tick()
    out = fleet.sent[-1]
    assert fleet.floor == "2" and out.reverse and out.floor == "2"
    assert np.allclose(out.waypoints[-1], (1, 0))
    fleet.arrive()
    tree.tick()
    assert fleet.released == ["lift_a"] and fleet.sent[-1].path_id == "r.1"


def test_lift_out_of_service_fails_and_names_it() -> None:
    bb = blackboard()
    bb.blocked = ""
    fleet = ScriptedFleet(None)
    tree = grow(create_route_tree(LIFT_ROUTE, fleet.now, 100.0, 60.0, 0.2), fleet)
    tree.tick()
    fleet.arrive()
    fleet.lifts["lift_a"] = lift_at("1", session="", mode=4)
    tree.tick()
    tree.tick()
    assert tree.root.status == Status.FAILURE
    assert bb.blocked == "lift_a" and "out of service" in bb.failure


def test_lidar_must_agree_in_three_scans_before_passing() -> None:
    blackboard()
    fleet = ScriptedFleet(None)
    cp = door()
    cp.centre = Pose2D(2.0, 0.0, 0.0, "1")
    route = RouteReply(True, leg("r"), legs=[leg("r.0"), leg("r.1")], checkpoints=[cp])
    tree = grow(create_route_tree(route, fleet.now, 100.0, 60.0, 0.2), fleet)
    tree.tick()
    fleet.arrive()
    fleet.doors["d1"] = DoorMode.OPEN  # the building says open ...
    fleet.lidar = "closed"  # ... the scans do not
    for _ in range(5):
        tree.tick()
    assert fleet.sent[-1].path_id == "r.0"
    fleet.lidar = "unknown"  # unknown is not open either
    tree.tick()
    fleet.lidar = "open"
    tree.tick()
    tree.tick()
    assert fleet.sent[-1].path_id == "r.0"  # two scans agree: not yet
    tree.tick()
    assert fleet.sent[-1].path_id == "r.door0"  # the third: go
