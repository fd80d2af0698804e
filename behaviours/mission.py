"""Mission trees: plan a route, then drive it leg by leg and door by door, or stop safely.

A mission runs two trees, one after the other (the second is built from the route the
first one got, as the seed's phase manager built its action list)::

    Plan (Selector, memory)            Route (Selector, memory)
    ├── PlanTimeout(ComputeRoute)      ├── Safety (SafetyGate: holds all below while unsafe)
    │                                  │   Drive (Sequence, memory)
    └── SafeStop                       │   ├── Leg 0: Timeout(FollowPath)
        ├── StopChair                  │   ├── Door <id> (Sequence, memory)
        └── MissionFailed              │   │   ├── Phase 0: Timeout(DockAt approach)   correct
                                       │   │   ├── Phase 1: Timeout(DockAt face exit)  turn
                                       │   │   ├── RequestDoor OPEN              (powered)
                                       │   │   ├── Phase 2: Timeout(WaitForDoorOpen    verify
                                       │   │   │            [|| IdleMotion: automatic])
                                       │   │   ├── Phase 3: Timeout(DriveThrough)      pass
                                       │   │   └── ReleaseDoor: close when clear (powered)
                                       │   ├── Leg 1 ...
                                       │   └── Elevator <id> (Sequence, memory)
                                       │       ├── Call car, Phase 0, Arrive (lift + LiDAR)
                                       │       ├── Enter, Call to floor, Ride (lift + LiDAR
                                       │       │   behind), SetFloor, Exit (reverse), Release
                                       └── SafeStop

Phase 4 (completion) is the door's Sequence succeeding. A door or lift whose wait times
out is named in ``/mission/blocked``: the navigator then plans around it.

Blackboard (namespace ``/mission``): ``goal`` (Pose2D or None), ``place`` (str),
``route`` (RouteReply), ``action`` (str), ``phase`` (:class:`~shared.messages.Phase`),
``failure`` (str), ``blocked`` (str), ``recover`` (str: the cause of a hold handed over
to the navigator's recoveries).

The route's steps (legs, doors, elevators) are the children of the sequence named
:data:`DRIVE`; :func:`route_steps` finds them in a route tree.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import py_trees
from py_trees.common import Access, Status

from behaviours.door import (
    DoorAsMapped,
    IdleMotion,
    LocateDoor,
    ReleaseDoor,
    RequestDoor,
    SmoothDoorPass,
    WaitForDoorOpen,
)
from behaviours.door_fix import DoorFix
from behaviours.elevator import ReleaseLift, RequestLift, SetFloor, WaitForLift
from behaviours.fleet import NS, FleetBehaviour
from behaviours.motion import DockAt, DriveThrough, FollowPath, StopChair
from behaviours.recovery import HandToRecoveries
from behaviours.safety import SafetyGate
from behaviours.timeouts import Timeout
from shared.config import FleetConfig, NavigatorConfig
from shared.messages import DoorMode, Path, Phase, Pose2D, RouteReply

DRIVE = "Drive"  # the route tree's sequence of steps


class ComputeRoute(FleetBehaviour):
    """Ask the planner for a route to the goal; RUNNING until it answers.

    Sends the request in ``initialise``, or once there is a pose estimate (the route
    starts from it; free running, a goal can come first): the time limit above bounds the
    wait. SUCCESS with ``/mission/route`` written when the planner returns a route;
    FAILURE with the planner's reason otherwise. Reads ``/mission/goal`` and
    ``/mission/place``.
    """

    phase = Phase.PLAN

    def __init__(self, name: str = "ComputeRoute") -> None:
        super().__init__(name)
        self.bb.register_key("goal", access=Access.READ)
        self.bb.register_key("place", access=Access.READ)
        self.bb.register_key("route", access=Access.WRITE)
        self._answer: tuple[RouteReply | None, str] | None = None

    def initialise(self) -> None:
        self.bb.phase = self.phase
        self._answer = None
        self._token = None
        self._request()

    def _request(self) -> None:
        """Ask the planner, once there is a pose estimate to start from."""
        if self.fleet.pose() is None:
            self.feedback_message = "waiting for a pose estimate"
            return
        self.feedback_message = "waiting for the planner"
        token = object()
        self._token = token

        def on_done(reply: RouteReply | None, error: str) -> None:
            if self._token is token:  # ignore answers to a cancelled request
                self._answer = (reply, error)

        self.fleet.request_route(self.bb.goal, self.bb.place, on_done)

    def update(self) -> Status:
        if self._token is None:
            self._request()
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


class MissionFailed(py_trees.behaviour.Behaviour):
    """Always FAILURE: the safe stop ran because navigation failed."""

    def update(self) -> Status:
        return Status.FAILURE


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


@dataclass(frozen=True)
class EntryParams:
    """What the door and elevator subtrees need to know: the navigator's config, the door
    speed and the chair's footprint (front and rear of the pose point)."""

    nav: NavigatorConfig
    door_speed: float
    front_m: float
    rear_m: float
    half_width_m: float = 0.325
    cruise_speed: float = 0.5

    @classmethod
    def from_config(cls, cfg: FleetConfig) -> EntryParams:
        """The navigator section, the planner's door and cruise speeds and the robot's
        footprint."""
        fp = cfg.robot.footprint
        pl = cfg.planner
        return cls(cfg.navigator, pl.door_speed, fp.front, fp.rear, fp.width / 2, pl.cruise_speed)

    @property
    def turn_radius_m(self) -> float:
        """How far the chair's corners reach from the pose point when it turns on the spot
        (about the rear axle), plus 5 cm."""
        return math.hypot(max(self.front_m, self.rear_m), self.half_width_m) + 0.05

    @property
    def centre_offset_m(self) -> float:
        """How far the footprint's centre lies ahead of the pose point (rear axle)."""
        return (self.front_m - self.rear_m) / 2


