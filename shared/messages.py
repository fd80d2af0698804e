"""Message types exchanged between wheelnav services, each defined once.

Every type is a small dataclass with a wire tag (``TAG``) and a schema version
(``VERSION``). The codec in :mod:`shared.codec` checks every field against the type
hints below, so a message that decodes is a message the receiver can use: every number
is finite and inside its range (``num``: field metadata; a number without one still
within ``±DEFAULT_LIMIT``), and :meth:`Msg.validate` checks the fields together (lengths
that must agree, an order of two ticks). Encoding runs the same checks.

Conventions:
    * ``stamp`` is time in seconds on the fleet clock (simulation time in the
      simulator, the chair's clock on hardware).
    * Poses are of the rear-axle point, metres and radians, in the frame of the floor's map.
    * Arrays carry their shape in field metadata; ``None`` in a shape means "any length".
    * Door and lift fields follow Open-RMF's ``rmf_door_msgs`` / ``rmf_lift_msgs``.
"""

from __future__ import annotations

import math
from dataclasses import MISSING, dataclass, field
from enum import StrEnum
from typing import ClassVar

import numpy as np

REGISTRY: dict[str, type] = {}


def message(tag: str, version: int = 1):
    """Register a dataclass as a wire message with ``tag`` and schema ``version``."""

    def wrap(cls: type) -> type:
        if tag in REGISTRY:
            raise ValueError(f"message tag {tag!r} registered twice")
        cls.TAG = tag
        cls.VERSION = version
        REGISTRY[tag] = cls
        return cls

    return wrap


# Ranges (inclusive) of the numbers on the wire: generous physical limits, there to refuse
# nonsense (1e300 m/s, a coordinate beyond any building), not to judge a plan.
DEFAULT_LIMIT = 1e12  # any number without a range of its own: |value| <= this
STAMP = (0.0, 1e10)  # seconds: simulation time, or Unix time on a real chair
COORD = (-1e6, 1e6)  # metres on a floor's map (and in a sensor frame)
ANGLE = (-1e6, 1e6)  # radians (headings are usually wrapped; this only refuses nonsense)
SPEED = (-100.0, 100.0)  # m/s, forward speed
TURN = (-100.0, 100.0)  # rad/s
LENGTH = (0.0, 1e6)  # metres, not negative
SECONDS = (0.0, 1e10)  # a duration or a sum of them
COUNT = (0, 2**53)  # a count or a tick
INT_LIMIT = 2**53  # any integer without a range of its own: |value| <= this
MAX_TEXT = 1_000_000  # characters in any text field


def num(lo: float, hi: float, default: object = MISSING):
    """A number field (float or int) whose value must lie in ``[lo, hi]``."""
    return field(default=default, metadata={"range": (lo, hi)})


def array(
    dtype: str, shape: tuple[int | None, ...], limit: float | None = None, default_factory=None
):
    """A dataclass field holding a numpy array of a fixed dtype and shape pattern; with
    ``limit`` every element must satisfy ``|value| <= limit``."""
    meta = {"dtype": np.dtype(dtype), "shape": shape, "limit": limit}
    if default_factory is not None:
        return field(default_factory=default_factory, metadata=meta)
    return field(metadata=meta)


class Invalid(ValueError):
    """Raised by :meth:`Msg.validate`: fields that disagree, named (``"v_ref: ..."``)."""

    def __init__(self, field_name: str, why: str) -> None:
        super().__init__(f"{field_name}: {why}")


def _same_length(name: str, values, of: str, n: int, unit: str) -> None:
    if len(values) != n:
        raise Invalid(name, f"{len(values)} value(s) for {n} {unit}")


class Msg:
    """Base of all messages (only for typing: ``TAG`` and ``VERSION`` are set by ``message``)."""

    TAG: ClassVar[str]
    VERSION: ClassVar[int]

    def validate(self) -> None:
        """Check the fields together (each field is already checked on its own by the
        codec); raise :class:`Invalid` naming the first field that disagrees."""


# --------------------------------------------------------------------------------------
# Geometry and motion
# --------------------------------------------------------------------------------------


@message("pose2d")
@dataclass
class Pose2D(Msg):
    """A planar pose on a named floor."""

    x: float = num(*COORD)
    y: float = num(*COORD)
    theta: float = num(*ANGLE)
    floor: str = ""


