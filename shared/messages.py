"""Message types exchanged between wheelnav services, each defined once.

Every type is a small dataclass with a wire tag (``TAG``) and a schema version
(``VERSION``). The codec in :mod:`shared.codec` checks every field against the type
hints below, so a message that decodes is a message the receiver can use.

Conventions:
    * ``stamp`` is time in seconds on the fleet clock (simulation time in the
      simulator, the chair's clock on hardware).
    * Poses are of the rear-axle point, metres and radians, in the frame of the floor's map.
    * Arrays carry their shape in field metadata; ``None`` in a shape means "any length".
    * Door and lift fields follow Open-RMF's ``rmf_door_msgs`` / ``rmf_lift_msgs``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
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


def array(dtype: str, shape: tuple[int | None, ...]):
    """A dataclass field holding a numpy array of a fixed dtype and shape pattern."""
    return field(metadata={"dtype": np.dtype(dtype), "shape": shape})


class Msg:
    """Base of all messages (only for typing: ``TAG`` and ``VERSION`` are set by ``message``)."""

    TAG: ClassVar[str]
    VERSION: ClassVar[int]


# --------------------------------------------------------------------------------------
# Geometry and motion
# --------------------------------------------------------------------------------------


@message("pose2d")
@dataclass
class Pose2D(Msg):
    """A planar pose on a named floor."""

    x: float
    y: float
    theta: float
    floor: str = ""


@message("twist")
@dataclass
class Twist(Msg):
    """A velocity command for the chair: forward speed ``v`` (m/s), turn rate ``w`` (rad/s)."""

    stamp: float
    v: float
    w: float


@message("odometry")
@dataclass
class Odometry(Msg):
    """Wheel odometry: the pose integrated from the wheels (drifts) and the measured speeds."""

    stamp: float
    pose: Pose2D
    v: float
    w: float
    frame: str = "odom"


@message("pose_estimate")
@dataclass
class PoseEstimate(Msg):
    """The localisation's pose on the current floor's map, with covariance (x, y, theta)."""

    stamp: float
    pose: Pose2D
    covariance: np.ndarray = array("float64", (3, 3))
    lost: bool = False


@message("point_cloud")
@dataclass
class PointCloud(Msg):
    """Points in the sensor frame (x forward, y left, z up), metres, float32."""

    stamp: float
    frame: str
    points: np.ndarray = array("float32", (None, 3))


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
    """

    stamp: float
    path_id: str
    floor: str
    waypoints: np.ndarray = array("float64", (None, 2))
    v_ref: np.ndarray = array("float64", (None,))
    reverse: bool = False
    precise: bool = False
    zones: list[str] = field(default_factory=list)
    dock_heading: float | None = None


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

    stamp: float
    tick: int
    dt: float
    stage: int = 0


@message("ack", version=2)
@dataclass
class Ack(Msg):
    """A lockstep participant has answered ``tick`` and will answer next at ``next_tick``;
    its step took ``compute_s`` seconds of wall time (for the lockstep profile)."""

    participant: str
    tick: int
    next_tick: int
    compute_s: float = field(default=0.0, compare=False)  # a measurement, not identity


@message("lockstep_profile")
@dataclass
class LockstepProfile(Msg):
    """Where the simulator's wall time went since the clock started (cumulative sums, s).

    Per tick: the simulator's own step (``physics_s``), its publishing, each lockstep
    stage from announcing the tick to the last answer (``stage_wait_s``, one per stage) and
    its pacing; per participant, the wall time of its steps and how many it took.
    """

    stamp: float
    dt: float
    ticks: int
    wall_s: float
    physics_s: float
    publish_s: float
    pacing_s: float
    stage_wait_s: list[float] = field(default_factory=list)
    participants: list[str] = field(default_factory=list)
    compute_s: list[float] = field(default_factory=list)
    steps: list[int] = field(default_factory=list)


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

    stamp: float
    door_name: str
    current_mode: int


@message("door_request")
@dataclass
class DoorRequest(Msg):
    """Ask a door to open or close on behalf of ``requester_id`` (a ``DoorMode`` value)."""

    stamp: float
    requester_id: str
    door_name: str
    requested_mode: int


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

    stamp: float
    lift_name: str
    available_floors: list[str]
    current_floor: str
    destination_floor: str
    door_state: int
    motion_state: int
    current_mode: int
    session_id: str


@message("lift_request")
@dataclass
class LiftRequest(Msg):
    """Open or end a lift session, and send the car to ``destination_floor``."""

    stamp: float
    lift_name: str
    session_id: str
    request_type: int
    destination_floor: str
    door_state: int