MANOEUVRE_TURN = math.radians(90)  # Phase 0 starting further round gets a manoeuvre's time


def _pass_timeout(distance_m: float, speed: float) -> float:
    return max(10.0, 4 * distance_m / speed)


def doorway(cp) -> np.ndarray | None:
    """The door checkpoint's opening as a segment (1, 4), for Phase 0 and 1 to count as a
    wall: a manoeuvre before a door must not turn in its doorway or go through it (campaign
    b6.m04 did, past the open leaf of the second of two doors in series). None for others."""
    if cp.kind != "door" or cp.centre is None or cp.width_m <= 0:
        return None
    h = cp.approach.theta
    ax, ay = -math.sin(h) * cp.width_m / 2, math.cos(h) * cp.width_m / 2
    cx, cy = cp.centre.x, cp.centre.y
    return np.array([[cx - ax, cy - ay, cx + ax, cy + ay]])


def _dock_at(
    name: str,
    phase: Phase,
    floor: str,
    target: tuple[float, float],
    heading: float | None,
    nav: NavigatorConfig,
    tolerance_deg: float,
    **kwargs,
) -> DockAt:
    """A :class:`DockAt` at the navigator's correction speed, tolerance, attempts and
    stall limit (``kwargs``: ``face``, ``keep_out``, ``fix``)."""
    return DockAt(
        name,
        phase,
        floor,
        target,
        heading,
        nav.correction_speed,
        nav.position_tolerance_m,
        tolerance_deg,
        nav.correction_attempts,
        nav.correction_stall_s,
        **kwargs,
    )


def _drive_s(nav: NavigatorConfig, reach_m: float) -> float:
    """The time a docking that also drives ``reach_m`` gets beyond its own limit: there
    and back at ``correction_speed`` and a manoeuvre's allowance (a tight room)."""
    return 2 * reach_m / nav.correction_speed + nav.manoeuvre_allowance_s


def _approach_dock(cp, nav: NavigatorConfig, name: str, fix: DoorFix | None = None) -> DockAt:
    """Dock at the checkpoint's approach pose facing its approach heading (Phase 0)."""
    a = cp.approach
    return _dock_at(
        name,
        Phase.CORRECT,
        cp.floor,
        (a.x, a.y),
        a.theta,
        nav,
        nav.heading_tolerance_deg,
        keep_out=doorway(cp),
        fix=fix,
    )


def _turn_to_exit(cp, nav: NavigatorConfig, name: str, fix: DoorFix | None = None) -> DockAt:
    """Turn on the spot to face the checkpoint's exit pose (Phase 1)."""
    a, e = cp.approach, cp.exit
    return _dock_at(
        name,
        Phase.TURN,
        cp.floor,
        (a.x, a.y),
        None,
        nav,
        nav.turn_tolerance_deg,
        face=(e.x, e.y),
        keep_out=doorway(cp),
        fix=fix,
    )