@message("twist")
@dataclass
class Twist(Msg):
    """A velocity command for the chair: forward speed ``v`` (m/s), turn rate ``w`` (rad/s)."""

    stamp: float = num(*STAMP)
    v: float = num(*SPEED)
    w: float = num(*TURN)


@message("odometry")
@dataclass
class Odometry(Msg):
    """Wheel odometry: the pose integrated from the wheels (drifts) and the measured speeds."""

    stamp: float = num(*STAMP)
    pose: Pose2D
    v: float = num(*SPEED)
    w: float = num(*TURN)
    frame: str = "odom"


@message("driver_status")
@dataclass
class DriverStatus(Msg):
    """The chair driver's view of the base: battery (%), speed mode and error code as the
    chair reports them, whether the rider holds the joystick (the driver has handed the
    chair to them) and whether the serial link is up (port open, data arriving)."""

    stamp: float = num(*STAMP)
    battery_percent: int = num(0, 100)
    speed_mode: int = num(0, 255)
    error_code: int = num(0, 255)
    joystick_active: bool = False
    serial_ok: bool = False


@message("pose_estimate")
@dataclass
class PoseEstimate(Msg):
    """The localisation's pose on the current floor's map, with covariance (x, y, theta)."""

    stamp: float = num(*STAMP)
    pose: Pose2D
    covariance: np.ndarray = array("float64", (3, 3))
    lost: bool = False


@message("point_cloud")
@dataclass
class PointCloud(Msg):
    """Points in the sensor frame (x forward, y left, z up), metres, float32."""

    stamp: float = num(*STAMP)
    frame: str
    points: np.ndarray = array("float32", (None, 3), limit=COORD[1])


@message("path", version=5)
@dataclass
class Path(Msg):
    """Waypoints (x, y) on one floor and the reference speed at each (m/s, 0 at the goal).

    ``reverse``: drive it backwards (out of a lift car, where the chair cannot turn).
    ``precise``: a short, straight pass through a door or into a car: track it exactly.
    ``zones``: a tag per waypoint (room, corridor, door, goal), empty if unknown.
    ``dock_heading``: set, the path is a docking manoeuvre to its last waypoint, ending
    facing this heading (position correction before a door, idle motion); ``v_ref[0]``
    caps its speed. See services/controller/docking.py.
    ``keep_out``: segments (x1, y1, x2, y2) a docking manoeuvre counts as walls: the
    doorway of the door it docks before, which it must not turn in nor go through.
    ``door``: set, the path is a smooth pass through a door, [x, y, heading, width_m,
    lead_m, through_m] and optionally offset_m: the mapped door centre, the heading
    through it, its width, where the curve joins the centre line (``lead_m`` before the
    plane) and where the pass ends (``through_m`` past it), and how far to the left of the
    doorway's middle (facing through it) the pass runs (a hinged leaf standing open beyond
    the door takes part of the opening the scan does not show; 0 if absent); the
    controller steers onto the door it sees in the scan
    (services/controller/smooth_pass.py), at up to ``v_ref[0]``; the waypoints are the
    pass as planned (approach to exit pose).
    """

    stamp: float = num(*STAMP)
    path_id: str
    floor: str
    waypoints: np.ndarray = array("float64", (None, 2), limit=COORD[1])
    v_ref: np.ndarray = array("float64", (None,), limit=SPEED[1])
    reverse: bool = False
    precise: bool = False
    zones: list[str] = field(default_factory=list)
    dock_heading: float | None = num(*ANGLE, default=None)
    keep_out: np.ndarray = array(
        "float64", (None, 4), limit=COORD[1], default_factory=lambda: np.zeros((0, 4))
    )
    door: list[float] = field(default_factory=list)

    def validate(self) -> None:
        n = len(self.waypoints)
        if self.door and (
            len(self.door) not in (6, 7) or not all(math.isfinite(v) for v in self.door)
        ):
            raise Invalid(
                "door",
                f"{len(self.door)} value(s): [x, y, heading, width, lead, through(, offset)]",
            )
        if len(self.door) == 7 and abs(self.door[6]) > self.door[3] / 2:
            raise Invalid("door", "offset must be within half the door's width")
        if self.door and (self.door[3] < 0 or self.door[4] < 0 or self.door[5] <= 0):
            raise Invalid("door", "width and lead must be >= 0, through > 0 (metres)")
        if self.door and n == 0:
            raise Invalid("door", "a door pass needs its waypoints")
        _same_length("v_ref", self.v_ref, "waypoints", n, "waypoint(s)")
        if self.zones:
            _same_length("zones", self.zones, "waypoints", n, "waypoint(s)")
        if self.dock_heading is not None and n == 0:
            raise Invalid("dock_heading", "a docking path needs a waypoint")


