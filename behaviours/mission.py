"""Mission trees: plan a route, then drive it leg by leg and door by door, or stop safely.

A mission runs two trees, one after the other (the second is built from the route the
first one got, as the seed's phase manager built its action list)::

    Plan (Selector, memory)                 Route (Selector, memory)
    ├── Timeout(ComputeRoute)               ├── Drive (Sequence, memory)
    └── SafeStop                            │   ├── Timeout(FollowPath leg 0)
        ├── StopChair                       │   ├── Door <id> (Sequence, memory)
        └── MissionFailed                   │   │   ├── RequestDoor OPEN    (powered doors)
                                            │   │   ├── Timeout(WaitForDoorOpen)
                                            │   │   ├── Timeout(FollowPath through)
                                            │   │   └── RequestDoor CLOSED  (powered doors)
                                            │   ├── Timeout(FollowPath leg 1)
                                            │   └── ...
                                            └── SafeStop

Blackboard (namespace ``/mission``): ``goal`` (Pose2D or None), ``place`` (str),
``route`` (RouteReply), ``phase`` (str), ``action`` (str), ``failure`` (str).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import py_trees
from py_trees.common import Access, Status

from behaviours.elevator import ReleaseLift, RequestLift, SetFloor, WaitForLift
from behaviours.fleet import NS, FleetBehaviour
from behaviours.timeouts import Timeout
from shared.messages import DoorMode, Path, RouteReply


class ComputeRoute(FleetBehaviour):
    """Ask the planner for a route to the goal; RUNNING until it answers.

    Sends the request in ``initialise``. SUCCESS with ``/mission/route`` written when the
    planner returns a route; FAILURE with the planner's reason otherwise. Reads
    ``/mission/goal`` and ``/mission/place``.
    """

    phase = "plan"

    def __init__(self, name: str = "ComputeRoute") -> None:
        super().__init__(name)
        self.bb.register_key("goal", access=Access.READ)
        self.bb.register_key("place", access=Access.READ)
        self.bb.register_key("route", access=Access.WRITE)
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
        self.bb.route = reply
        doors = [c.id for c in reply.checkpoints]
        self.feedback_message = (
            f"route {reply.path.path_id}: {len(reply.legs)} legs, "
            f"checkpoints {', '.join(doors) or 'none'}"
        )
        return Status.SUCCESS

    def terminate(self, new_status: Status) -> None:
        self._token = None


class FollowPath(FleetBehaviour):
    """Send ``path`` to the controller and wait until it reports arrival.

    RUNNING while the controller follows; SUCCESS on ``arrived`` for this path. A controller
    that reports ``idle`` without this path (it was restarted) gets the path again. Never
    FAILURE itself: the timeout above it bounds the wait. ``terminate`` on pre-emption
    stops the chair.
    """

    phase = "follow"

    def __init__(
        self, path: Path, name: str = "", phase: str = "follow", door_id: str = ""
    ) -> None:
        super().__init__(name or f"Follow {path.path_id}")
        self.path = path
        self.phase = phase
        self.path_id = path.path_id
        self.door_id = door_id  # passing this door: pause while it is not reported OPEN
        self.sent_at = 0.0
        self.paused = False

    def initialise(self) -> None:
        self.bb.phase = self.phase
        self.sent_at = self.fleet.now()
        self.paused = False
        self.fleet.send_path(self.path)
        self.feedback_message = f"following {self.path_id}"

    def update(self) -> Status:
        if self.door_id:
            open_now = self.fleet.door_mode(self.door_id) == DoorMode.OPEN
            if not open_now and not self.paused:  # the door started to close: stop in it
                self.fleet.stop()
                self.paused = True
            if self.paused:
                if not open_now:
                    self.feedback_message = f"door {self.door_id} not open: holding"
                    return Status.RUNNING
                self.paused = False
                self.sent_at = self.fleet.now()
                self.fleet.send_path(self.path)
                return Status.RUNNING
        status = self.fleet.follow_status()
        restarted = (
            status is not None
            and status.state in ("idle", "no_pose")
            and status.path_id != self.path_id
            and status.stamp > self.sent_at
        )
        if restarted:  # a restarted controller has lost the path: send it again
            self.sent_at = self.fleet.now()
            self.fleet.send_path(self.path)
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


class StopChair(FleetBehaviour):
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


class RequestDoor(FleetBehaviour):
    """Send a DoorRequest (OPEN or CLOSED) for ``door_id``. Always SUCCESS at once."""

    def __init__(self, door_id: str, mode: int) -> None:
        word = "OPEN" if mode == DoorMode.OPEN else "CLOSED"
        super().__init__(f"Request {door_id} {word}")
        self.door_id, self.mode = door_id, mode

    def update(self) -> Status:
        self.fleet.request_door(self.door_id, self.mode)
        self.feedback_message = "requested"
        return Status.SUCCESS


class WaitForDoorOpen(FleetBehaviour):
    """RUNNING until the door is open by both accounts, then SUCCESS.

    The building must report ``door_id`` OPEN and, when ``centre`` is given, the LiDAR
    check (the seed's ROI method) must have said "open" in ``scans`` consecutive new
    scans. CLOSED, MOVING, OFFLINE, UNKNOWN, no report, and a LiDAR "unknown" are all "not
    open" (the seed took unknown for open). The timeout above it bounds the wait.
    """

    phase = "door"

    def __init__(
        self, door_id: str, centre: tuple[float, float] | None = None, scans: int = 3
    ) -> None:
        super().__init__(f"WaitForDoorOpen {door_id}")
        self.door_id = door_id
        self.centre = centre
        self.scans = scans
        self._agree = 0
        self._last_scan = -1.0

    def initialise(self) -> None:
        self.bb.phase = self.phase
        self._agree, self._last_scan = 0, -1.0
        self.fleet.stop()

    def update(self) -> Status:
        mode = self.fleet.door_mode(self.door_id)
        if self.centre is not None:
            stamp, seen = self.fleet.lidar_door_state(*self.centre)
            if stamp > self._last_scan:
                self._last_scan = stamp
                self._agree = self._agree + 1 if seen == "open" else 0
        lidar_ok = self.centre is None or self._agree >= self.scans
        if mode == DoorMode.OPEN and lidar_ok:
            self.feedback_message = "open"
            return Status.SUCCESS
        names = {0: "closed", 1: "moving", 3: "offline", 4: "unknown"}
        seen = f", LiDAR open in {self._agree}/{self.scans} scans" if self.centre else ""
        self.feedback_message = f"door {names.get(mode, 'not reported')}{seen}, waiting"
        return Status.RUNNING


def _timeouts() -> Callable[[str], None]:
    bb = py_trees.blackboard.Client(name="MissionTimeouts", namespace=NS)
    bb.register_key("failure", access=Access.WRITE)

    def record(reason: str) -> None:
        bb.failure = reason

    return record


def _safe_stop() -> py_trees.behaviour.Behaviour:
    return py_trees.composites.Sequence(
        "SafeStop", memory=True, children=[StopChair(), MissionFailed("MissionFailed")]
    )


def create_plan_tree(
    clock: Callable[[], float], plan_timeout_s: float
) -> py_trees.behaviour.Behaviour:
    """The first tree of a mission: ask for a route (the goal is on the blackboard)."""
    plan = Timeout("PlanTimeout", ComputeRoute(), plan_timeout_s, clock, _timeouts())
    return py_trees.composites.Selector("Plan", memory=True, children=[plan, _safe_stop()])


def straight_path(
    path_id: str,
    floor: str,
    a: tuple[float, float],
    b: tuple[float, float],
    speed: float,
    spacing: float = 0.25,
) -> Path:
    """A straight path from ``a`` to ``b`` at ``speed``, stopping at ``b``."""
    n = max(2, int(np.ceil(np.hypot(b[0] - a[0], b[1] - a[1]) / spacing)) + 1)
    pts = np.linspace(a, b, n)
    v = np.full(n, speed)
    v[-1] = 0.0
    return Path(0.0, path_id, floor, pts, v, precise=True)


def _door_steps(
    cp, i: int, route_id: str, clock, record, door_timeout_s: float, door_speed: float
) -> py_trees.behaviour.Behaviour:
    through = straight_path(
        f"{route_id}.door{i}",
        cp.floor,
        (cp.approach.x, cp.approach.y),
        (cp.exit.x, cp.exit.y),
        door_speed,
    )
    steps: list[py_trees.behaviour.Behaviour] = []
    if cp.door_type == "powered":
        steps.append(RequestDoor(cp.id, DoorMode.OPEN))
    steps += [
        Timeout(
            f"Door {cp.id} wait",
            WaitForDoorOpen(cp.id, (cp.centre.x, cp.centre.y) if cp.centre else None),
            door_timeout_s,
            clock,
            _blocking(record, cp.id),
        ),
        Timeout(
            f"Door {cp.id} pass",
            FollowPath(through, f"Pass {cp.id}", "door", door_id=cp.id),
            max(10.0, 4 * cp.pass_distance_m / door_speed),
            clock,
            record,
        ),
    ]
    if cp.door_type == "powered":
        steps.append(RequestDoor(cp.id, DoorMode.CLOSED))
    return py_trees.composites.Sequence(f"Door {cp.id}", memory=True, children=steps)


def _elevator_steps(
    cp,
    i: int,
    route_id: str,
    clock,
    record,
    lift_timeout_s: float,
    door_speed: float,
    centre_offset_m: float,
) -> py_trees.behaviour.Behaviour:
    """Call the car, drive in, ride, switch floor, back out, release (the seed's phases)."""
    heading = np.array([np.cos(cp.approach.theta), np.sin(cp.approach.theta)])
    start = np.array([cp.approach.x, cp.approach.y])
    inside = start + heading * (cp.pass_distance_m - centre_offset_m)
    out = np.array([cp.exit.x, cp.exit.y])
    drive_in = straight_path(
        f"{route_id}.lift{i}.in", cp.floor, tuple(start), tuple(inside), door_speed
    )
    back_out = straight_path(
        f"{route_id}.lift{i}.out", cp.to_floor, tuple(inside), tuple(out), door_speed
    )
    back_out.reverse = True
    blocked = _blocking(record, cp.id)
    steps = [
        RequestLift(cp.id, cp.floor),
        Timeout(
            f"Lift {cp.id} arrive", WaitForLift(cp.id, cp.floor), lift_timeout_s, clock, blocked
        ),
        Timeout(
            f"Lift {cp.id} enter",
            FollowPath(drive_in, f"Enter {cp.id}", "elevator"),
            max(10.0, 4 * cp.pass_distance_m / door_speed),
            clock,
            record,
        ),
        RequestLift(cp.id, cp.to_floor),
        Timeout(
            f"Lift {cp.id} ride", WaitForLift(cp.id, cp.to_floor), lift_timeout_s, clock, record
        ),
        SetFloor(cp.id, cp.to_floor),
        Timeout(
            f"Lift {cp.id} exit",
            FollowPath(back_out, f"Exit {cp.id}", "elevator"),
            max(10.0, 4 * cp.pass_distance_m / door_speed),
            clock,
            record,
        ),
        ReleaseLift(cp.id),
    ]
    return py_trees.composites.Sequence(f"Elevator {cp.id}", memory=True, children=steps)


def _blocking(record: Callable[[str], None], checkpoint_id: str) -> Callable[[str], None]:
    """A timeout callback that also names the checkpoint as blocked (the navigator re-plans)."""
    bb = py_trees.blackboard.Client(name=f"Blocking {checkpoint_id}", namespace=NS)
    bb.register_key("blocked", access=Access.WRITE)

    def on_timeout(reason: str) -> None:
        record(reason)
        bb.blocked = checkpoint_id

    return on_timeout


def create_route_tree(
    route: RouteReply,
    clock: Callable[[], float],
    follow_timeout_s: float,
    door_timeout_s: float,
    door_speed: float,
    lift_timeout_s: float = 120.0,
    centre_offset_m: float = 0.205,
) -> py_trees.behaviour.Behaviour:
    """The second tree of a mission: drive the route's legs and pass its checkpoints in order.

    ``centre_offset_m`` is how far the footprint's centre lies ahead of the pose reference
    point (rear axle), so the chair stops with its body centred in a lift car.
    """
    record = _timeouts()
    route_id = route.path.path_id if route.path is not None else "route"
    steps: list[py_trees.behaviour.Behaviour] = []
    for i, leg in enumerate(route.legs):
        steps.append(Timeout(f"Leg {i} timeout", FollowPath(leg), follow_timeout_s, clock, record))
        if i >= len(route.checkpoints):
            continue
        cp = route.checkpoints[i]
        if cp.kind == "door":
            steps.append(_door_steps(cp, i, route_id, clock, record, door_timeout_s, door_speed))
        else:
            steps.append(
                _elevator_steps(
                    cp, i, route_id, clock, record, lift_timeout_s, door_speed, centre_offset_m
                )
            )
    drive = py_trees.composites.Sequence("Drive", memory=True, children=steps)
    return py_trees.composites.Selector("Route", memory=True, children=[drive, _safe_stop()])