def _correct(
    cp,
    name: str,
    p: EntryParams,
    clock,
    record,
    reach_m: float = 0.0,
    handed: Callable[[], float] | None = None,
) -> py_trees.behaviour.Behaviour:
    """Phase 0: dock at the checkpoint's approach pose, checked against the tolerances;
    ``reach_m``: the leg it docks instead of following, whose drive (and a manoeuvre in a
    tight room, ``navigator.manoeuvre_allowance_s``) adds to the limit; ``handed()``: what
    the leg before left to it when it was held near its end (:class:`FollowPath`), which
    adds the same when it starts."""
    nav = p.nav
    dock = _approach_dock(cp, nav, f"Correct {cp.id}")
    limit = nav.correction_timeout_s
    if reach_m > 0:
        return _or_recover(
            Timeout(name, dock, limit + _drive_s(nav, reach_m), clock, record), dock, nav
        )

    def round_about() -> float:
        """Starting more than MANOEUVRE_TURN off the approach heading, a small room may
        need a manoeuvre (turns and short drives) to turn round: its allowance; taking
        over the end of a leg, that drive's time and the allowance."""
        left = handed() if handed is not None else 0.0
        if left > 0.0:
            return _drive_s(nav, left)
        return nav.manoeuvre_allowance_s if dock.heading_off_rad() > MANOEUVRE_TURN else 0.0

    return _or_recover(Timeout(name, dock, limit, clock, record, extra=round_about), dock, nav)


def _or_recover(
    step: py_trees.behaviour.Behaviour, dock: DockAt, nav: NavigatorConfig
) -> py_trees.behaviour.Behaviour:
    """``step`` (a bounded docking before a door or a lift) with the navigator's recoveries
    as its fallback (:class:`~behaviours.recovery.HandToRecoveries`), where there are
    any (``navigator.max_recoveries``)."""
    if nav.max_recoveries <= 0:
        return step
    hand_over = HandToRecoveries(f"{step.name}: recover", dock, nav.position_tolerance_m)
    return py_trees.composites.Selector(
        f"{step.name} or recover", memory=True, children=[step, hand_over]
    )