# --------------------------------------------------------------------------------------
# Time
# --------------------------------------------------------------------------------------


@message("clock")
@dataclass
class Clock(Msg):
    """Fleet time: published by the simulator after every step (tick ``tick`` of length ``dt``).

    In lockstep one tick is announced once per ``stage`` (see shared/lockstep.py); stage 0 is
    always sent, so listeners that only want the time take stage 0.
    """

    stamp: float = num(*STAMP)
    tick: int = num(*COUNT)
    dt: float = num(1e-6, 3600.0)
    stage: int = num(0, 1000, default=0)


@message("ack", version=2)
@dataclass
class Ack(Msg):
    """A lockstep participant has answered ``tick`` and will answer next at ``next_tick``;
    its step took ``compute_s`` seconds of wall time (for the lockstep profile)."""

    participant: str
    tick: int = num(*COUNT)
    next_tick: int = num(*COUNT)
    # a measurement, not identity
    compute_s: float = field(default=0.0, compare=False, metadata={"range": SECONDS})

    def validate(self) -> None:
        if self.next_tick <= self.tick:
            raise Invalid("next_tick", f"{self.next_tick} is not after tick {self.tick}")


@message("lockstep_profile")
@dataclass
class LockstepProfile(Msg):
    """Where the simulator's wall time went since the clock started (cumulative sums, s).

    Per tick: the simulator's own step (``physics_s``), its publishing, each lockstep
    stage from announcing the tick to the last answer (``stage_wait_s``, one per stage) and
    its pacing; per participant, the wall time of its steps and how many it took.
    """

    stamp: float = num(*STAMP)
    dt: float = num(1e-6, 3600.0)
    ticks: int = num(*COUNT)
    wall_s: float = num(*SECONDS)
    physics_s: float = num(*SECONDS)
    publish_s: float = num(*SECONDS)
    pacing_s: float = num(*SECONDS)
    stage_wait_s: list[float] = field(default_factory=list)
    participants: list[str] = field(default_factory=list)
    compute_s: list[float] = field(default_factory=list)
    steps: list[int] = field(default_factory=list)

    def validate(self) -> None:
        n = len(self.participants)
        _same_length("compute_s", self.compute_s, "participants", n, "participant(s)")
        _same_length("steps", self.steps, "participants", n, "participant(s)")


# --------------------------------------------------------------------------------------
# Building: doors and lifts (Open-RMF's fields)
# --------------------------------------------------------------------------------------


class DoorMode:
    """``rmf_door_msgs/DoorMode`` values."""

    CLOSED = 0
    MOVING = 1
    OPEN = 2
    OFFLINE = 3
    UNKNOWN = 4


@message("door_state")
@dataclass
class DoorState(Msg):
    """The current mode of one door (a ``DoorMode`` value)."""

    stamp: float = num(*STAMP)
    door_name: str
    current_mode: int = num(DoorMode.CLOSED, DoorMode.UNKNOWN)


@message("door_request")
@dataclass
class DoorRequest(Msg):
    """Ask a door to open or close on behalf of ``requester_id`` (a ``DoorMode`` value)."""

    stamp: float = num(*STAMP)
    requester_id: str
    door_name: str
    requested_mode: int = num(DoorMode.CLOSED, DoorMode.UNKNOWN)


class LiftRequestType:
    """``rmf_lift_msgs/LiftRequest`` request types."""

    END_SESSION = 0
    AGV_MODE = 1
    HUMAN_MODE = 2


class LiftDoor:
    """``rmf_lift_msgs`` door states."""

    CLOSED = 0
    MOVING = 1
    OPEN = 2


class LiftMode:
    """``rmf_lift_msgs/LiftState`` modes; ``UNUSABLE``: a car no robot may be sent to."""

    UNKNOWN = 0
    HUMAN = 1
    AGV = 2
    FIRE = 3
    OFFLINE = 4
    EMERGENCY = 5
    UNUSABLE = (FIRE, OFFLINE, EMERGENCY)


class LiftMotion:
    """``rmf_lift_msgs/LiftState`` motion states."""

    STOPPED = 0
    UP = 1
    DOWN = 2
    UNKNOWN = 3


