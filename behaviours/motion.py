"""Behaviours that move the chair: follow a path, dock at a pose, drive through a doorway.

Each one hands the controller a :class:`~shared.messages.Path` and watches the
controller's FollowStatus and the pose; none of them is ever FAILURE because time runs
out (the Timeout above it does that), and each stops the chair when it is pre-empted.
"""

from __future__ import annotations

import math

import numpy as np
from py_trees.common import Status

from behaviours.door_fix import DoorFix
from behaviours.fleet import FleetBehaviour
from shared.geometry import angle_between
from shared.messages import DoorMode, Path, Phase

MOVING_M_S = 0.01  # odometry speeds above these: the chair is still moving
MOVING_RAD_S = 0.02
HANDOVER_HELD_S = 2.0  # a path's end held by an obstacle this long is docked instead


class FollowPath(FleetBehaviour):
    """Send ``path`` to the controller and wait until it reports arrival.

    RUNNING while the controller follows; SUCCESS on ``arrived`` for this path, or with
    ``handover_m`` > 0 once that little is left (the chair still moving: the next step
    sends its own path at once, as a smooth door pass does) and, where a
    ``handover_heading`` is given, the chair faces within ``handover_rad`` of it (a smooth
    pass from a chair facing away has no curve onto the door's line). A controller
    that reports ``idle`` without this path (it was restarted) gets the path again. Never
    FAILURE itself: the timeout above it bounds the wait. ``terminate`` on pre-emption
    stops the chair.

    ``dock_within_m`` > 0: the path ends at a pose the next step docks at (a door's or a
    lift's approach, with manoeuvres where turning needs them). Held by the safety gate
    (blocked, or an obstacle for ``HANDOVER_HELD_S``) with at most that much left, it
    hands the rest to that step (SUCCESS) instead of waiting for the navigator's
    recoveries: campaign b2011.m06 stalled 0.8 m before an approach pose beside a leaf
    standing open towards it, where the path's last corner left no room to turn.
    """

    phase = Phase.FOLLOW

    def __init__(
        self,
        path: Path,
        name: str = "",
        phase: Phase = Phase.FOLLOW,
        handover_m: float = 0.0,
        dock_within_m: float = 0.0,
        handover_heading: float | None = None,
        handover_rad: float = math.pi,
    ) -> None:
        super().__init__(name or f"Follow {path.path_id}")
        self.path = path
        self.phase = phase
        self.handover_m = handover_m
        self.dock_within_m = dock_within_m
        self.handover_heading = handover_heading
        self.handover_rad = handover_rad
        self.path_id = path.path_id
        self.sent_at = 0.0
        self.to_go = math.inf  # the controller's last distance to go on this path
        self.docking = False

    def initialise(self) -> None:
        self.bb.phase = self.phase
        self.to_go = math.inf
        self.docking = False
        self.send()
        self.feedback_message = f"following {self.path_id}"

    def send(self) -> None:
        self.sent_at = self.fleet.now()
        self.fleet.send_path(self.path)

    def arrived(self) -> bool:
        """True once the controller reports arrival on this path (resends it after a restart)."""
        status = self.fleet.follow_status()
        restarted = (
            status is not None
            and status.state in ("idle", "no_pose")
            and status.path_id != self.path_id
            and status.stamp > self.sent_at
        )
        if restarted:  # a restarted controller has lost the path: send it again
            self.send()
            self.feedback_message = f"controller idle: resent {self.path_id}"
            return False
        if status is None or status.path_id != self.path_id:
            return False
        self.to_go = status.distance_to_goal
        self.feedback_message = (
            f"{status.state}: {100 * status.progress:.0f} %, {status.distance_to_goal:.2f} m to go"
        )
        if status.state == "following" and status.distance_to_goal <= self.handover_m:
            if self._facing():
                return True  # the next step takes over at speed (a smooth door pass)
            self.feedback_message += ": turning to face the door before handing over"
        return status.state == "arrived"

    def _facing(self) -> bool:
        """True if the chair faces within ``handover_rad`` of ``handover_heading`` (or
        there is none to face)."""
        if self.handover_heading is None:
            return True
        est = self.fleet.pose()
        if est is None:
            return False
        off = est.pose.theta - self.handover_heading
        return abs(math.atan2(math.sin(off), math.cos(off))) <= self.handover_rad

    def handed_m(self) -> float:
        """How much of the path this step left to the next when it was held (0: none)."""
        return self.to_go if self.docking else 0.0

    def quits_when_held(self, cause: str, held_s: float) -> bool:
        """Asked by the safety gate while it holds the chair: True (and SUCCESS at the next
        update: the next step docks the rest) when held near the end (class doc)."""
        held = cause == "blocked" or (cause == "obstacle" and held_s >= HANDOVER_HELD_S)
        if held and self.to_go <= self.dock_within_m:
            self.docking = True
            return True
        return False

    def update(self) -> Status:
        if self.docking:
            self.feedback_message = f"held {self.to_go:.2f} m before the end: docking the rest"
            return Status.SUCCESS
        return Status.SUCCESS if self.arrived() else Status.RUNNING

    def terminate(self, new_status: Status) -> None:
        # only an interrupted drive stops the chair: a memory selector also resets a child
        # that failed earlier (INVALID after FAILURE), and that stop would cancel the path
        # the next child has just sent (b0.m08: the rocking after a failed pass stood still)
        if new_status == Status.INVALID and self.status == Status.RUNNING and self.fleet:
            self.fleet.stop()


