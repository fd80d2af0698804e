"""The mission tree: plan a route, follow it under a timeout, and stop safely on failure.

    Mission (Selector, memory)
    ├── Navigate (Sequence, memory)
    │   ├── Timeout(ComputeRoute)
    │   └── Timeout(FollowPath)
    └── SafeStop (Sequence, memory)
        ├── StopChair
        └── MissionFailed

Blackboard (namespace ``/mission``): ``goal`` (Pose2D or None), ``place`` (str), ``path``
(Path), ``phase`` (str), ``failure`` (str). Later issues add door and elevator subtrees
between the route and the arrival; the wiring stays.
"""

from __future__ import annotations

from collections.abc import Callable

import py_trees
from py_trees.common import Access, Status

from behaviours.fleet import Fleet
from behaviours.timeouts import Timeout
from shared.messages import Path, RouteReply

NS = "/mission"


class _FleetBehaviour(py_trees.behaviour.Behaviour):
    """A behaviour that reaches the fleet through ``setup(fleet=...)`` and writes ``phase``."""

    phase = ""

    def __init__(self, name: str) -> None:
        super().__init__(name)
        self.fleet: Fleet | None = None
        self.bb = self.attach_blackboard_client(name=name, namespace=NS)
        self.bb.register_key("phase", access=Access.WRITE)
        self.bb.register_key("failure", access=Access.WRITE)

    def setup(self, **kwargs) -> None:
        if "fleet" not in kwargs:
            raise KeyError(f"{self.name}: setup needs fleet=<Fleet>")
        self.fleet = kwargs["fleet"]

    def fail(self, reason: str) -> Status:
        self.feedback_message = reason
        self.bb.failure = f"{self.name}: {reason}"
        return Status.FAILURE


class ComputeRoute(_FleetBehaviour):
    """Ask the planner for a route to the goal; RUNNING until it answers.

    Sends the request in ``initialise``. SUCCESS with ``/mission/path`` written when the
    planner returns a path; FAILURE with the planner's reason otherwise. Reads
    ``/mission/goal`` and ``/mission/place``.
    """

    phase = "plan"

    def __init__(self, name: str = "ComputeRoute") -> None:
        super().__init__(name)
        self.bb.register_key("goal", access=Access.READ)
        self.bb.register_key("place", access=Access.READ)
        self.bb.register_key("path", access=Access.WRITE)
        self._answer: tuple[RouteReply | None, str] | None = None

    def initialise(self) -> None:
        self.bb.phase = self.phase
        self._answer = None
        self.feedback_message = "waiting for the planner"
        token = object()
        self._token = token

        def on_done(reply: RouteReply | None, error: str) -> None:
            if self._token is token:  # ignore answers to a cancelled request
                self._answer = (reply, error)

        self.fleet.request_route(self.bb.goal, self.bb.place, on_done)

    def update(self) -> Status:
        if self._answer is None:
            return Status.RUNNING
        reply, error = self._answer
        if reply is None:
            return self.fail(error)
        if not reply.ok or reply.path is None:
            return self.fail(f"{reply.error_code}: {reply.error}")
        self.bb.path = reply.path
        self.feedback_message = f"route {reply.path.path_id}, {len(reply.path.waypoints)} waypoints"
        return Status.SUCCESS

    def terminate(self, new_status: Status) -> None:
        self._token = None


class FollowPath(_FleetBehaviour):
    """Send ``/mission/path`` to the controller and wait until it reports arrival.

    RUNNING while the controller follows; SUCCESS on ``arrived`` for this path. A controller
    that reports ``idle`` without this path (it was restarted) gets the path again. Never
    FAILURE itself: the timeout above it bounds the wait. ``terminate`` on pre-emption
    stops the chair.
    """

    phase = "follow"

    def __init__(self, name: str = "FollowPath") -> None:
        super().__init__(name)
        self.bb.register_key("path", access=Access.READ)
        self.path_id = ""
        self.sent_at = 0.0

    def initialise(self) -> None:
        self.bb.phase = self.phase
        path: Path = self.bb.path
        self.path_id = path.path_id
        self.sent_at = self.fleet.now()
        self.fleet.send_path(path)
        self.feedback_message = f"following {self.path_id}"

    def update(self) -> Status:
        status = self.fleet.follow_status()
        restarted = (
            status is not None
            and status.state in ("idle", "no_pose")
            and status.path_id != self.path_id
            and status.stamp > self.sent_at
        )
        if restarted:  # a restarted controller has lost the path: send it again
            self.sent_at = self.fleet.now()
            self.fleet.send_path(self.bb.path)
            self.feedback_message = f"controller idle: resent {self.path_id}"
            return Status.RUNNING
        if status is None or status.path_id != self.path_id:
            return Status.RUNNING
        self.feedback_message = (
            f"{status.state}: {100 * status.progress:.0f} %, {status.distance_to_goal:.2f} m to go"
        )
        return Status.SUCCESS if status.state == "arrived" else Status.RUNNING

    def terminate(self, new_status: Status) -> None:
        if new_status == Status.INVALID and self.fleet is not None:
            self.fleet.stop()


class StopChair(_FleetBehaviour):
    """Command the controller to drop its path (zero speed). Always SUCCESS at once."""

    phase = "stop"

    def __init__(self, name: str = "StopChair") -> None:
        super().__init__(name)

    def update(self) -> Status:
        self.bb.phase = self.phase
        self.fleet.stop()
        self.feedback_message = "chair stopped"
        return Status.SUCCESS


class MissionFailed(py_trees.behaviour.Behaviour):
    """Always FAILURE: the safe stop ran because navigation failed."""

    def update(self) -> Status:
        return Status.FAILURE


def create_mission_tree(
    clock: Callable[[], float], plan_timeout_s: float, follow_timeout_s: float
) -> py_trees.behaviour.Behaviour:
    """Build the mission tree (the goal is set on the blackboard by the navigator)."""
    bb = py_trees.blackboard.Client(name="MissionTimeouts", namespace=NS)
    bb.register_key("failure", access=Access.WRITE)

    def record(reason: str) -> None:
        bb.failure = reason

    plan = Timeout("PlanTimeout", ComputeRoute(), plan_timeout_s, clock, record)
    follow = Timeout("FollowTimeout", FollowPath(), follow_timeout_s, clock, record)
    navigate = py_trees.composites.Sequence("Navigate", memory=True, children=[plan, follow])
    safe_stop = py_trees.composites.Sequence(
        "SafeStop", memory=True, children=[StopChair(), MissionFailed("MissionFailed")]
    )
    return py_trees.composites.Selector("Mission", memory=True, children=[navigate, safe_stop])