@message("lift_state")
@dataclass
class LiftState(Msg):
    """The state of one lift: where the car is, where it goes, its door, who holds it."""

    stamp: float = num(*STAMP)
    lift_name: str
    available_floors: list[str]
    current_floor: str
    destination_floor: str
    door_state: int = num(LiftDoor.CLOSED, LiftDoor.OPEN)
    motion_state: int = num(LiftMotion.STOPPED, LiftMotion.UNKNOWN)
    current_mode: int = num(0, 5)  # rmf_lift_msgs/LiftState MODE_UNKNOWN .. MODE_EMERGENCY
    session_id: str


@message("lift_request")
@dataclass
class LiftRequest(Msg):
    """Open or end a lift session, and send the car to ``destination_floor``."""

    stamp: float = num(*STAMP)
    lift_name: str
    session_id: str
    request_type: int = num(LiftRequestType.END_SESSION, LiftRequestType.HUMAN_MODE)
    destination_floor: str
    door_state: int = num(LiftDoor.CLOSED, LiftDoor.OPEN)


# --------------------------------------------------------------------------------------
# Planning, control and mission
# --------------------------------------------------------------------------------------


@message("building_bodies")
@dataclass
class BuildingBodies(Msg):
    """Simulation only: how far each door is open and where each lift car and its doors are,
    for the simulator to move the bodies (a real building moves its own)."""

    stamp: float = num(*STAMP)
    doors: list[str]
    door_openings: np.ndarray = array("float64", (None,), limit=COORD[1])
    lifts: list[str] = field(default_factory=list)
    car_elevations: np.ndarray = array(
        "float64", (None,), limit=COORD[1], default_factory=lambda: np.zeros(0)
    )
    lift_door_openings: np.ndarray = array(
        "float64", (None,), limit=COORD[1], default_factory=lambda: np.zeros(0)
    )

    def validate(self) -> None:
        _same_length("door_openings", self.door_openings, "doors", len(self.doors), "door(s)")
        n = len(self.lifts)
        _same_length("car_elevations", self.car_elevations, "lifts", n, "lift(s)")
        _same_length("lift_door_openings", self.lift_door_openings, "lifts", n, "lift(s)")


@message("route_request", version=3)
@dataclass
class RouteRequest(Msg):
    """Ask the planner for a route from ``start`` to ``goal`` or to the named ``place``,
    avoiding the doors and lifts named in ``avoid`` (ones that failed this mission), the
    points in ``blocked`` (what held the chair, marked by a recovery; map frame, floor)
    and, where another way exists, the points in ``untraversed`` (v3: the stretch of a
    leg the chair was held on, a gap it could not enter; dropped first when they shut
    every way)."""

    start: Pose2D
    goal: Pose2D | None = None
    place: str = ""
    avoid: list[str] = field(default_factory=list)
    blocked: list[Pose2D] = field(default_factory=list)
    stamp: float = num(*STAMP, default=0.0)  # the asker's clock: unavailable marks expire
    untraversed: list[Pose2D] = field(default_factory=list)


@message("checkpoint", version=3)
@dataclass
class Checkpoint(Msg):
    """A door or elevator between two legs of a route, with the poses to drive to.

    Door: ``approach`` on the door's normal at the standoff, facing the door; ``exit`` on the
    far side with the same heading; ``pass_distance_m`` between them. Elevator: ``approach``
    outside the car door on ``floor`` facing into the car; ``exit`` outside the car door on
    ``to_floor``; ``pass_distance_m`` from the approach to the car centre.
    """

    kind: str
    id: str
    floor: str
    approach: Pose2D
    exit: Pose2D
    pass_distance_m: float = num(*LENGTH)
    door_type: str = ""
    width_m: float = num(*LENGTH, default=0.0)
    to_floor: str = ""
    centre: Pose2D | None = None  # the door's (or car door's) middle, heading = approach's
    controller: bool = True  # the building reports this door (False: verified by LiDAR alone)
    # the approach pose lies in the sweep of the door's hinged leaf (it opens towards the
    # chair and the space before it is too shallow to wait behind it): a powered door is
    # asked to open before the chair comes into that space
    in_sweep: bool = False
    # a hinged leaf stands open beyond the door (it swings away from the chair): the
    # doorway a scan shows runs jamb to jamb, the free opening is beside the leaf
    leaf_away: bool = False


