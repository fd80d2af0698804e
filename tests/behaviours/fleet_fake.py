"""A scripted fleet for ticking mission trees without Zenoh, and the routes the tests drive.

The scripted fleet is a perfect controller on demand: ``arrive()`` puts the chair at the
end of the last path it was sent (a docking goal with its heading) and says so. It
implements the behaviours' ``Fleet`` and the navigator's ``MissionFleet`` (avoid set,
lift session), so the same fake drives the trees alone (tests/behaviours) and under the
navigator's core (tests/services/navigator).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from shared.messages import (
    Checkpoint,
    DoorMode,
    DoorRequest,
    FollowStatus,
    LiftState,
    Odometry,
    Path,
    Pose2D,
    PoseEstimate,
    RouteReply,
)


class ScriptedFleet:
    """Answers route requests at once (or never); door modes, LiDAR and arrivals as told.

    ``answer`` answers every route request; ``routes``, when not empty, answers the next
    ones first, in order. ``route_requests`` records (goal, place, avoided ids) of each.
    """

    def __init__(self, answer: RouteReply | None, routes: list[RouteReply] | None = None) -> None:
        self.t = 0.0
        self.answer = answer
        self.routes = list(routes or [])
        self.route_requests: list[tuple[Pose2D | None, str, list[str]]] = []
        self.sent: list[Path] = []
        self.stops = 0
        self.commands: list[str] = []  # what the controller was told, in order: path ids, "stop"
        self.follow: FollowStatus | None = None
        self.doors: dict[str, int] = {}
        self.door_requests: list[tuple[str, int]] = []
        self.closing: dict[str, tuple[str, tuple[float, float, float], float]] = {}
        self.lifts: dict[str, LiftState] = {}
        self.lift_requests: list[tuple[str, str]] = []
        self.released: list[str] = []
        self.floor: str | None = None
        self.scan_stamp = 0.0
        self.lidar = "open"
        self.lane = False
        self.doorways: list[tuple[float, float, float, float]] = []  # what the scans show
        self.widths: list[float] = []  # the door widths the LiDAR checks were asked about
        self.x, self.y, self.th = 0.0, 0.0, 0.0
        self.events: list[tuple[str, str]] = []
        self.session = "s1"
        self.avoided: set[str] = set()
        self.turn_room = True
        self.marked = 0
        self.marked_at: list[tuple[tuple[float, float, float], float]] = []
        self.marked_near: list[np.ndarray] = []
        self.turning = 0.0  # the turn rate odometry reports (rad/s): a chair at work
        self.forgotten = 0
        self.untraversed: list[tuple[str, np.ndarray]] = []  # (floor, points) marked
        self.no_pose = False  # True: no pose estimate yet
        self.lost = False  # the localisation's lost flag
        self.door_clear = False  # the leaves of the doors waiting to close cannot reach it

    def now(self) -> float:
        return self.t

    def new_mission(self, goal_id: str) -> None:
        self.avoided.clear()
        self.session = f"chair1-{goal_id}"

    def avoid(self, checkpoint_id: str) -> None:
        self.avoided.add(checkpoint_id)

    def request_route(self, goal, place, on_done) -> None:
        self.route_requests.append((goal, place, sorted(self.avoided)))
        answer = self.routes.pop(0) if self.routes else self.answer
        if answer is not None:
            on_done(answer, "")

    def send_path(self, path: Path) -> None:
        self.sent.append(path)
        self.commands.append(path.path_id)

    def stop(self) -> None:
        self.stops += 1
        self.commands.append("stop")

    def follow_status(self) -> FollowStatus | None:
        # a live controller reports every cycle: its last state, stamped now
        return dataclasses.replace(self.follow, stamp=self.t) if self.follow else None

    def event(self, kind: str, detail: str) -> None:
        self.events.append((kind, detail))

    def pose(self) -> PoseEstimate | None:
        if self.no_pose:
            return None
        return PoseEstimate(self.t, Pose2D(self.x, self.y, self.th), np.eye(3), self.lost)

    def odometry(self) -> Odometry:
        return Odometry(self.t, Pose2D(self.x, self.y, self.th), 0.0, self.turning)

    def door_mode(self, door_id: str) -> int | None:
        return self.doors.get(door_id)

    def request_door(self, door_id: str, mode: int) -> None:
        self.door_requests.append((door_id, mode))

    def close_door_when_clear(self, door_id, floor, centre, width_m) -> None:
        self.door_requests.append((door_id, DoorMode.CLOSED))
        self.closing[door_id] = (floor, centre, width_m)

    def hold_door_open(self, door_id: str) -> None:
        self.door_requests.append((door_id, DoorMode.OPEN))

    def doors_clear_to_close(self) -> list[DoorRequest]:
        """The doors waiting to close, once ``door_clear`` says their leaves cannot reach
        the chair (each once)."""
        if not self.door_clear:
            return []
        due, self.closing = list(self.closing), {}
        return [DoorRequest(self.t, "chair1", d, DoorMode.CLOSED) for d in due]

    def lidar_door_state(self, x: float, y: float, width_m: float) -> tuple[float, str]:
        self.widths.append(width_m)
        self.scan_stamp += 0.1
        return self.scan_stamp, self.lidar

    def lane_blocked(self, door_xy, direction, lead_m, width_m) -> tuple[float, bool]:
        self.widths.append(width_m)
        self.scan_stamp += 0.1
        return self.scan_stamp, self.lane

    def doorways_seen(self) -> tuple[float, list[tuple[float, float, float, float]]]:
        self.scan_stamp += 0.1
        return self.scan_stamp, list(self.doorways)

    def room_to_turn(self, radius_m: float) -> bool:
        return self.turn_room

    def mark_blocking(self) -> int:
        self.marked += 1
        return 3

    def mark_near(self, points: np.ndarray) -> int:
        self.marked_near.append(points)
        return 4

    def mark_in_footprint(self, pose: tuple[float, float, float], margin_m: float) -> int:
        self.marked_at.append((pose, margin_m))
        return 2

    def mark_untraversed(self, floor: str, points: np.ndarray) -> int:
        self.untraversed.append((floor, points))
        return len(points)

    def forget_blocking(self) -> None:
        self.forgotten += 1

    def lift_state(self, lift_id: str):
        return self.lifts.get(lift_id)

    def session_id(self) -> str:
        return self.session

    def request_lift(self, lift_id: str, floor: str) -> None:
        self.lift_requests.append((lift_id, floor))

    def release_lift(self, lift_id: str) -> None:
        self.released.append(lift_id)

    def set_floor(self, floor: str) -> None:
        self.floor = floor

    def arrive(self, off: tuple[float, float] = (0.0, 0.0)) -> None:
        """The chair reaches the end of the last path (``off`` metres wrong in x, y)."""
        path = self.sent[-1]
        end = path.waypoints[-1]
        if path.dock_heading is not None:
            self.th = path.dock_heading
        elif len(path.waypoints) > 1:
            d = path.waypoints[-1] - path.waypoints[-2]
            self.th = math.atan2(d[1], d[0]) + (math.pi if path.reverse else 0.0)
        self.x, self.y = float(end[0]) + off[0], float(end[1]) + off[1]
        self.follow = FollowStatus(self.t, path.path_id, "arrived", 1.0, 0.0, 0.0)


def leg(path_id: str, a=(-2.0, 0.0), b=(1.0, 0.0)) -> Path:
    return Path(0.0, path_id, "1", np.array([a, b], float), np.array([0.5, 0.0]))


def door(kind: str = "manual", door_id: str = "d1") -> Checkpoint:
    """A door 1.0 m wide: approach (1, 0), exit (3.2, 0), heading 0."""
    return Checkpoint(
        "door", door_id, "1", Pose2D(1, 0, 0, "1"), Pose2D(3.2, 0, 0, "1"), 2.2, kind, 1.0
    )


def route(cp: Checkpoint) -> RouteReply:
    """Leg 0 to the door's approach pose, the door, leg 1 from its exit pose."""
    after = leg("r.1", (3.2, 0.0), (6.0, 0.0))
    return RouteReply(True, leg("r"), legs=[leg("r.0"), after], checkpoints=[cp])
