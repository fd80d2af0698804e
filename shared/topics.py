"""Every Zenoh key expression wheelnav uses, defined once.

Robot keys live under ``wheelnav/<robot>/...``; building keys (doors and lifts, shared by
every robot in the building) under ``wheelnav/building/...``. No other module holds a key
literal: services ask :class:`Keys` for one by its name in :data:`TOPICS`.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from shared import messages as m

ROOT = "wheelnav"
BUILDING = f"{ROOT}/building"
_NAME = re.compile(r"^[A-Za-z0-9_\-]+$")


@dataclass(frozen=True)
class Topic:
    """One row of the topic table: key pattern, message type, who publishes and who listens."""

    name: str
    pattern: str
    msg: type | None
    kind: str
    publisher: str
    subscribers: str
    doc: str


TOPICS: tuple[Topic, ...] = (
    Topic(
        "clock",
        "{ns}/clock",
        m.Clock,
        "pub",
        "sim",
        "first-stage lockstep participants, tools",
        "fleet time: each tick, announced to the first lockstep stage",
    ),
    Topic(
        "clock_stage",
        "{ns}/clock/stage/{stage}",
        m.Clock,
        "pub",
        "sim",
        "lockstep participants of that stage",
        "the tick announced to a later lockstep stage (1, 2, ...): only its participants wake",
    ),
    Topic(
        "ack",
        "{ns}/clock/ack",
        m.Ack,
        "pub",
        "localisation, building, controller, navigator, mission",
        "sim",
        "lockstep: tick answered",
    ),
    Topic(
        "cmd_vel",
        "{ns}/cmd_vel",
        m.Twist,
        "pub",
        "controller",
        "sim / chair driver",
        "velocity command",
    ),
    Topic(
        "odom",
        "{ns}/odom",
        m.Odometry,
        "pub",
        "sim / chair driver",
        "localisation, controller, navigator",
        "wheel odometry, 50 Hz",
    ),
    Topic(
        "scan",
        "{ns}/scan",
        m.PointCloud,
        "pub",
        "sim / chair driver",
        "localisation, navigator",
        "LiDAR points in the sensor frame",
    ),
    Topic(
        "driver_status",
        "{ns}/driver/status",
        m.DriverStatus,
        "pub",
        "chair driver",
        "navigator, user",
        "the base: battery, speed mode, error code, rider on the joystick, serial link",
    ),
    Topic(
        "pose",
        "{ns}/pose",
        m.PoseEstimate,
        "pub",
        "localisation",
        "controller, navigator",
        "pose on the floor map",
    ),
    Topic(
        "initial_pose",
        "{ns}/pose/initial",
        m.PoseEstimate,
        "pub",
        "navigator, user",
        "localisation",
        "(re)initialise the pose, e.g. on a new floor after a lift ride",
    ),
    Topic(
        "ground_truth",
        "{ns}/sim/ground_truth",
        m.Odometry,
        "pub",
        "sim",
        "evaluation only (mission report, viz)",
        "true pose; no navigation service may listen",
    ),
    Topic(
        "sim_status",
        "{ns}/sim/status",
        m.SimStatus,
        "pub",
        "sim",
        "evaluation only (mission report, viz)",
        "collisions and clearance",
    ),
    Topic(
        "sim_profile",
        "{ns}/sim/profile",
        m.LockstepProfile,
        "pub",
        "sim",
        "wheelnav bench fleet",
        "lockstep profile: where a tick's wall time goes (every 100 ticks)",
    ),
    Topic("path", "{ns}/path", m.Path, "pub", "navigator", "controller", "path to follow"),
    Topic(
        "follow_status",
        "{ns}/controller/status",
        m.FollowStatus,
        "pub",
        "controller",
        "navigator",
        "progress along the path",
    ),
    Topic(
        "route",
        "{ns}/planner/route",
        m.RouteRequest,
        "query",
        "navigator (get)",
        "planner (queryable)",
        "route request; reply is a RouteReply",
    ),
    Topic(
        "planner_updates",
        "{ns}/planner/updates",
        m.Availability,
        "pub",
        "navigator, user",
        "planner",
        "mark a door or elevator blocked / free",
    ),
    Topic(
        "nav_goal",
        "{ns}/nav/goal",
        m.NavGoal,
        "pub",
        "user / mission runner",
        "navigator",
        "start or cancel a mission",
    ),
    Topic(
        "nav_resume",
        "{ns}/nav/resume",
        m.NavResume,
        "pub",
        "user (wheelnav resume)",
        "navigator",
        "resume a mission paused because the rider took the joystick",
    ),
    Topic(
        "estop",
        "{ns}/estop",
        m.EmergencyStop,
        "pub",
        "user (wheelnav stop)",
        "controller, chair driver / sim, navigator",
        "emergency stop: set or cleared; every layer obeys at once",
    ),
    Topic(
        "estop_state",
        "{ns}/estop/state/{service}",
        m.EmergencyStopQuery,
        "query",
        "wheelnav stop, a (re)starting holder (get)",
        "controller, driver, sim, navigator (queryable)",
        "the emergency stop that service holds; reply is an EmergencyStop",
    ),
    Topic(
        "nav_status",
        "{ns}/nav/status",
        m.NavStatus,
        "pub",
        "navigator",
        "user",
        "mission state, on change and at 2 Hz",
    ),
    Topic(
        "nav_route",
        "{ns}/nav/route",
        m.RouteReply,
        "pub",
        "navigator",
        "mission runner, viz",
        "the route being driven (after each (re)plan)",
    ),
    Topic(
        "tree",
        "{ns}/nav/tree",
        m.TreeSnapshot,
        "pub",
        "navigator",
        "wheelnav tree, viz",
        "behaviour tree snapshot on every change",
    ),
    Topic(
        "events",
        "{ns}/events/{source}",
        m.Event,
        "pub",
        "any service",
        "user, navigator (localisation's)",
        "notable events",
    ),
    Topic(
        "diagnostics",
        "{ns}/diagnostics/{service}",
        m.Diagnostics,
        "pub",
        "every service",
        "mission runner, wheelnav topic echo",
        "counters per key (messages in, bad messages) and restarts, every 1 s of wall time",
    ),
    Topic(
        "alive",
        "{ns}/alive/{service}",
        None,
        "liveliness",
        "every service",
        "sim, tools",
        "liveliness token per service",
    ),
    Topic(
        "door_state",
        BUILDING + "/door/{door}/state",
        m.DoorState,
        "pub",
        "building",
        "any",
        "door mode",
    ),
    Topic(
        "door_request",
        BUILDING + "/door/{door}/request",
        m.DoorRequest,
        "pub",
        "navigator",
        "building",
        "door open/close request",
    ),
    Topic(
        "lift_state",
        BUILDING + "/lift/{lift}/state",
        m.LiftState,
        "pub",
        "building",
        "any",
        "lift state",
    ),
    Topic(
        "building_bodies",
        BUILDING + "/sim/bodies",
        m.BuildingBodies,
        "pub",
        "building (emulator)",
        "sim",
        "simulation only: door openings, car positions",
    ),
    Topic(
        "lift_request",
        BUILDING + "/lift/{lift}/request",
        m.LiftRequest,
        "pub",
        "navigator",
        "building",
        "lift session request",
    ),
)
_BY_NAME = {t.name: t for t in TOPICS}


def check_name(kind: str, value: str) -> str:
    """A robot, service or door name must be one key chunk; raises ValueError naming it."""
    if not _NAME.match(value):
        raise ValueError(f"{kind} name {value!r}: use letters, digits, '_' or '-'")
    return value


class Keys:
    """Key expressions for one robot: ``Keys("chair1").odom == "wheelnav/chair1/odom"``."""

    def __init__(self, robot: str) -> None:
        self.robot = check_name("robot", robot)
        self.ns = f"{ROOT}/{robot}"

    def key(self, name: str, **parts: str) -> str:
        """The key of topic ``name``; fill ``{source}``, ``{service}``, ``{door}``, ``{lift}``
        or ``{stage}``.

        A part left out becomes ``*`` so the result can be subscribed to as a pattern.
        """
        topic = _BY_NAME.get(name)
        if topic is None:
            raise KeyError(f"unknown topic {name!r}; known: {', '.join(_BY_NAME)}")
        fields = {
            "ns": self.ns,
            "source": "*",
            "service": "*",
            "door": "*",
            "lift": "*",
            "stage": "*",
        }
        fields.update({k: check_name(k, v) for k, v in parts.items()})
        return topic.pattern.format(**fields)

    def __getattr__(self, name: str) -> str:
        if name in _BY_NAME and "{" not in _BY_NAME[name].pattern.replace("{ns}", ""):
            return self.key(name)
        raise AttributeError(name)

    def clock_of(self, stage: int) -> str:
        """Where the simulator announces a tick to lockstep stage ``stage``."""
        return self.clock if stage == 0 else self.key("clock_stage", stage=str(stage))

    def all(self) -> str:
        """A pattern matching every key of this robot."""
        return f"{self.ns}/**"


def topic(name: str) -> Topic:
    """The table row of topic ``name``."""
    return _BY_NAME[name]


def markdown_table() -> str:
    """The topic table of docs/ARCHITECTURE.md (a test keeps the two equal)."""
    rows = [
        "| name | key | message | kind | publisher | subscribers | what |",
        "|---|---|---|---|---|---|---|",
    ]
    for t in TOPICS:
        key = t.pattern.replace("{ns}", "wheelnav/<robot>").replace("{", "<").replace("}", ">")
        msg = t.msg.__name__ if t.msg else "(token)"
        rows.append(
            f"| {t.name} | `{key}` | {msg} | {t.kind} | {t.publisher} | {t.subscribers} | {t.doc} |"
        )
    return "\n".join(rows)
