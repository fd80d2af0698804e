"""The fleet as the navigator last heard it, and what it computes from that (no I/O).

:class:`FleetState` keeps the latest pose, odometry, controller status, scan, door
modes and lift states, answers the reading half of the behaviours'
:class:`~behaviours.fleet.Fleet` interface (the LiDAR door checks included), holds the
mission's avoid set and lift session, and builds the messages the other half sends.
``services/navigator/node.py`` subclasses it with the half that publishes on the bus.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from typing import TypeVar

import numpy as np

from services.navigator.door_check import UNKNOWN, door_state_from_scan, lane_blocked
from shared.config import DoorCheckConfig, DoorScanConfig
from shared.door_scan import find_doorways
from shared.door_scan import warm_up as warm_door_scan
from shared.messages import (
    Clock,
    DoorMode,
    DoorRequest,
    DoorState,
    Event,
    FollowStatus,
    LiftDoor,
    LiftMode,
    LiftRequest,
    LiftRequestType,
    LiftState,
    Odometry,
    Path,
    PointCloud,
    Pose2D,
    PoseEstimate,
    RouteRequest,
)

WARNING_EVENTS = ("safety_stop", "fallback")
T = TypeVar("T")


# why a lift in a LiftMode.UNUSABLE mode is left out, in the event that says so
UNUSABLE_WHY = {
    LiftMode.FIRE: "in fire mode",
    LiftMode.OFFLINE: "out of service",
    LiftMode.EMERGENCY: "in emergency mode",
}


class FleetState:
    """Latest messages, LiDAR checks, avoid set and lift session of one chair's navigator.

    ``robot`` names the chair (door requests, lift sessions), ``source`` the events'
    sender; ``half_width_m`` is the chair's clearance half-width (the doorway lane) and
    ``sensor_height_m`` the LiDAR's height above the floor. A door's or a lift's state
    older than ``state_max_age_s`` is no state (a silent building leaves no OPEN behind).
    """

    def __init__(
        self,
        robot: str,
        door_check: DoorCheckConfig,
        sensor_height_m: float,
        half_width_m: float,
        source: str = "navigator",
        front_m: float = 0.76,
        rear_m: float = 0.35,
        door_scan: DoorScanConfig | None = None,
        restamp: Callable[[], float] | None = None,
        state_max_age_s: float = math.inf,
    ) -> None:
        self.robot = robot
        self.door_check = door_check
        self.sensor_height_m = sensor_height_m
        self.half_width_m = half_width_m
        self.front_m, self.rear_m = front_m, rear_m  # the footprint around the pose point
        self.reach_m = math.hypot(max(front_m, rear_m), half_width_m)  # its farthest corner
        self.source = source
        # on wall time, the controller's status and the building's states are stamped on
        # arrival with this clock (the navigator's own): their age is judged against now(),
        # and a controller or a building on another host stamps from another clock
        # (shared/arrivals.py)
        self.restamp = restamp
        self.state_max_age_s = state_max_age_s
        self.clock: Clock | None = None
        self.avoided: set[str] = set()
        self.lifts_reported: set[str] = set()  # lifts out of service reported this mission
        self.blocking: list[tuple[float, float, str]] = []  # marked by recoveries (map frame)
        self.untraversed: list[tuple[float, float, str]] = []  # legs' stretches held on
        self.session = ""
        self._pose: PoseEstimate | None = None
        self._odom: Odometry | None = None
        self._follow: FollowStatus | None = None
        self._scan: PointCloud | None = None
        self.door_scan = door_scan or DoorScanConfig()  # the doorway finder's (shared.door_scan)
        warm_door_scan()  # its kernel compiled now, not in a tick that looks for a doorway
        self._doorways: tuple[float, list[tuple[float, float, float, float]]] = (-1.0, [])
        # the building's states, with when each was current (see _current)
        self._doors: dict[str, tuple[float, int]] = {}
        self._lifts: dict[str, tuple[float, LiftState]] = {}
        self._closing: dict[str, tuple[str, float, float, float, float]] = {}

    # ---- what arrives -------------------------------------------------------------------

    def on_clock(self, msg: Clock) -> None:
        self.clock = msg

    def on_pose(self, msg: PoseEstimate) -> None:
        self._pose = msg

    def on_odom(self, msg: Odometry) -> None:
        self._odom = msg

    def on_follow(self, msg: FollowStatus) -> None:
        if self.restamp is not None:  # wall time: its age on this clock, not the controller's
            msg = dataclasses.replace(msg, stamp=self.restamp())
        self._follow = msg

    def on_scan(self, msg: PointCloud) -> None:
        self._scan = msg

    def on_door_state(self, msg: DoorState) -> None:
        self._doors[msg.door_name] = (self._arrived(msg.stamp), msg.current_mode)

    def on_lift_state(self, msg: LiftState) -> None:
        self._lifts[msg.lift_name] = (self._arrived(msg.stamp), msg)

    def _arrived(self, stamp: float) -> float:
        """When a message stamped ``stamp`` was current on this clock: on wall time its
        arrival (the building's host has a clock of its own), else its stamp."""
        return self.restamp() if self.restamp is not None else stamp

    def _current(self, heard: tuple[float, T] | None) -> T | None:
        """The value of a building state heard at most ``state_max_age_s`` ago, else None."""
        if heard is None or self.now() - heard[0] > self.state_max_age_s:
            return None
        return heard[1]

    # ---- the mission (the navigator's side) ---------------------------------------------

    def new_mission(self, goal_id: str) -> None:
        """Forget the checkpoints avoided so far; lift requests now hold ``<robot>-<goal_id>``."""
        self.avoided.clear()
        self.forget_blocking()
        self.lifts_reported.clear()
        self.session = f"{self.robot}-{goal_id}"

    def avoid(self, checkpoint_id: str) -> None:
        """Route requests from now on go around ``checkpoint_id``."""
        self.avoided.add(checkpoint_id)

    # ---- the Fleet interface: reading ---------------------------------------------------

    def now(self) -> float:
        return self.clock.stamp if self.clock else 0.0

    def pose(self) -> PoseEstimate | None:
        return self._pose

    def odometry(self) -> Odometry | None:
        return self._odom

    def follow_status(self) -> FollowStatus | None:
        return self._follow

    def door_mode(self, door_id: str) -> int | None:
        return self._current(self._doors.get(door_id))

    def lift_state(self, lift_id: str) -> LiftState | None:
        return self._current(self._lifts.get(lift_id))

    def session_id(self) -> str:
        return self.session

    def _band(self) -> np.ndarray:
        """The latest scan's points in the door check's height band (sensor frame)."""
        pts = self._scan.points
        height = pts[:, 2] + self.sensor_height_m
        band = self.door_check.band_m
        return pts[(height >= band[0]) & (height <= band[1])]

    def room_to_turn(self, radius_m: float) -> bool:
        if self._scan is None or self._pose is None:
            return False
        pts = self._band()
        return not bool(np.any(np.hypot(pts[:, 0], pts[:, 1]) < radius_m))

    def mark_blocking(self, reach_m: float = 1.0) -> int:
        if self._scan is None or self._pose is None:
            return 0
        pts = self._band()
        beside = np.abs(pts[:, 1]) <= self.half_width_m + 0.1
        ahead = (pts[:, 0] > self.front_m) & (pts[:, 0] < self.front_m + reach_m)
        behind = (pts[:, 0] < -self.rear_m) & (pts[:, 0] > -self.rear_m - reach_m)
        near = pts[beside & (ahead | behind)]
        near = near[:: max(1, len(near) // 60)]  # at most about 60 points per hold
        p = self._pose.pose
        c, s = math.cos(p.theta), math.sin(p.theta)
        for x, y in near[:, :2]:
            x, y = float(x), float(y)  # scan points are float32; the wire wants numbers
            self.blocking.append((p.x + c * x - s * y, p.y + s * x + c * y, p.floor))
        del self.blocking[:-400]
        return len(near)

    def _band_on_map(self) -> np.ndarray:
        """The latest scan's points in the door check's height band, map frame (N, 2)."""
        pts = self._band()[:, :2].astype(float)
        p = self._pose.pose
        c, s = math.cos(p.theta), math.sin(p.theta)
        return np.column_stack(
            [p.x + c * pts[:, 0] - s * pts[:, 1], p.y + s * pts[:, 0] + c * pts[:, 1]]
        )

    def _remember(self, near: np.ndarray) -> int:
        """Keep about 60 of ``near`` (N, 2, map frame) as blocking points; how many."""
        near = near[:: max(1, len(near) // 60)]
        floor = self._pose.pose.floor
        self.blocking.extend((float(px), float(py), floor) for px, py in near)
        del self.blocking[:-400]
        return len(near)

    def mark_near(self, points: np.ndarray) -> int:
        if self._scan is None or self._pose is None or len(points) == 0:
            return 0
        world = self._band_on_map()
        d = np.hypot(world[:, None, 0] - points[None, :, 0], world[:, None, 1] - points[None, :, 1])
        return self._remember(world[(d <= self.half_width_m).any(axis=1)])

    def mark_in_footprint(self, pose: tuple[float, float, float], margin_m: float) -> int:
        if self._scan is None or self._pose is None:
            return 0
        world = self._band_on_map()
        x, y, th = pose
        d = world - (x, y)
        along = d[:, 0] * math.cos(th) + d[:, 1] * math.sin(th)
        across = -d[:, 0] * math.sin(th) + d[:, 1] * math.cos(th)
        inside = (
            (along >= -self.rear_m - margin_m)
            & (along <= self.front_m + margin_m)
            & (np.abs(across) <= self.half_width_m + margin_m)
        )
        return self._remember(world[inside])

    def mark_untraversed(self, floor: str, points: np.ndarray) -> int:
        self.untraversed.extend((float(x), float(y), floor) for x, y in points)
        del self.untraversed[:-400]
        return len(points)

    def forget_blocking(self) -> None:
        self.blocking.clear()
        self.untraversed.clear()

    def lidar_door_state(self, x: float, y: float, width_m: float) -> tuple[float, str]:
        if self._scan is None or self._pose is None:
            return -1.0, UNKNOWN
        p = self._pose.pose
        seen = door_state_from_scan(
            self._scan.points,
            (p.x, p.y, p.theta),
            (x, y),
            self.sensor_height_m,
            self.door_check,
            width_m,
        )
        return self._scan.stamp, seen

    def doorways_seen(self) -> tuple[float, list[tuple[float, float, float, float]]]:
        if self._scan is None or self._pose is None:
            return -1.0, []
        if self._scan.stamp != self._doorways[0]:
            p = self._pose.pose
            c, s = math.cos(p.theta), math.sin(p.theta)
            seen = []
            for w in find_doorways(self._scan.points, self.door_scan):
                if not w.open:
                    continue
                x, y = (float(v) for v in w.plane_centre)
                dx, dy = (float(v) for v in w.direction)
                seen.append(
                    (
                        p.x + c * x - s * y,
                        p.y + s * x + c * y,
                        p.theta + math.atan2(dy, dx),
                        w.width,
                    )
                )
            self._doorways = (self._scan.stamp, seen)
        return self._doorways

    def lane_blocked(
        self, door_xy: tuple[float, float], direction: float, lead_m: float, width_m: float
    ) -> tuple[float, bool]:
        if self._scan is None or self._pose is None:
            return -1.0, False
        p = self._pose.pose
        blocked = lane_blocked(
            self._scan.points,
            (p.x, p.y, p.theta),
            door_xy,
            direction,
            self.sensor_height_m,
            self.half_width_m,
            lead_m,
            self.door_check,
            width_m,
        )
        return self._scan.stamp, blocked

    # ---- the Fleet interface: the messages its sending half publishes -------------------

    def unusable_lifts(self) -> list[str]:
        """The lifts whose current state says no robot may use them (out of service, fire,
        emergency), by name: a route is not planned through them (Open-RMF does not send a
        robot to an offline lift either)."""
        return sorted(
            name
            for name, heard in self._lifts.items()
            if (state := self._current(heard)) is not None
            and state.current_mode in LiftMode.UNUSABLE
        )

    def lifts_to_report(self) -> list[tuple[str, str]]:
        """The unusable lifts not yet reported in this mission, with why (marks them
        reported): a route goes round them, and the mission's report says so once."""
        out = []
        for name in self.unusable_lifts():
            if name not in self.lifts_reported:
                self.lifts_reported.add(name)
                out.append((name, UNUSABLE_WHY[self._lifts[name][1].current_mode]))
        return out

    def route_request(self, goal: Pose2D | None, place: str) -> RouteRequest | None:
        """A route from the current pose around the avoided checkpoints and the lifts out of
        service; None without a pose."""
        if self._pose is None:
            return None
        avoid = sorted(self.avoided | set(self.unusable_lifts()))
        return RouteRequest(
            start=self._pose.pose,
            goal=goal,
            place=place,
            avoid=avoid,
            blocked=[Pose2D(x, y, 0.0, floor) for x, y, floor in self.blocking],
            stamp=self.now(),
            untraversed=[Pose2D(x, y, 0.0, floor) for x, y, floor in self.untraversed],
        )

    def stop_path(self) -> Path:
        """The empty path: the controller drops its path and commands zero speed."""
        return Path(self.now(), "", "", np.zeros((0, 2)), np.zeros(0))

    def lift_request(self, lift_id: str, floor: str) -> LiftRequest:
        """Hold our session on ``lift_id``, its car to ``floor`` with the doors to open."""
        return LiftRequest(
            self.now(), lift_id, self.session, LiftRequestType.AGV_MODE, floor, LiftDoor.OPEN
        )

    def lift_release(self, lift_id: str) -> LiftRequest:
        """End our session on ``lift_id``."""
        return LiftRequest(
            self.now(), lift_id, self.session, LiftRequestType.END_SESSION, "", LiftDoor.CLOSED
        )

    def initial_pose(self, floor: str) -> PoseEstimate | None:
        """The current pose on ``floor`` (same x, y, heading); None without a pose."""
        if self._pose is None:
            return None
        p = self._pose.pose
        return PoseEstimate(self.now(), Pose2D(p.x, p.y, p.theta, floor), self._pose.covariance)

    def event_message(self, kind: str, detail: str) -> Event:
        level = "warning" if kind in WARNING_EVENTS else "info"
        return Event(self.now(), self.source, kind, detail, level)

    def door_request(self, door_id: str, mode: int) -> DoorRequest:
        """The request message; asking a door open drops a close still waiting for it."""
        if mode != DoorMode.CLOSED:
            self._closing.pop(door_id, None)
        return DoorRequest(self.now(), self.robot, door_id, mode)

    def hold_door_open_request(self, door_id: str) -> DoorRequest:
        """The renewal of a passed door's open request: its close when clear still waits."""
        return DoorRequest(self.now(), self.robot, door_id, DoorMode.OPEN)

    def close_door_when_clear(
        self, door_id: str, floor: str, centre: tuple[float, float, float], width_m: float
    ) -> None:
        self._closing[door_id] = (floor, *centre, width_m)

    def doors_clear_to_close(self) -> list[DoorRequest]:
        """Close requests for the doors waiting to close whose leaf can no longer reach
        the chair, each returned once.

        Which jamb is the hinge is not known here, so both count: the chair is clear when
        its pose point is farther than the leaf's length plus the footprint's farthest
        corner from both ends of the door, or on another floor.
        """
        pose = self._pose
        if pose is None:
            return []
        due = []
        for door_id, (floor, cx, cy, theta, width) in self._closing.items():
            if pose.pose.floor == floor:
                ax, ay = -math.sin(theta) * width / 2, math.cos(theta) * width / 2
                near = min(
                    math.hypot(pose.pose.x - (cx + s * ax), pose.pose.y - (cy + s * ay))
                    for s in (-1.0, 1.0)
                )
                if near <= width + self.reach_m:
                    continue
            due.append(door_id)
        for door_id in due:
            del self._closing[door_id]
        return [self.door_request(d, DoorMode.CLOSED) for d in due]