def _door_steps(
    cp,
    route_id: str,
    p: EntryParams,
    clock,
    record,
    reach_m: float = 0.0,
    handed: Callable[[], float] | None = None,
) -> py_trees.behaviour.Behaviour:
    """The seed's door entry: correct, turn to the exit, verify open, pass, done
    (``reach_m``, ``handed``: :func:`_correct`)."""
    nav = p.nav
    a, e = cp.approach, cp.exit
    centre = (cp.centre.x, cp.centre.y) if cp.centre else None
    turn = _turn_to_exit(cp, nav, f"Turn {cp.id}")
    steps: list[py_trees.behaviour.Behaviour] = [
        _correct(cp, f"Phase 0 {cp.id}", p, clock, record, reach_m, handed),
        Timeout(f"Phase 1 {cp.id}", turn, nav.correction_timeout_s, clock, record),
    ]
    building = cp.controller  # a door without a controller is verified by LiDAR alone
    if cp.door_type == "powered" and building:
        steps.append(RequestDoor(cp.id, DoorMode.OPEN))
    rocking = cp.door_type == "automatic" and nav.idle_motion

    def wait(again: str = "") -> py_trees.behaviour.Behaviour:
        """Phase 2: wait for the door to be seen open (rocking, so an automatic door's
        motion sensor fires), bounded; on timeout the door is named blocked."""
        if rocking:
            inner: py_trees.behaviour.Behaviour = py_trees.composites.Parallel(
                f"Open {cp.id}{again}",
                policy=py_trees.common.ParallelPolicy.SuccessOnOne(),
                children=[
                    WaitForDoorOpen(
                        cp.id,
                        centre,
                        nav.door_scans,
                        stop_on_start=False,
                        width_m=cp.width_m,
                        building=building,
                        fix=fix if again else None,
                    ),
                    IdleMotion(
                        cp.id, cp.floor, (a.x, a.y, a.theta), nav.idle_speed, nav.idle_amplitude_m
                    ),
                ],
            )
        else:
            inner = WaitForDoorOpen(
                cp.id,
                centre,
                nav.door_scans,
                width_m=cp.width_m,
                building=building,
                fix=fix if again else None,
            )
        says = f"door {cp.id} did not open within {nav.door_timeout_s:g} s"
        return Timeout(
            f"Phase 2 {cp.id}{again}",
            inner,
            nav.door_timeout_s,
            clock,
            _blocking(record, cp.id, says),
        )

    def through(again: str = "", closed_fails: bool = False) -> py_trees.behaviour.Behaviour:
        """Phase 3: the pass, bounded by the time its distance takes at the door speed."""
        drive = DriveThrough(
            f"Pass {cp.id}{again}",
            f"{route_id}.door.{cp.id}",
            Phase.PASS,
            cp.floor,
            (a.x, a.y),
            (e.x, e.y),
            p.door_speed,
            centre,
            p.front_m,
            door_id=cp.id if building else "",
            overrun_m=nav.pass_overrun_m,
            door_width_m=cp.width_m,
            closed_fails=closed_fails,
            fix=fix,
        )
        limit = _pass_timeout(cp.pass_distance_m, p.door_speed)
        return Timeout(f"Phase 3 {cp.id}{again}", drive, limit, clock, record)

    fix = DoorFix() if nav.locate_door and cp.centre is not None and cp.width_m > 0 else None
    steps.append(wait())
    if fix is not None:
        steps.append(_line_up(cp, p, clock, record, fix))
    if rocking and building:
        # an automatic door that closes while the chair stands before it (its hold time ran
        # out at the end of a long correction) opens again only for motion: wait again,
        # rocking, and pass once more
        again = py_trees.composites.Sequence(
            f"Again {cp.id}", memory=True, children=[wait(" again"), through(" again")]
        )
        steps.append(
            py_trees.composites.Selector(
                f"Pass {cp.id} or again",
                memory=True,
                children=[through(closed_fails=True), again],
            )
        )
    else:
        steps.append(through())
    if cp.door_type == "powered" and building:
        middle = cp.centre or Pose2D((a.x + e.x) / 2, (a.y + e.y) / 2, a.theta)
        steps.append(ReleaseDoor(cp.id, cp.floor, (middle.x, middle.y, middle.theta), cp.width_m))
    stop_turn_go = py_trees.composites.Sequence(f"Door {cp.id}", memory=True, children=steps)
    if not _smooth(cp, nav, reach_m):
        return stop_turn_go
    stop_turn_go.name = f"Stop-turn-go {cp.id}"
    smooth = _smooth_pass(cp, route_id, p)
    limit = _pass_timeout(float(smooth.path.door[4] + smooth.path.door[5]), p.door_speed)
    return py_trees.composites.Selector(
        f"Door {cp.id}",
        memory=True,
        children=[Timeout(f"Smooth {cp.id}", smooth, limit, clock, record), stop_turn_go],
    )


def _line_up(cp, p: EntryParams, clock, record, fix: DoorFix) -> py_trees.behaviour.Behaviour:
    """Once the door is seen open: find it in the scans (``fix``: its shift along the wall
    from the map) and, where it is not as mapped, dock at the moved approach pose and face
    the moved exit again."""
    nav, a = p.nav, cp.approach
    locate = LocateDoor(
        cp.id,
        fix,
        (cp.centre.x, cp.centre.y),
        a.theta,
        nav.locate_reach_m,
        2 * p.half_width_m,
        nav.locate_scans,
        nav.locate_min_shift_m,
        nav.locate_timeout_s,
    )
    dock = _approach_dock(cp, nav, f"Realign {cp.id}", fix)
    turn = _turn_to_exit(cp, nav, f"Turn again {cp.id}", fix)
    limit = nav.correction_timeout_s

    def sideways() -> float:
        """A door seen further along its wall than the position tolerance: the chair
        moves sideways, which a chair that cannot slide does by a manoeuvre (back, turn,
        forward: world-differs campaign b7000w.m08, 0.195 m, ran out of 20 s): its
        allowance."""
        shift = math.hypot(*fix.shift)
        return nav.manoeuvre_allowance_s if shift > nav.position_tolerance_m else 0.0

    realign = Timeout(f"Phase 0 again {cp.id}", dock, limit, clock, record, extra=sideways)
    again = py_trees.composites.Sequence(
        f"Realign {cp.id} on the door seen",
        memory=True,
        children=[
            _or_recover(realign, dock, nav),
            Timeout(f"Phase 1 again {cp.id}", turn, limit, clock, record),
        ],
    )
    return py_trees.composites.Sequence(
        f"Line up {cp.id}",
        memory=True,
        children=[
            locate,
            py_trees.composites.Selector(
                f"{cp.id} as mapped or realign",
                memory=True,
                children=[DoorAsMapped(cp.id, fix), again],
            ),
        ],
    )


