"""The mission tree ticked for real, against a scripted fleet (the tree is pure logic)."""

from __future__ import annotations

import numpy as np
import py_trees
from py_trees.common import Status

from behaviours.mission import create_mission_tree
from shared.messages import FollowStatus, Path, Pose2D, PoseEstimate, RouteReply


class ScriptedFleet:
    """Answers route requests at once (or never) and reports follow states it is told."""

    def __init__(self, answer: RouteReply | None) -> None:
        self.t = 0.0
        self.answer = answer
        self.sent: list[Path] = []
        self.stops = 0
        self.follow: FollowStatus | None = None

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


def tree_with(fleet: ScriptedFleet, plan_timeout: float = 5.0, follow_timeout: float = 20.0):
    root = create_mission_tree(fleet.now, plan_timeout, follow_timeout)
    tree = py_trees.trees.BehaviourTree(root)
    tree.setup(fleet=fleet)
    bb = py_trees.blackboard.Client(name="test", namespace="/mission")
    for key in ("goal", "place", "failure", "phase"):
        bb.register_key(key, access=py_trees.common.Access.WRITE)
    bb.goal, bb.place, bb.failure, bb.phase = None, "room_b", "", ""
    return tree, bb


PATH = Path(0.0, "route-1", "1", np.array([[0.0, 0.0], [1.0, 0.0]]), np.array([0.5, 0.0]))


def test_plans_follows_and_succeeds() -> None:
    fleet = ScriptedFleet(RouteReply(True, PATH))
    tree, bb = tree_with(fleet)
    tree.tick()
    assert tree.root.status == Status.RUNNING and fleet.sent[0].path_id == "route-1"
    assert bb.phase == "follow"
    fleet.follow = FollowStatus(1.0, "route-1", "arrived", 1.0, 0.0, 0.0)
    tree.tick()
    assert tree.root.status == Status.SUCCESS


def test_planner_refusal_stops_safely_with_its_reason() -> None:
    fleet = ScriptedFleet(RouteReply(False, None, "GOAL_OCCUPIED", "goal is inside a wall"))
    tree, bb = tree_with(fleet)
    tree.tick()
    assert tree.root.status == Status.FAILURE
    assert fleet.stops == 1 and fleet.sent == []
    assert "GOAL_OCCUPIED" in bb.failure


def test_silent_planner_times_out_on_fleet_time() -> None:
    fleet = ScriptedFleet(None)
    tree, bb = tree_with(fleet, plan_timeout=5.0)
    for t in range(5):
        fleet.t = float(t)
        tree.tick()
        assert tree.root.status == Status.RUNNING
    fleet.t = 5.5
    tree.tick()
    assert tree.root.status == Status.FAILURE
    assert bb.failure == "ComputeRoute: timed out after 5 s"
    assert fleet.stops == 1


def test_follow_timeout_stops_the_chair() -> None:
    fleet = ScriptedFleet(RouteReply(True, PATH))
    tree, bb = tree_with(fleet, follow_timeout=10.0)
    tree.tick()
    fleet.t = 10.5
    tree.tick()
    assert tree.root.status == Status.FAILURE
    assert bb.failure == "FollowPath: timed out after 10 s"
    assert fleet.stops >= 1