# --------------------------------------------------------------------------------------
# Planning, control and mission
# --------------------------------------------------------------------------------------


@message("building_bodies")
@dataclass
class BuildingBodies(Msg):
    """Simulation only: how far each door is open and where each lift car and its doors are,
    for the simulator to move the bodies (a real building moves its own)."""

    stamp: float
    doors: list[str]
    door_openings: np.ndarray = array("float64", (None,))
    lifts: list[str] = field(default_factory=list)
    car_elevations: np.ndarray = field(
        default_factory=lambda: np.zeros(0),
        metadata={"dtype": np.dtype("float64"), "shape": (None,)},
    )
    lift_door_openings: np.ndarray = field(
        default_factory=lambda: np.zeros(0),
        metadata={"dtype": np.dtype("float64"), "shape": (None,)},
    )


@message("route_request", version=2)
@dataclass
class RouteRequest(Msg):
    """Ask the planner for a route from ``start`` to ``goal`` or to the named ``place``,
    avoiding the doors and lifts named in ``avoid`` (ones that failed this mission) and the
    points in ``blocked`` (what held the chair, marked by a recovery; map frame, floor)."""

    start: Pose2D
    goal: Pose2D | None = None
    place: str = ""
    avoid: list[str] = field(default_factory=list)
    blocked: list[Pose2D] = field(default_factory=list)


@message("checkpoint", version=2)
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
    pass_distance_m: float
    door_type: str = ""
    width_m: float = 0.0
    to_floor: str = ""
    centre: Pose2D | None = None  # the door's (or car door's) middle, heading = approach's
    controller: bool = True  # the building reports this door (False: verified by LiDAR alone)


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

    stamp: float
    name: str
    available: bool
    reason: str = ""


@message("follow_status", version=2)
@dataclass
class FollowStatus(Msg):
    """The controller's progress along the current path (``state``: idle/following/arrived).

    ``precise``: the path is a precise pass or a docking manoeuvre, not a leg (reports
    keep the cross-track error of legs apart).
    """

    stamp: float
    path_id: str
    state: str
    progress: float
    distance_to_goal: float
    cross_track: float
    precise: bool = False


@message("nav_goal")
@dataclass
class NavGoal(Msg):
    """Start a mission to a pose or a named place; ``cancel`` stops the running one."""

    stamp: float
    goal_id: str
    goal: Pose2D | None = None
    place: str = ""
    cancel: bool = False


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

    stamp: float
    goal_id: str
    state: str
    action: str = ""
    phase: str = ""  # a Phase value
    reason: str = ""
    progress: float = 0.0


TERMINAL_STATES = ("succeeded", "failed", "cancelled")  # NavStatus.state once a mission ended


@message("tree_node")
@dataclass
class TreeNode(Msg):
    """One behaviour of a tree snapshot: its place, kind, status and feedback."""

    id: int
    parent: int  # -1 for the root
    name: str
    kind: str  # Sequence, Selector, decorator or leaf class name
    status: str  # SUCCESS, FAILURE, RUNNING, INVALID
    feedback: str = ""


@message("tree_snapshot")
@dataclass
class TreeSnapshot(Msg):
    """The navigator's behaviour tree after a tick (as py_trees_ros streams it)."""

    stamp: float
    goal_id: str
    tree: str
    nodes: list[TreeNode] = field(default_factory=list)


@message("event")
@dataclass
class Event(Msg):
    """Something worth a line in the log and the report (collision, fallback, restart...)."""

    stamp: float
    source: str
    kind: str
    detail: str = ""
    severity: str = "info"


@message("door_clearance")
@dataclass
class DoorClearance(Msg):
    """The smallest clearance the simulator measured while the chair was in one opening:
    what it was to (``nearest``: "wall", "door X", ...), where the chair stood then (true
    pose [x, y, theta]) and the opening's clear width (``free_width_m``: less half a hinged
    leaf's thickness, which stands in it open; 0: as ``width_m``)."""

    door_id: str
    width_m: float
    min_clearance_m: float
    nearest: str = ""
    at: list[float] = field(default_factory=list)
    free_width_m: float = 0.0


@message("sim_status")
@dataclass
class SimStatus(Msg):
    """Simulator bookkeeping for evaluation: collisions so far and the smallest clearance seen."""

    stamp: float
    collisions: int
    in_collision: bool
    clearance_m: float
    min_clearance_m: float
    min_clearance_away_m: float = 1e6  # away from every door opening (1e6: none seen yet)
    doors: list[DoorClearance] = field(default_factory=list)  # door openings passed so far
    away_nearest: str = ""  # what the clearance away was to, and the true pose [x, y, theta]
    away_at: list[float] = field(default_factory=list)