def _smooth(cp, nav: NavigatorConfig, reach_m: float) -> bool:
    """True if ``cp`` is passed smoothly (``navigator.door_procedure``): a manual door with
    a known centre, after a leg that is followed (not docked: a series room)."""
    return (
        nav.door_procedure == "smooth"
        and cp.kind == "door"
        and cp.door_type == "manual"
        and cp.centre is not None
        and not reach_m
    )


def _smooth_pass(cp, route_id: str, p: EntryParams) -> SmoothDoorPass:
    """The smooth pass of door ``cp``: from its approach pose's line (where the curve
    joins the centre line) to its exit pose, at up to the cruise speed (the controller
    slows for the curve and the doorway)."""
    a, e, c = cp.approach, cp.exit, cp.centre
    n = (math.cos(a.theta), math.sin(a.theta))
    lead = max(0.0, (c.x - a.x) * n[0] + (c.y - a.y) * n[1])
    through = max(0.1, (e.x - c.x) * n[0] + (e.y - c.y) * n[1])
    # beside a leaf open beyond the door, the planned line (the free opening's middle) to
    # the left of the door's middle, facing through: the scan shows the jamb-to-jamb middle
    offset = (a.y - c.y) * n[0] - (a.x - c.x) * n[1] if cp.leaf_away else 0.0
    path = Path(
        0.0,
        f"{route_id}.smooth.{cp.id}",
        cp.floor,
        np.array([[a.x, a.y], [e.x, e.y]]),
        np.array([p.cruise_speed, 0.0]),
        precise=True,
        door=[c.x, c.y, a.theta, cp.width_m, lead, through, offset],
    )
    return SmoothDoorPass(
        cp.id,
        path,
        (c.x, c.y),
        a.theta,
        cp.width_m,
        p.front_m,
        p.rear_m,
        p.nav.door_scans,
        building=cp.controller,
        commit_m=p.nav.smooth_commit_m,
        hold_s=p.nav.smooth_hold_s,
    )


def _elevator_steps(
    cp,
    route_id: str,
    p: EntryParams,
    clock,
    record,
    reach_m: float = 0.0,
    riding: bool = False,
    handed: Callable[[], float] | None = None,
) -> py_trees.behaviour.Behaviour:
    """Call the car, correct, verify its door open, drive in, ride, switch floor, back out
    (LiDAR behind and lift state agreeing), release: the seed's phases on the lift protocol.
    ``riding``: the chair is in the car already (a restarted navigator): from sending the
    car to the floor on (``reach_m``, ``handed``: :func:`_correct`)."""
    nav = p.nav
    heading = np.array([np.cos(cp.approach.theta), np.sin(cp.approach.theta)])
    start = np.array([cp.approach.x, cp.approach.y])
    inside = start + heading * (cp.pass_distance_m - p.centre_offset_m)
    out = (cp.exit.x, cp.exit.y)
    door = (cp.centre.x, cp.centre.y) if cp.centre else None
    timeout = _pass_timeout(cp.pass_distance_m, p.door_speed)
    drive_in = DriveThrough(
        f"Drive into {cp.id}",
        f"{route_id}.lift.{cp.id}.in",
        Phase.ENTER,
        cp.floor,
        tuple(start),
        tuple(inside),
        p.door_speed,
        door,
        p.front_m,
        overrun_m=0.0,
        door_width_m=cp.width_m,
    )
    back_out = DriveThrough(
        f"Back out of {cp.id}",
        f"{route_id}.lift.{cp.id}.out",
        Phase.EXIT,
        cp.to_floor,
        tuple(inside),
        out,
        p.door_speed,
        door,
        p.rear_m,
        reverse=True,
        overrun_m=nav.pass_overrun_m,
        door_width_m=cp.width_m,
    )
    blocked = _blocking(
        record,
        cp.id,
        f"lift {cp.id} did not come to floor {cp.floor} within {nav.lift_timeout_s:g} s",
    )
    steps = [
        RequestLift(cp.id, cp.floor),
        _correct(cp, f"Phase 0 {cp.id}", p, clock, record, reach_m, handed),
        Timeout(
            f"Arrive {cp.id}",
            WaitForLift(cp.id, cp.floor, door, nav.door_scans, door_width_m=cp.width_m),
            nav.lift_timeout_s,
            clock,
            blocked,
        ),
        Timeout(f"Enter {cp.id}", drive_in, timeout, clock, record),
        RequestLift(cp.id, cp.to_floor),
        Timeout(
            f"Ride {cp.id}",
            WaitForLift(
                cp.id, cp.to_floor, door, nav.door_scans, Phase.RIDE, door_width_m=cp.width_m
            ),
            nav.lift_timeout_s,
            clock,
            record,
        ),
        SetFloor(cp.id, cp.to_floor),
        Timeout(f"Exit {cp.id}", back_out, timeout, clock, record),
        ReleaseLift(cp.id),
    ]
    if riding:
        steps = steps[4:]
    return py_trees.composites.Sequence(f"Elevator {cp.id}", memory=True, children=steps)