class StopChair(FleetBehaviour):
    """Command the controller to drop its path (zero speed). Always SUCCESS at once."""

    phase = Phase.STOP

    def __init__(self, name: str = "StopChair") -> None:
        super().__init__(name)

    def update(self) -> Status:
        self.bb.phase = self.phase
        self.fleet.stop()
        self.feedback_message = "chair stopped"
        return Status.SUCCESS


def dock_path(
    path_id: str,
    floor: str,
    x: float,
    y: float,
    heading: float,
    speed: float,
    keep_out: np.ndarray | None = None,
) -> Path:
    """A docking manoeuvre to (x, y) facing ``heading`` at up to ``speed``; its manoeuvres
    count the ``keep_out`` segments (N, 4) as walls."""
    return Path(
        0.0,
        path_id,
        floor,
        np.array([[x, y]]),
        np.array([speed]),
        dock_heading=heading,
        keep_out=np.zeros((0, 4)) if keep_out is None else np.asarray(keep_out, float),
    )


class DockAt(FleetBehaviour):
    """Drive to a pose and check it: the seed's Phase 0 (position correction), damped.

    The controller docks (services/controller/docking.py); this behaviour checks the
    result on the pose estimate. SUCCESS when the controller reports arrival and the pose
    is within ``position_tolerance_m`` and ``heading_tolerance_deg``; otherwise it sends
    the manoeuvre again, up to ``attempts`` times in all. FAILURE when the attempts run
    out, or when the chair has stood still for ``stall_s`` short of the goal (the
    convergence check, on wheel odometry: a chair that cannot get closer should not
    keep trying until the time limit).

    ``heading`` None means "face ``face`` (x, y) from wherever the chair stands": the
    seed's Phase 1 turn towards the exit pose, on the spot. The final errors are its
    feedback (the mission report measures them on the ground truth). ``keep_out``:
    segments (N, 4) its manoeuvres count as walls (the doorway of the door ahead).
    ``fix``: ``target``, ``face`` and ``keep_out`` are moved onto the door the scans showed
    (:class:`~behaviours.door_fix.DoorFix`), as it stands when the behaviour starts.
    """

    def __init__(
        self,
        name: str,
        phase: Phase,
        floor: str,
        target: tuple[float, float],
        heading: float | None,
        speed: float,
        position_tolerance_m: float = 0.15,
        heading_tolerance_deg: float = 5.0,
        attempts: int = 3,
        stall_s: float = 4.0,
        face: tuple[float, float] | None = None,
        keep_out: np.ndarray | None = None,
        fix: DoorFix | None = None,
    ) -> None:
        super().__init__(name)
        self.keep_out = keep_out
        self.fix = fix
        self._keep_out = keep_out
        self.phase = phase
        self.floor = floor
        self.target, self.heading, self.face = target, heading, face
        self.speed = speed
        self.position_tolerance_m = position_tolerance_m
        self.heading_tolerance = math.radians(heading_tolerance_deg)
        self.attempts = attempts
        self.stall_s = stall_s
        self._goal: tuple[float, float, float] = (0.0, 0.0, 0.0)
        self._tries = 0
        self._best_at = 0.0
        self._started = 0.0
        self._last_update = 0.0
        self._path_id = ""

    def initialise(self) -> None:
        self.bb.phase = self.phase
        self._tries = 0
        self._started = self.fleet.now()
        self._last_update = self._started
        x, y = self._moved(self.target)
        self._keep_out = self.keep_out
        if self.fix is not None and self.keep_out is not None:
            dx, dy = self.fix.shift
            self._keep_out = np.asarray(self.keep_out, float) + [dx, dy, dx, dy]
        heading = self.heading
        if heading is None:  # turn on the spot towards ``face``
            est = self.fleet.pose()
            if est is not None:
                x, y = est.pose.x, est.pose.y
            fx, fy = self._moved(self.face)
            heading = math.atan2(fy - y, fx - x)
        self._goal = (x, y, heading)
        self._send()

    def _moved(self, xy: tuple[float, float]) -> tuple[float, float]:
        return xy if self.fix is None else self.fix.at(*xy)

    def _send(self) -> None:
        self._tries += 1
        self._best_at = self.fleet.now()
        self._path_id = f"{self.name} #{self._tries}"
        x, y, h = self._goal
        self.fleet.send_path(
            dock_path(self._path_id, self.floor, x, y, h, self.speed, self._keep_out)
        )

    @property
    def goal(self) -> tuple[float, float, float]:
        """The pose (x, y, heading) it docks at, as set when it last started."""
        return self._goal

    def heading_off_rad(self) -> float:
        """How far the pose estimate faces from the goal heading now (0: turning to face a
        point, or no estimate)."""
        est = self.fleet.pose() if self.fleet is not None else None
        if self.heading is None or est is None:
            return 0.0
        return angle_between(self.heading, est.pose.theta)

    def errors(self) -> tuple[float, float] | None:
        """(position error m, heading error rad) of the pose estimate, None without one."""
        est = self.fleet.pose()
        if est is None:
            return None
        p = est.pose
        x, y, h = self._goal
        return math.hypot(x - p.x, y - p.y), angle_between(h, p.theta)

    def update(self) -> Status:
        err = self.errors()
        if err is None:
            self.feedback_message = "no pose estimate"
            return Status.RUNNING
        dist, dth = err
        now = self.fleet.now()
        if now - self._last_update > 1.0:  # not ticked for a while (a safety hold)
            self._best_at = now
        self._last_update = now
        odom = self.fleet.odometry()
        if odom is not None and (abs(odom.v) > MOVING_M_S or abs(odom.w) > MOVING_RAD_S):
            self._best_at = now  # still working at it
        within = dist <= self.position_tolerance_m and dth <= self.heading_tolerance
        self.feedback_message = (
            f"error {dist:.3f} m, {math.degrees(dth):.1f} deg (attempt {self._tries})"
        )
        status = self.fleet.follow_status()
        arrived = (
            status is not None and status.path_id == self._path_id and status.state == "arrived"
        )
        if arrived and within:
            self.feedback_message = (
                f"done: {dist:.3f} m, {math.degrees(dth):.1f} deg in {now - self._started:.1f} s"
            )
            return Status.SUCCESS
        if arrived and self._tries >= self.attempts:
            return self.fail(
                f"not within {self.position_tolerance_m} m / "
                f"{math.degrees(self.heading_tolerance):.0f} deg after {self._tries} attempts "
                f"({dist:.3f} m, {math.degrees(dth):.1f} deg)"
            )
        if arrived:
            self._send()
            return Status.RUNNING
        if now - self._best_at > self.stall_s:
            return self.fail(
                f"not converging: stopped {dist:.3f} m, {math.degrees(dth):.1f} deg off "
                f"for {self.stall_s:g} s"
            )
        return Status.RUNNING

    def terminate(self, new_status: Status) -> None:
        self.stop_if_driving(new_status)