@message("route_reply", version=3)
@dataclass
class RouteReply(Msg):
    """The planner's answer: legs joined by checkpoints, or an error code and a reason.

    ``path`` is the whole route on the start floor as one path (the legs joined through
    the doors), for a follower that does not handle checkpoints itself.
    """

    ok: bool
    path: Path | None = None
    error_code: str = ""
    error: str = ""
    legs: list[Path] = field(default_factory=list)
    checkpoints: list[Checkpoint] = field(default_factory=list)


@message("availability")
@dataclass
class Availability(Msg):
    """Mark a door or elevator unavailable to the planner (or available again), and why."""

    stamp: float = num(*STAMP)
    name: str
    available: bool
    reason: str = ""

    def validate(self) -> None:
        if not self.name:
            raise Invalid("name", "empty (which door or elevator?)")


@message("follow_status", version=2)
@dataclass
class FollowStatus(Msg):
    """The controller's progress along the current path (``state``: idle/following/arrived).

    ``precise``: the path is a precise pass or a docking manoeuvre, not a leg (reports
    keep the cross-track error of legs apart).
    """

    stamp: float = num(*STAMP)
    path_id: str
    state: str
    progress: float = num(*LENGTH)
    distance_to_goal: float = num(*LENGTH)
    cross_track: float = num(*COORD)
    precise: bool = False


@message("nav_goal")
@dataclass
class NavGoal(Msg):
    """Start a mission to a pose or a named place; ``cancel`` stops the running one."""

    stamp: float = num(*STAMP)
    goal_id: str
    goal: Pose2D | None = None
    place: str = ""
    cancel: bool = False

    def validate(self) -> None:
        if not self.cancel and self.goal is None and not self.place:
            raise Invalid("goal", "neither a goal pose nor a place (and not a cancel)")


@message("nav_resume")
@dataclass
class NavResume(Msg):
    """Resume the mission the rider paused by taking the joystick (``goal_id`` empty: the
    running one); ``source`` says who asked, for the log."""

    stamp: float = num(*STAMP)
    source: str = ""
    goal_id: str = ""


# --------------------------------------------------------------------------------------
# Emergency stop
# --------------------------------------------------------------------------------------


@message("emergency_stop")
@dataclass
class EmergencyStop(Msg):
    """Set (``active``) or clear the emergency stop that every layer obeys: the controller
    zeroes its command, the driver (or the simulator) stops the chair, the navigator holds
    the mission. ``stamp`` is the sender's clock, for the log only (never compared with a
    receiver's); ``source`` says who sent it and ``reason`` why."""

    stamp: float = num(*STAMP)
    active: bool
    source: str = ""
    reason: str = ""


@message("emergency_stop_query")
@dataclass
class EmergencyStopQuery(Msg):
    """Ask a service that obeys the emergency stop which one it holds (the reply is the
    :class:`EmergencyStop` it last received); ``asker`` names who asks, for the log."""

    asker: str = ""


class Phase(StrEnum):
    """What the mission is doing (``NavStatus.phase``; on the wire it is the plain string).

    Door entry: correct, turn, verify, pass (the seed's Phases 0-3). Elevator entry:
    elevator (a request sent), call (waiting for the car), enter, ride, exit. Recover: back
    up and turn in place after a hold (behaviours/recovery.py).
    """

    IDLE = ""
    PLAN = "plan"
    FOLLOW = "follow"
    STOP = "stop"
    CORRECT = "correct"
    TURN = "turn"
    VERIFY = "verify"
    PASS = "pass"
    ELEVATOR = "elevator"
    CALL = "call"
    ENTER = "enter"
    RIDE = "ride"
    EXIT = "exit"
    RECOVER = "recover"


@message("nav_status")
@dataclass
class NavStatus(Msg):
    """The navigator's mission state: idle/running/succeeded/failed/cancelled and why."""

    stamp: float = num(*STAMP)
    goal_id: str
    state: str
    action: str = ""
    phase: str = ""  # a Phase value
    reason: str = ""
    progress: float = num(*LENGTH, default=0.0)


TERMINAL_STATES = ("succeeded", "failed", "cancelled")  # NavStatus.state once a mission ended


@message("tree_node")
@dataclass
class TreeNode(Msg):
    """One behaviour of a tree snapshot: its place, kind, status and feedback."""

    id: int = num(*COUNT)
    parent: int = num(-1, COUNT[1])  # -1 for the root
    name: str
    kind: str  # Sequence, Selector, decorator or leaf class name
    status: str  # SUCCESS, FAILURE, RUNNING, INVALID
    feedback: str = ""