def _recovering() -> Callable[[str], None]:
    """The safety gate's hand-over: ``/mission/recover`` names the cause of the hold."""
    bb = py_trees.blackboard.Client(name="Recovering", namespace=NS)
    bb.register_key("recover", access=Access.WRITE)

    def on_recover(cause: str) -> None:
        bb.recover = cause

    return on_recover


def _blocking(
    record: Callable[[str], None], checkpoint_id: str, says: str
) -> Callable[[str], None]:
    """A timeout callback that records ``says`` (what did not happen, in words) and names
    the checkpoint as blocked (the navigator re-plans around it)."""
    bb = py_trees.blackboard.Client(name=f"Blocking {checkpoint_id}", namespace=NS)
    bb.register_key("blocked", access=Access.WRITE)

    def on_timeout(_reason: str) -> None:
        record(says)
        bb.blocked = checkpoint_id

    return on_timeout


def _leg_length(leg: Path) -> float:
    pts = np.asarray(leg.waypoints, float)
    return float(np.linalg.norm(np.diff(pts, axis=0), axis=1).sum()) if len(pts) > 1 else 0.0


# a leg at most this much longer than the line between its ends counts as straight; the
# planner's path in the room between two doors in series bends (b10.m00: 1.42)
STRAIGHT = 1.5


def _docked_instead(leg: Path, after_door: bool, nav) -> float:
    """The length of ``leg`` if it is left to the next checkpoint's position correction,
    else 0: a short one (``correction_reach_m``), or the room between two doors in series
    (after a door, straight and at most ``series_reach_m``; the path follower cannot turn
    in it, the correction's turn, drive and turn can)."""
    length = _leg_length(leg)
    if length < nav.correction_reach_m:
        return max(length, 1e-3)
    pts = np.asarray(leg.waypoints, float)
    line = float(np.linalg.norm(pts[-1] - pts[0])) if len(pts) > 1 else 0.0
    if after_door and length <= nav.series_reach_m and length <= STRAIGHT * line:
        return length
    return 0.0


def _end_dock(leg: Path, nav, name: str) -> DockAt | None:
    """Dock at the end of ``leg`` facing along its last segment, as Phase 0 docks (with
    manoeuvres where turning needs them); None for a leg of one point."""
    pts = np.asarray(leg.waypoints, float)
    if len(pts) < 2:
        return None
    (x0, y0), (x1, y1) = pts[-2], pts[-1]
    heading = math.atan2(y1 - y0, x1 - x0)
    target = (float(x1), float(y1))
    return _dock_at(name, Phase.FOLLOW, leg.floor, target, heading, nav, nav.heading_tolerance_deg)


def _last_leg(
    leg: Path, i: int, follow: py_trees.behaviour.Behaviour, nav, clock, record
) -> py_trees.behaviour.Behaviour:
    """The route's last leg when it starts at a door and is shorter than
    ``correction_reach_m``: docked first, followed if docking fails. Campaign b3002.m07:
    0.75 m from a door's exit pose beside a wall to the goal, the path follower found no
    way to turn there (blocked at once) and the recoveries' manoeuvres passed 3.8 cm from
    the wall."""
    dock = _end_dock(leg, nav, f"Dock leg {i}")
    if dock is None:
        return follow
    limit = nav.correction_timeout_s + _drive_s(nav, _leg_length(leg))
    docked = Timeout(f"Dock leg {i}", dock, limit, clock, record)
    return py_trees.composites.Selector(f"Leg {i}", memory=True, children=[docked, follow])