class DriveThrough(FollowPath):
    """Drive a straight pass (through a door, into or out of a car) and end it by odometry.

    The pass ends when the wheel odometry says the chair has travelled the distance from
    where it stood to the pass's end, measured along the pass (the seed measured it by
    dead reckoning on wall-clock time; localisation can jump while the chair is inside a
    door frame, the wheels do not). The path sent to the controller runs ``overrun_m``
    past the end, so the controller does not stop early; it is a fallback end only.

    It holds (chair stopped, path resent when clear) while the lane ahead is blocked by
    LiDAR (a leaf closing in front of the chair, in a doorway ``door_width_m`` wide, 0 if
    unknown: see :func:`services.navigator.door_check.lane_blocked`) or, for a door, while
    the building stops reporting the door OPEN. With ``closed_fails`` a door that stops
    being reported OPEN while the chair's front has not reached its plane ends the pass
    (FAILURE) instead: an automatic door that closed while the chair stood still before it
    (its motion sensor saw nothing for its hold time) opens again only for motion, so
    holding still would wait for ever; the door steps then wait for it again, rocking.
    ``fix``: the pass (its start, end and door) is moved onto the door the scans showed
    (:class:`~behaviours.door_fix.DoorFix`), as it stands when the pass starts.
    """

    def __init__(
        self,
        name: str,
        path_id: str,
        phase: Phase,
        floor: str,
        start: tuple[float, float],
        end: tuple[float, float],
        speed: float,
        door_xy: tuple[float, float] | None,
        lead_m: float,
        door_id: str = "",
        reverse: bool = False,
        overrun_m: float = 0.2,
        tolerance_m: float = 0.03,
        door_width_m: float = 0.0,
        closed_fails: bool = False,
        fix: DoorFix | None = None,
    ) -> None:
        self._mapped = (start, end, door_xy)
        self.speed, self.overrun_m, self.floor = speed, overrun_m, floor
        a, b = np.asarray(start, float), np.asarray(end, float)
        super().__init__(self._pass_path(path_id, a, b, reverse), name, phase)
        self.end = (float(b[0]), float(b[1]))
        self.door_xy = door_xy
        self.fix = fix
        self.door_width_m = door_width_m
        self.lead_m = lead_m
        self.door_id = door_id
        self.reverse = reverse
        self.tolerance_m = tolerance_m
        self.required_m = float(np.linalg.norm(b - a))
        self.closed_fails = closed_fails
        self._to_plane: float | None = None  # from the front to the door plane at the start
        self.held_for = ""
        self._odom0: tuple[float, float] | None = None
        self._odom_dir = 0.0
        self._last_scan = -1.0
        self._blocked = False

    def _pass_path(self, path_id: str, a: np.ndarray, b: np.ndarray, reverse: bool) -> Path:
        """The straight pass from ``a`` to ``overrun_m`` past ``b``; sets its direction."""
        length = float(np.linalg.norm(b - a))
        self.direction = math.atan2(b[1] - a[1], b[0] - a[0])
        far = b + (b - a) / max(length, 1e-9) * self.overrun_m
        n = max(2, int(np.ceil((length + self.overrun_m) / 0.25)) + 1)
        v = np.full(n, self.speed)
        v[-1] = 0.0
        return Path(
            0.0, path_id, self.floor, np.linspace(a, far, n), v, reverse=reverse, precise=True
        )

    def _move_onto_door(self) -> None:
        """Aim the pass at the mapped poses moved by ``fix`` (no fix: as mapped)."""
        start, end, door = self._mapped
        if self.fix is None:
            return
        a, b = np.array(self.fix.at(*start)), np.array(self.fix.at(*end))
        self.path = self._pass_path(self.path_id, a, b, self.reverse)
        self.end = (float(b[0]), float(b[1]))
        self.door_xy = None if door is None else self.fix.at(*door)

    def initialise(self) -> None:
        self._move_onto_door()
        est = self.fleet.pose()
        self._to_plane = None
        if est is not None:  # the distance still to go, from where the chair stands
            ux, uy = math.cos(self.direction), math.sin(self.direction)
            p = est.pose
            self.required_m = (self.end[0] - p.x) * ux + (self.end[1] - p.y) * uy
            if self.door_xy is not None:
                ahead = (self.door_xy[0] - p.x) * ux + (self.door_xy[1] - p.y) * uy
                self._to_plane = ahead - self.lead_m
        odom = self.fleet.odometry()
        self._odom0 = (odom.pose.x, odom.pose.y) if odom is not None else None
        self._odom_dir = odom.pose.theta + (math.pi if self.reverse else 0.0) if odom else 0.0
        self.held_for, self._blocked, self._last_scan = "", False, -1.0
        super().initialise()

    def travelled(self) -> float | None:
        """Metres travelled along the pass since it began, by wheel odometry."""
        odom = self.fleet.odometry()
        if odom is None or self._odom0 is None:
            return None
        dx, dy = odom.pose.x - self._odom0[0], odom.pose.y - self._odom0[1]
        return dx * math.cos(self._odom_dir) + dy * math.sin(self._odom_dir)

    def _door_not_open(self) -> bool:
        """Whether the building no longer reports this pass's door OPEN."""
        return bool(self.door_id) and self.fleet.door_mode(self.door_id) != DoorMode.OPEN

    def _hold_reason(self) -> str:
        if self._door_not_open():
            return f"door {self.door_id} no longer reported open"
        if self.door_xy is not None:
            stamp, blocked = self.fleet.lane_blocked(
                self.door_xy, self.direction, self.lead_m, self.door_width_m
            )
            if stamp > self._last_scan:
                self._last_scan, self._blocked = stamp, blocked
            if self._blocked:
                return "LiDAR: something in the doorway ahead"
        return ""

    def _before_the_door(self) -> bool:
        """Whether the chair's front has not yet reached the door plane (by odometry)."""
        done = self.travelled()
        return self._to_plane is not None and done is not None and done < self._to_plane

    def update(self) -> Status:
        if self.closed_fails and self._door_not_open() and self._before_the_door():
            self.fleet.stop()
            return self.fail(f"door {self.door_id} closed before the chair reached it")
        reason = self._hold_reason()
        if reason:
            if not self.held_for:
                self.fleet.stop()
            self.held_for = reason
            self.feedback_message = f"holding: {reason}"
            return Status.RUNNING
        if self.held_for:  # clear again: carry on
            self.held_for = ""
            self.send()
            return Status.RUNNING
        done = self.travelled()
        if done is not None and done >= self.required_m - self.tolerance_m:
            self.fleet.stop()
            self.feedback_message = f"passed: {done:.2f} m by odometry"
            return Status.SUCCESS
        if self.arrived():  # the controller reached the overrun end: odometry lags or is lost
            self.feedback_message = "passed: controller reached the end"
            return Status.SUCCESS
        if done is not None:
            self.feedback_message = f"{done:.2f} of {self.required_m:.2f} m by odometry"
        return Status.RUNNING