@message("tree_snapshot")
@dataclass
class TreeSnapshot(Msg):
    """The navigator's behaviour tree after a tick (as py_trees_ros streams it)."""

    stamp: float = num(*STAMP)
    goal_id: str
    tree: str
    nodes: list[TreeNode] = field(default_factory=list)

    def validate(self) -> None:
        ids: set[int] = set()
        for i, node in enumerate(self.nodes):
            if node.id in ids:
                raise Invalid(f"nodes[{i}].id", f"{node.id} appears twice")
            ids.add(node.id)
        for i, node in enumerate(self.nodes):
            if node.parent != -1 and node.parent not in ids:
                raise Invalid(f"nodes[{i}].parent", f"no node {node.parent} in the snapshot")


@message("event")
@dataclass
class Event(Msg):
    """Something worth a line in the log and the report (collision, fallback, restart...)."""

    stamp: float = num(*STAMP)
    source: str
    kind: str
    detail: str = ""
    severity: str = "info"


@message("door_clearance")
@dataclass
class DoorClearance(Msg):
    """The smallest clearance the simulator measured while the chair was in one opening:
    what it was to (``nearest``: "wall", "door X", ...), where the chair stood then (true
    pose [x, y, theta]), the opening's clear width (``free_width_m``: less half a hinged
    leaf's thickness, which stands in it open; 0: as ``width_m``) and whether the chair's
    centre stood in the doorway (``entered``; False: only its outline came near, as
    turning beside a door it does not pass). Once entered, ``min_clearance_m`` covers the
    time the centre stood in the doorway, and ``outline_clearance_m`` the time only the
    outline was in its zone (approaching, turning beside it; 1e6: never)."""

    door_id: str
    width_m: float = num(*LENGTH)
    min_clearance_m: float
    nearest: str = ""
    at: list[float] = field(default_factory=list)
    free_width_m: float = num(*LENGTH, default=0.0)
    entered: bool = True
    outline_clearance_m: float = 1e6

    def validate(self) -> None:
        if len(self.at) not in (0, 3):
            raise Invalid("at", f"{len(self.at)} values (a pose is [x, y, theta], or none)")


@message("sim_status")
@dataclass
class SimStatus(Msg):
    """Simulator bookkeeping for evaluation: collisions so far and the smallest clearance seen."""

    stamp: float = num(*STAMP)
    collisions: int = num(*COUNT)
    in_collision: bool
    clearance_m: float
    min_clearance_m: float
    min_clearance_away_m: float = 1e6  # away from every door opening (1e6: none seen yet)
    doors: list[DoorClearance] = field(default_factory=list)  # door openings passed so far
    away_nearest: str = ""  # what the clearance away was to, and the true pose [x, y, theta]
    away_at: list[float] = field(default_factory=list)

    def validate(self) -> None:
        if len(self.away_at) not in (0, 3):
            raise Invalid(
                "away_at", f"{len(self.away_at)} values (a pose is [x, y, theta], or none)"
            )


# --------------------------------------------------------------------------------------
# Diagnostics
# --------------------------------------------------------------------------------------


@message("key_counters")
@dataclass
class KeyCounters(Msg):
    """What one subscription (or queryable) of a service received: every sample
    (``messages_in``) and those dropped as bad (undecodable, invalid, or their handler
    raised). ``key`` is the key expression as declared (a pattern where it has one)."""

    key: str
    messages_in: int = num(*COUNT)
    bad_messages: int = num(*COUNT)


@message("diagnostics")
@dataclass
class Diagnostics(Msg):
    """A service's counters, every second of wall time and when it stops: ``stamp`` is
    Unix time (wall clock, even on simulation time), ``restarts`` how often the launcher
    restarted this service before this process, the totals the sums over ``keys``."""

    stamp: float = num(*STAMP)
    service: str
    pid: int = num(*COUNT)
    restarts: int = num(*COUNT)
    uptime_s: float = num(*SECONDS)
    messages_in: int = num(*COUNT)
    bad_messages: int = num(*COUNT)
    keys: list[KeyCounters] = field(default_factory=list)

    def validate(self) -> None:
        total_in = sum(k.messages_in for k in self.keys)
        if self.messages_in != total_in:
            raise Invalid("messages_in", f"{self.messages_in}, but the keys add up to {total_in}")
        total_bad = sum(k.bad_messages for k in self.keys)
        if self.bad_messages != total_bad:
            raise Invalid(
                "bad_messages", f"{self.bad_messages}, but the keys add up to {total_bad}"
            )