def _opens_early(cp) -> bool:
    """True if door ``cp`` is asked to open before the chair comes near it: a powered door
    whose leaf sweeps the approach pose (campaign b1005.m08: a leaf opening towards a
    chair that waited in a 2 m room between two doors swung into it)."""
    return cp.kind == "door" and cp.door_type == "powered" and cp.controller and cp.in_sweep


def create_route_tree(
    route: RouteReply,
    clock: Callable[[], float],
    params: EntryParams,
    riding_at: int = -1,
) -> py_trees.behaviour.Behaviour:
    """The second tree of a mission: drive the route's legs and pass its checkpoints in order.

    A leg shorter than ``navigator.correction_reach_m`` that ends at a checkpoint is left
    to that checkpoint's position correction (the seed's Phase 0 tests start 0.5 m from
    the approach pose, sometimes past it: the chair backs up rather than turning round),
    and so is the room between two doors in series (:func:`_docked_instead`).
    ``riding_at``: the index of a lift step (as :func:`route_steps` counts) the chair is
    in the car of already; the tree starts there, from sending the car to the floor.
    """
    record = _timeouts()
    nav = params.nav
    route_id = route.path.path_id if route.path is not None else "route"
    steps: list[py_trees.behaviour.Behaviour] = []
    door_at: dict[int, int] = {}  # checkpoint index -> its step's index
    for i, leg in enumerate(route.legs):
        cp = route.checkpoints[i] if i < len(route.checkpoints) else None
        after_door = i > 0 and route.checkpoints[i - 1].kind == "door"
        docked = _docked_instead(leg, after_door, nav) if cp is not None else 0.0
        if cp is not None and _opens_early(cp):
            # before the chair comes into the space its leaf sweeps: through the door
            # before it (two doors in series), else along this leg
            at = door_at[i - 1] if after_door else len(steps)
            steps.insert(at, RequestDoor(cp.id, DoorMode.OPEN, early=True))
            door_at = {k: v + (v >= at) for k, v in door_at.items()}
        if not docked:
            smooth = cp is not None and _smooth(cp, nav, docked)
            handover = nav.smooth_handover_m if smooth else 0.0
            reach = nav.correction_reach_m if cp is not None else 0.0
            follow = FollowPath(
                leg,
                f"Follow leg {i}",
                handover_m=handover,
                dock_within_m=reach,
                handover_heading=cp.approach.theta if smooth else None,
                handover_rad=math.radians(nav.smooth_handover_deg),
            )
            step = Timeout(f"Leg {i}", follow, nav.follow_timeout_s, clock, record)
            if cp is None and after_door and _leg_length(leg) < nav.correction_reach_m:
                step = _last_leg(leg, i, step, nav, clock, record)
            steps.append(step)
        if cp is None:
            continue
        handed = None if docked else follow.handed_m
        if cp.kind == "door":
            door_at[i] = len(steps)
            steps.append(_door_steps(cp, route_id, params, clock, record, docked, handed))
        else:
            riding = len(steps) == riding_at
            steps.append(
                _elevator_steps(cp, route_id, params, clock, record, docked, riding, handed)
            )
    if riding_at >= 0:
        if riding_at >= len(steps) or not steps[riding_at].name.startswith("Elevator "):
            raise ValueError(f"route step {riding_at} is not a lift")
        steps = steps[riding_at:]
    drive = py_trees.composites.Sequence(DRIVE, memory=True, children=steps)
    safety = SafetyGate(
        "Safety",
        drive,
        clock,
        nav.safety_timeout_s,
        record,
        recover_after_s=nav.recovery_wait_s if nav.max_recoveries > 0 else None,
        on_recover=_recovering(),
    )
    return py_trees.composites.Selector("Route", memory=True, children=[safety, _safe_stop()])


def route_steps(root: py_trees.behaviour.Behaviour) -> list[py_trees.behaviour.Behaviour]:
    """The steps of a route tree, in order (its legs, doors and elevators): the children of
    the sequence named :data:`DRIVE`. Empty for a tree without one (the plan tree)."""
    for b in root.iterate():
        if b.name == DRIVE and isinstance(b, py_trees.composites.Sequence):
            return list(b.children)
    return []
