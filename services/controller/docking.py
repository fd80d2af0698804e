"""Docking: drive to one pose, slowly and exactly (the seed's Phase 0 position correction).

The seed corrected its position before a door by turning towards the target, driving
forwards or backwards to it and stopping within 0.15 m and 5 deg, at fixed speeds. Here
the same manoeuvre is damped: speeds fall in proportion to the remaining error (with a
floor so the chair does not creep), so it stops without overshoot on a chair with motor
lag. Stages:

* ``move`` (when starting further than ``near_m`` from a manoeuvre's pose, or
  ``FACE_REACH_M`` from the goal itself, until within the tolerance): turn towards the
  target, or away from it to back up to it when it lies within ``reverse_reach_m`` and
  backing up leaves the chair nearer the goal heading (a target behind a chair facing the
  door; a pose across a corridor facing the other way), then drive while steering. Nearer
  than that it no longer turns on the spot to face the target: with the target off to a
  side it hands over to the final stage.
* ``final``: turn on the spot to the goal heading, then drive out the error along it.
  Turned more than ``SHIFT_RAD`` off the goal heading (arriving sideways along a
  corridor, the door in its side), it first drives along the heading it has until the
  error across the goal heading is gone: that error lies mostly along its way, and there
  may be no room behind for a sidestep.
* ``sidestep``: what is left across the goal heading, over ``lateral_tolerance_m``, is
  taken out by docking first at a pose on the goal's line behind the chair (backing up
  slantwise onto it) and then along the line: a pass through a door starts on its centre
  line, and its front enters the doorway within 3 cm of it.

When the chair stands still for ``STUCK_S`` while commanded to move (the safety checks
hold it: in the room between two doors in series, 2 x 2 m, there is no room to turn at
either door's pose), or a turn on the spot the short way would sweep into a point, the
docker plans a manoeuvre in the room its LiDAR points show
(:mod:`services.controller.manoeuvre`: turn-drive-turn where that fits, else turns where
the room allows and straight drives forwards and back between them) and docks through
its poses one by one, each within ``VIA_TOLERANCE_M`` and ``VIA_HEADING_RAD``, before
the goal itself. Only then: the search costs a second or two.

The move stage looks at the LiDAR points it is given: driving to a target 0.3 m away by
turning to face it can put the front into a wall a few centimetres beyond it. When the
footprint at the target, facing the way it would drive, holds a point, it drives the
other way (backwards or forwards) if that is clear, else it turns to the goal heading
first and drives along it (the final stage), as a person would in a small room.

Idle motion for automatic doors (small moves back and forth) uses the same manoeuvre with
a low speed cap. Pure: the tracker hands in poses and gets commands.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from services.controller.command import Command
from services.controller.manoeuvre import Budget, ManoeuvreBody, Room, plan_manoeuvre
from shared.config import ControllerConfig, Footprint, RobotConfig
from shared.geometry import (
    angle_between,
    in_footprint,
    into_frame,
    moves_close_in,
    swept_arc_poses,
    turn_closes_in,
    wrap_angle,
)

ALIGN_RAD = math.radians(10)  # turn on the spot first when the target is further off
MIN_SPEED = 0.03  # m/s: below this the chair barely moves against its motor lag
MIN_TURN = 0.08  # rad/s
LEAVE_FACTOR = 2.0  # the final stage starts over if the error grows past this x near_m
SWITCH_RAD = math.radians(20)  # hysteresis of the forwards / backwards choice
SWEEP_RAD = math.radians(15)  # a turn on the spot looks this far ahead for its corners
STUCK_S = 1.5  # commanded to move, not moving this long: plan a manoeuvre
STUCK_M, STUCK_RAD = 0.01, math.radians(1)  # what counts as moving
VIA_TOLERANCE_M = 0.01  # how near each pose of a manoeuvre is reached (3 cm: a turn planned
# clear of a leaf's tip began 2.6 cm short of its point and swept 4.3 cm from it)
VIA_HEADING_RAD = math.radians(3)
ROOM_CELL_M = 0.05  # the grid a manoeuvre is planned on
ROOM_REACH_M = 1.5  # how far round the pose and the goal the room is taken from the points
PLAN_EXPANSIONS = 400_000  # all margins together; none found: 1.2 s idle, 1.7 s by 2 busy loops
ENDS_ON_M = 0.05  # a manoeuvre ending this near the goal's line reaches it (one cell)
PLAN_SLACK_M = 0.03  # a manoeuvre keeps this much more than the margin: poses are reached
# within VIA_TOLERANCE_M, and the safety checks must never hold one of its turns
SIDESTEP_RAD = math.radians(20)  # a sidestep backs up at most this far off the goal heading
SIDESTEP_MIN_M = 0.15  # and at least this far along it (more than near_m: a real move)
SIDESTEP_REACH = 0.9  # and at most this share of reverse_reach_m (it must back up to it)
SIDESTEPS = 2  # at most this many per goal
PLANNED_LOOK_M = 0.15  # a drive after a manoeuvre checks this far ahead (1 s at dock speed)
REPLANS = 2  # a manoeuvre the scan shows would not keep its margin is planned again this often
GOALWARD_RAD = math.radians(15)  # driving within this of the goal heading ends on the goal
FACE_REACH_M = 0.25  # nearer the goal itself the final stage and a sidestep beat facing it
SHIFT_RAD = math.radians(45)  # turned this far off the goal heading: drive out what is across


@dataclass
class DockLimits:
    """Tolerances, gains and speed caps of one docking manoeuvre (``controller.dock_*``)."""

    position_tolerance_m: float
    heading_tolerance_rad: float
    max_speed: float
    max_turn: float
    speed_gain: float  # 1/s: v = gain * remaining distance
    turn_gain: float  # 1/s: w = gain * heading error
    near_m: float
    reverse_reach_m: float
    lateral_tolerance_m: float = 0.015

    @classmethod
    def from_config(cls, cfg: ControllerConfig, robot: RobotConfig) -> DockLimits:
        """The limits the fleet runs with: controller.dock_* capped by the chair's limits."""
        return cls(
            position_tolerance_m=cfg.dock_tolerance_m,
            heading_tolerance_rad=math.radians(cfg.dock_heading_tolerance_deg),
            max_speed=min(cfg.dock_speed, robot.max_speed),
            max_turn=min(cfg.dock_turn_rate, robot.max_turn_rate),
            speed_gain=cfg.dock_speed_gain,
            turn_gain=cfg.dock_turn_gain,
            near_m=cfg.dock_near_m,
            reverse_reach_m=cfg.dock_reverse_reach_m,
            lateral_tolerance_m=cfg.dock_lateral_tolerance_m,
        )


def _segment_points(segments: np.ndarray | None) -> np.ndarray:
    """Points (N, 2) along each segment (x1, y1, x2, y2), half a manoeuvre cell apart:
    a wall to the manoeuvre search."""
    if segments is None or len(segments) == 0:
        return np.zeros((0, 2))
    out = []
    for x1, y1, x2, y2 in np.asarray(segments, dtype=float):
        n = max(2, int(math.ceil(math.hypot(x2 - x1, y2 - y1) / (ROOM_CELL_M / 2))) + 1)
        out.append(np.column_stack([np.linspace(x1, x2, n), np.linspace(y1, y2, n)]))
    return np.vstack(out)


class Docker:
    """Drives to one pose (x, y, heading); ``set_goal`` starts, ``clear`` stops."""

    def __init__(
        self, limits: DockLimits, footprint: Footprint | None = None, margin_m: float = 0.05
    ) -> None:
        self.limits = limits
        self.footprint = footprint
        self.margin_m = margin_m
        self._straight = False
        self.goal: tuple[float, float, float] | None = None
        self.stage = "start"
        self._start_error = 0.0
        self._arrived = False
        self._backwards: bool | None = None
        self._turn_sign = 0.0  # a turn on the spot the long way round, kept until aligned
        self._pose = (0.0, 0.0, 0.0)
        self._obstacles: np.ndarray | None = None
        self._target: tuple[float, float, float] | None = None  # the goal behind a manoeuvre
        self._via: list[tuple[float, float, float]] = []
        self._keep_out = np.zeros((0, 2))  # points along segments a manoeuvre counts as walls
        self._across = limits.near_m  # what may be left across the goal heading
        self.plan_margin: float | None = None  # the margin of the manoeuvre under way
        self._planned = False
        self.plan_note = ""  # what the last manoeuvre search found, for the node's log
        self._cramped = False  # a turn the short way would sweep into a point
        self._boxed = False  # and the other way too: plan a manoeuvre even at the goal point
        self._turn_left = math.inf  # how far this cycle's turn on the spot has to go
        self._still_s = 0.0  # commanded to move and not moving, since _still_at
        self._still_at: tuple[float, float, float] | None = None
        self._tol, self._tol_heading = limits.position_tolerance_m, limits.heading_tolerance_rad

    @property
    def active(self) -> bool:
        return self.goal is not None

    def set_goal(
        self,
        x: float,
        y: float,
        heading: float,
        max_speed: float | None = None,
        keep_out: np.ndarray | None = None,
    ) -> None:
        """Dock at (x, y) facing ``heading``; ``max_speed`` caps the speed (idle motion);
        a manoeuvre counts the ``keep_out`` segments (N, 4: x1, y1, x2, y2) as walls."""
        self._target, self._via, self._planned = (x, y, heading), [], False
        self._keep_out = _segment_points(keep_out)
        self._across = self._across_limit(keep_out)
        self.plan_margin: float | None = None
        self._still_s, self._still_at, self._cramped = 0.0, None, False
        self._boxed = False
        self._sidesteps = self._replans = 0
        self._aim(
            x, y, heading, self.limits.position_tolerance_m, self.limits.heading_tolerance_rad
        )
        self._cap = self.limits.max_speed if max_speed is None else max_speed

    def _aim(self, x: float, y: float, heading: float, tol: float, tol_heading: float) -> None:
        """Start docking at (x, y, heading) within ``tol`` and ``tol_heading``."""
        self.goal = (x, y, heading)
        self._tol, self._tol_heading = tol, tol_heading
        self.stage = "start"
        self._start_error = -1.0
        self._arrived = False
        self._backwards: bool | None = None
        self._turn_sign = 0.0
        self._straight = False

    def _across_limit(self, keep_out: np.ndarray | None) -> float:
        """What may be left across the goal heading once there: ``near_m``, and before a
        doorway (a ``keep_out`` segment) at most a quarter of the slack it leaves the chair,
        half the slack a side, the other half the pass's. An 0.80 m door leaves 7.5 cm a
        side: 0.097 m across stood the pass at the jamb (world-differs b7104w.m00)."""
        limit = self.limits.near_m
        if self.footprint is None or keep_out is None or len(keep_out) == 0:
            return limit
        seg = np.asarray(keep_out, dtype=float)
        widths = np.hypot(seg[:, 2] - seg[:, 0], seg[:, 3] - seg[:, 1])
        slack = (float(widths.min()) - self.footprint.width) / 2
        return min(limit, max(self.limits.lateral_tolerance_m, slack / 2))

    def clear(self) -> None:
        self.goal = None
        self._target, self._via = None, []
        self.plan_margin = None

    def turn_margin(self, default_m: float, manoeuvre_m: float) -> float:
        """The margin for the safety check of a turn on the spot: ``manoeuvre_m`` while a
        manoeuvre is under way (planned for a tight room, its poses reached within their
        tolerance: the controller's precise margin) or once none was found (the search's
        grid is conservative by up to a cell: the turn itself is the last way left), else
        ``default_m``."""
        if not self.active or not self._planned:
            return default_m
        return min(default_m, manoeuvre_m)

    def _stuck(self, x: float, y: float, theta: float, period_s: float) -> bool:
        """True once the pose has not moved for ``STUCK_S`` while the goal is not reached
        (the last command asked for motion: the safety checks hold it)."""
        ref = self._still_at
        if ref is None or (
            math.hypot(x - ref[0], y - ref[1]) > STUCK_M
            or abs(wrap_angle(theta - ref[2])) > STUCK_RAD
            or self._arrived
        ):
            self._still_at, self._still_s = (x, y, theta), 0.0
            return False
        self._still_s += period_s
        return self._still_s >= STUCK_S

    def _plan(self, x: float, y: float, theta: float, obstacles: np.ndarray | None) -> None:
        """Where turn-drive-turn to the goal does not fit the room the points show, dock
        through a manoeuvre's poses first (none found: dock as usual)."""
        self._planned = True
        fp, goal = self.footprint, self._target
        if fp is None or goal is None or obstacles is None or len(obstacles) == 0:
            return
        near = math.hypot(goal[0] - x, goal[1] - y) <= self.limits.position_tolerance_m
        if near and abs(wrap_angle(goal[2] - theta)) <= self.limits.heading_tolerance_rad:
            return  # there already (a turn that does not fit still needs a manoeuvre)
        lo = np.minimum((x, y), goal[:2]) - ROOM_REACH_M
        hi = np.maximum((x, y), goal[:2]) + ROOM_REACH_M
        shape = np.ceil((hi - lo) / ROOM_CELL_M).astype(int)
        pts = np.vstack([np.asarray(obstacles, dtype=float)[:, :2], self._keep_out])
        # and the points beyond the window that a footprint standing in it reaches: a pose
        # near its edge puts the front past it (campaign b8706.m02: 3.5 cm from a jamb
        # the window had left out)
        reach = math.hypot(max(fp.front, fp.rear), fp.width / 2) + self.margin_m
        reach += PLAN_SLACK_M + 2 * ROOM_CELL_M  # and what the room grows a point by
        ends = lo + shape * ROOM_CELL_M
        inside = pts[((pts >= lo - reach) & (pts < ends + reach)).all(axis=1)]
        origin = (float(lo[0]), float(lo[1]))
        poses, margin, short = None, 0.0, None
        # with slack first; a chair held by the safety checks may stand nearer than that.
        # A search whose goal does not fit ends anywhere within its slack, beside the goal:
        # a smaller margin that ends on the goal is better (kept otherwise as a fallback),
        # down to none: the room counts a pose as anywhere in its cell (half a cell more),
        # range noise scatters points nearer, and the controller's guard keeps its margin.
        # One that ends where the chair stands is no manoeuvre
        budget = Budget(PLAN_EXPANSIONS)
        for margin in (self.margin_m + PLAN_SLACK_M, self.margin_m, self.margin_m / 2, 0.0):
            body = ManoeuvreBody(fp.front, fp.rear, fp.width, margin)
            room = Room.from_points(inside, ROOM_CELL_M, origin, (shape[1], shape[0]), body)
            poses = plan_manoeuvre(room, (x, y, theta), goal, budget=budget)
            if poses is not None and _ends_on(poses[-1], goal):
                break
            if poses is not None and _moves(poses, (x, y, theta)):
                short = short or (poses, margin)
        else:
            poses, margin = short or (None, 0.0)
        if poses is None:
            self.plan_note = (
                f"no manoeuvre from ({x:.2f}, {y:.2f}, {math.degrees(theta):.0f} deg) to "
                f"({goal[0]:.2f}, {goal[1]:.2f}, {math.degrees(goal[2]):.0f} deg) in the room "
                f"{len(pts)} points show"
            )
            return
        self.plan_margin = margin
        # driven to its end, whether that is on the goal's line or beside it: what is left
        # the final stage takes out, along the goal heading. Steering from the pose before
        # the end straight at the goal is a way the search never checked (campaign
        # b8210.m01: ending beside it; b8611.m02: 4.7 cm across a 0.70 m drive, 4 deg off
        # the heading, swung the front corner to a leaf's tip)
        kept = poses if _moves([poses[-1]], goal) else poses[:-1]  # at the goal: aim it
        self._via = [p for p in kept if math.hypot(p[0] - x, p[1] - y) > 0 or p[2] != theta]
        self.plan_note = (
            f"manoeuvre from ({x:.2f}, {y:.2f}, {math.degrees(theta):.0f} deg): "
            f"{len(self._via)} poses, margin {margin:.3f} m"
        )
        if self._via:
            self._aim(*self._via.pop(0), VIA_TOLERANCE_M, VIA_HEADING_RAD)

    def step(
        self,
        x: float,
        y: float,
        theta: float,
        pose_fresh: bool = True,
        obstacles: np.ndarray | None = None,
        period_s: float = 0.0,
    ) -> Command:
        """The command for pose (x, y, theta); zero when idle, arrived or the pose is stale.
        ``obstacles`` (N, 2, map frame) are what the move stage keeps the footprint off;
        ``period_s`` since the last call (0: no manoeuvre when stuck)."""
        if self.goal is None:
            return Command(0.0, 0.0, "idle")
        self._pose, self._obstacles = (x, y, theta), obstacles
        self._turn_left = math.inf
        target = self._target or self.goal
        there = math.hypot(target[0] - x, target[1] - y) <= self.limits.position_tolerance_m
        # a turn at the goal point the short way held: the long way first; stuck, or
        # neither way keeps the margin: manoeuvre
        cramped = self._cramped and (not there or self._boxed)
        if (self._stuck(x, y, theta, period_s) or cramped) and not self._planned and pose_fresh:
            self._plan(x, y, theta, obstacles)
        lim = self.limits
        gx, gy, gth = self.goal
        ex, ey = gx - x, gy - y
        dist = math.hypot(ex, ey)
        if self._start_error < 0:
            self._start_error = max(dist, 1e-6)
        heading_err = wrap_angle(gth - theta)
        progress = max(0.0, min(1.0, 1.0 - dist / self._start_error))
        if self._arrived:
            return Command(0.0, 0.0, "arrived", 1.0, dist, 0.0)
        if not pose_fresh:
            return Command(0.0, 0.0, "stale", progress, dist, 0.0)
        near = self._near()
        if self.stage == "final" and dist > LEAVE_FACTOR * near and not self._straight:
            self.stage = "move"  # pushed away: start over
        if self.stage == "start":  # close already: no need to drive towards it first
            self.stage = "final" if dist <= near else "move"
        if self.stage == "move":
            if dist > self._tol:
                moved = self._move(ex, ey, dist, theta, obstacles)
                if moved == "short":  # the way on would not keep the margin: end here
                    self._arrived = True
                    return Command(0.0, 0.0, "arrived", progress, dist, 0.0)
                if isinstance(moved, tuple):
                    return Command(*moved, "following", progress, dist, 0.0, self._turn_left)
                self._straight = moved is None  # boxed in both ways: turn first, then along
            self.stage = "final"
        v, w, done = self._final(ex, ey, heading_err, gth)
        if done and self.goal != self._target:  # a pose of the manoeuvre: on to the next
            lim = self.limits
            if self._via:
                self._aim(*self._via.pop(0), VIA_TOLERANCE_M, VIA_HEADING_RAD)
            else:
                self._aim(*self._target, lim.position_tolerance_m, lim.heading_tolerance_rad)
            return Command(0.0, 0.0, "following", progress, dist, 0.0)
        if done and self._sidestep(x, y):
            return Command(0.0, 0.0, "following", progress, dist, 0.0)
        if done and self._manoeuvre_across(x, y, theta):
            return Command(0.0, 0.0, "following", progress, dist, 0.0)
        if done:
            self._arrived = True
            return Command(0.0, 0.0, "arrived", 1.0, dist, 0.0)
        return Command(v, w, "following", progress, dist, 0.0, self._turn_left)

    def _near(self) -> float:
        """Within this of the goal the move stage hands over to the final stage: ``near_m``
        for a manoeuvre's pose, ``FACE_REACH_M`` for the goal itself, whose error across
        the heading a sidestep takes out (facing a target a hand away costs two turns, the
        first of them maybe the long way round past a wall)."""
        return (
            self.limits.near_m
            if self.goal != self._target
            else max(self.limits.near_m, FACE_REACH_M)
        )

    def _sidestep(self, x: float, y: float) -> bool:
        """At the goal with more than ``lateral_tolerance_m`` across its heading: dock first
        at a pose on the goal's line behind it, then along the line to the goal. The chair
        backs up to it slantwise, as shallow as ``SIDESTEP_REACH`` of the reverse reach
        allows (under ALIGN_RAD it steers while backing instead of turning on the spot),
        at most ``SIDESTEP_RAD`` off the heading. False (arrive as it stands) when the
        footprint there, facing the goal heading or the slant, would hold a point, when
        the goal's own footprint holds one, or after ``SIDESTEPS``."""
        gx, gy, gth = self._target
        c, s = math.cos(gth), math.sin(gth)
        across = -(x - gx) * s + (y - gy) * c
        if abs(across) <= self.limits.lateral_tolerance_m or self._sidesteps >= SIDESTEPS:
            return False
        if not self._fits_at(self._target, gth, self._obstacles, 0.0):
            return False  # the drive along the line would end in a wall (b8208.m07)
        along = (x - gx) * c + (y - gy) * s
        reach = SIDESTEP_REACH * self.limits.reverse_reach_m
        shallow = max(0.9 * ALIGN_RAD, math.atan2(abs(across), reach))
        for slant in sorted({min(shallow, SIDESTEP_RAD), SIDESTEP_RAD}):
            back = max(SIDESTEP_MIN_M, abs(across) / math.tan(slant))
            if math.hypot(back, across) > self.limits.reverse_reach_m:
                continue
            via = (gx + (along - back) * c, gy + (along - back) * s, gth)
            travel = math.atan2(y - via[1], x - via[0])  # the heading it backs up along
            obstacles = self._obstacles
            if self._fits_at(via, gth, obstacles) and self._fits_at(via, travel, obstacles):
                break
        else:
            return False
        self._sidesteps += 1
        self._aim(*via, VIA_TOLERANCE_M, VIA_HEADING_RAD)
        return True

    def _manoeuvre_across(self, x: float, y: float, theta: float) -> bool:
        """At the goal with more than ``near_m`` across its heading (less before a narrow
        doorway: :meth:`_across_limit`) and no room for a sidestep (campaign b1004.m04:
        0.157 m beside the line of the second of two doors in series, the first door's
        jambs behind): plan a manoeuvre onto the goal, once. True if one is under way;
        False (arrive as it stands) if none was found."""
        gx, gy, gth = self._target
        across = -(x - gx) * math.sin(gth) + (y - gy) * math.cos(gth)
        if abs(across) <= self._across or self._planned:
            return False
        self._plan(x, y, theta, self._obstacles)
        return self.goal != self._target

    def _move(
        self, ex: float, ey: float, dist: float, theta: float, obstacles: np.ndarray | None
    ) -> tuple[float, float] | str | None:
        """(v, w) of the move stage: face the target (or away from it), then drive; None
        when the footprint at the target holds a point whichever way it faces; ``"near"``
        when the target is within ``near_m`` but off to a side (a stop short of a wall, or
        pose noise): a turn on the spot to face a target a few centimetres away is worse
        than the final stage's turn to the goal heading and drive along it; ``"short"``
        when, after a manoeuvre, the way on would bring a point within its margin."""
        lim = self.limits
        direction = math.atan2(ey, ex)
        backwards = self._backwards_to(direction, dist)
        ahead = direction + (math.pi if backwards else 0.0)
        # driving (nearly) the way the goal faces ends in the goal's own footprint: a point
        # in it (a leaf a few cm beside the goal) is there whichever way the chair drives,
        # and turning round to back up would flip back and forth as range noise moves the
        # point across the margin (door bench: 20 s of half turns before a door)
        goalward = angle_between(ahead, self.goal[2]) <= GOALWARD_RAD
        if not goalward and not self._fits(ahead, obstacles):
            if not self._fits(direction + (0.0 if backwards else math.pi), obstacles):
                return None
            backwards = self._backwards = not backwards
        bearing = wrap_angle(math.atan2(ey, ex) + (math.pi if backwards else 0.0) - theta)
        w = max(-lim.max_turn, min(lim.max_turn, lim.turn_gain * bearing))
        if abs(bearing) > ALIGN_RAD:
            if dist <= self._near():
                return "near"
            return 0.0, self._turn(math.copysign(max(MIN_TURN, abs(w)), w), abs(bearing))
        self._turn_sign = 0.0
        self._turn_left = abs(bearing)  # it steers to face the target, no further
        v = self._speed(dist) * math.cos(bearing)
        v = -v if backwards else v
        near = self._near()
        if dist <= near and self._arc_sweeps(v, w, dist, abs(bearing)):
            return "near"
        if dist > near and not self._planned and self._arc_sweeps(v, w, dist - near, abs(bearing)):
            self._cramped = True  # the way there passes a point within the margin: manoeuvre
            return 0.0, 0.0
        if dist > near and self._planned and self.plan_margin is not None:
            # after a manoeuvre no other is planned: the drive goes on while the next
            # PLANNED_LOOK_M of it keeps the plan's margin, and ends where it would not
            # (b8210.m01, b8208.m07: straight drives the search had not checked)
            margin = min(self.margin_m, self.plan_margin)
            if self._arc_sweeps(v, w, min(dist - near, PLANNED_LOOK_M), abs(bearing), margin):
                return (0.0, 0.0) if self._replan() else "short"
        return v, w

    def _final(
        self, ex: float, ey: float, heading_err: float, goal_heading: float
    ) -> tuple[float, float, bool]:
        """(v, w, done) of the final stage: turn to the goal heading on the spot, then
        drive out the error along it (the error across it, under ``near_m``, stays)."""
        lim = self.limits
        turn = lim.turn_gain * abs(heading_err)
        w = math.copysign(max(MIN_TURN, min(lim.max_turn, turn)), heading_err)
        if abs(heading_err) > max(self._tol_heading, ALIGN_RAD / 2):
            shift = self._shift(ex, ey, heading_err, goal_heading)
            if shift:
                return math.copysign(self._speed(abs(shift)), shift), 0.0, False
            return 0.0, self._turn(w, abs(heading_err)), False
        self._turn_sign = 0.0
        along = ex * math.cos(goal_heading) + ey * math.sin(goal_heading)
        if abs(along) > self._tol:
            self._turn_left = abs(heading_err)
            return math.copysign(self._speed(abs(along)), along), lim.turn_gain * heading_err, False
        if abs(heading_err) > self._tol_heading:
            self._turn_left = abs(heading_err)
            return 0.0, w, False
        return 0.0, 0.0, True

    def _shift(self, ex: float, ey: float, heading_err: float, goal_heading: float) -> float:
        """Metres to drive along the chair's heading (negative: backwards) before the
        final turn, so the goal's error across its heading is gone: 0 unless the goal
        itself is more than ``lateral_tolerance_m`` across, the chair is turned more than
        ``SHIFT_RAD`` off (so the drive is short and mostly across), the goal and the drive
        are within ``FACE_REACH_M`` and the footprint where it ends holds no point."""
        if self.goal != self._target or abs(math.sin(heading_err)) < math.sin(SHIFT_RAD):
            return 0.0
        if math.hypot(ex, ey) > FACE_REACH_M:  # far: the final stage only as a way round
            return 0.0
        across = -ex * math.sin(goal_heading) + ey * math.cos(goal_heading)
        if abs(across) <= self.limits.lateral_tolerance_m:
            return 0.0
        dist = across / math.sin(-heading_err)  # each metre moves sin(theta - goal) across
        x, y, theta = self._pose
        end = (x + dist * math.cos(theta), y + dist * math.sin(theta), theta)
        if abs(dist) > FACE_REACH_M or not self._fits_at(end, theta, self._obstacles):
            return 0.0
        return dist

    def _turn(self, w: float, left_rad: float = SWEEP_RAD) -> float:
        """``w`` for a turn on the spot (``left_rad`` of it to go), or the other way round
        when this way would sweep a corner into an obstacle point and the whole of the
        other way would not (a point off the front on one side, near a half turn); kept
        until aligned. Neither: this way, marked cramped (a manoeuvre may be needed)."""
        turned = w
        kept = self._kept_margin()
        replan = not self._turn_sign and kept is not None and self._sweeps(w, left_rad, kept)
        if replan and self._replan():
            return 0.0
        if self._turn_sign:
            turned = math.copysign(abs(w), self._turn_sign)
        elif self._sweeps(w, left_rad):
            self._cramped = True  # the short way is held: a manoeuvre may be needed
            if not self._sweeps_all(-w, 2.0 * math.pi - left_rad):
                self._turn_sign = -math.copysign(1.0, w)
                turned = -w
            elif not self._planned:
                # neither way keeps the margin: plan a manoeuvre before turning, not leave
                # it to the safety checks (b8405.m02: their hold on a jamb's corner let
                # go, 4.6 cm from it); none found, the turn goes on as before
                self._boxed = True
                return 0.0
        self._turn_left = left_rad if turned * w > 0 else 2.0 * math.pi - left_rad
        return turned

    def _sweeps(self, w: float, left_rad: float = SWEEP_RAD, margin_m: float | None = None) -> bool:
        """True if turning on the spot the way of ``w``, ``SWEEP_RAD`` or the ``left_rad``
        still to go if less, brings an obstacle point within ``margin_m`` (by default the
        docker's) of the footprint, or one already that near nearer still (none, without
        points)."""
        local = self._local_points()
        if local is None:
            return False
        fp = self.footprint
        angle = math.copysign(min(SWEEP_RAD, left_rad), w)
        margin = self.margin_m if margin_m is None else margin_m
        return turn_closes_in(local, fp.front, fp.rear, fp.width, margin, angle)

    def _kept_margin(self) -> float | None:
        """The margin the manoeuvre under way keeps to scan points (None: none is)."""
        if not self._planned or self.plan_margin is None:
            return None
        return min(self.margin_m, self.plan_margin)

    def _replan(self) -> bool:
        """Plan the manoeuvre under way again from here, at most ``REPLANS`` times a goal:
        the scan now shows it would bring a point within its margin, a face the scan it
        was planned on did not show (campaign b8200.m00: the far side of a column in a
        hall, hidden from where the manoeuvre began, swept by the rear corner of a turn
        planned beside it). True if it was (a new manoeuvre, or none found: docking as
        usual from here)."""
        if self._replans >= REPLANS or self._pose is None:
            return False
        self._replans += 1
        self._via, self.plan_margin = [], None
        lim = self.limits
        self._aim(*self._target, lim.position_tolerance_m, lim.heading_tolerance_rad)
        self._plan(*self._pose, self._obstacles)
        return True

    def _sweeps_all(self, w: float, turn_rad: float) -> bool:
        """True if turning on the spot the way of ``w`` by the whole of ``turn_rad`` (at
        ``turn_closes_in``'s poses) brings an obstacle point within ``margin_m`` of the
        footprint, or one already that near nearer still: the long way round is taken only
        when all of it is clear, not its first ``SWEEP_RAD`` (on a long turn the corners
        sweep nearly their whole circles)."""
        local = self._local_points()
        if local is None:
            return False
        fp = self.footprint
        angle = math.copysign(turn_rad, w)
        return turn_closes_in(local, fp.front, fp.rear, fp.width, self.margin_m, angle)

    def _arc_sweeps(
        self, v: float, w: float, dist: float, turn_rad: float, margin_m: float | None = None
    ) -> bool:
        """True if driving ``dist`` along the arc of (``v``, ``w``), turning at most
        ``turn_rad``, brings an obstacle point within ``margin_m`` (by default the docker's)
        of the footprint, or one already that near nearer still. Campaign b7300w.m04:
        steering 7 deg onto a pose 9 cm away swung the front corner at an open leaf, the
        guard held it and the chair stood; the final stage's drive along the goal heading
        turned away from the leaf."""
        local = self._local_points()
        if local is None or abs(v) < 1e-6:
            return False
        fp = self.footprint
        length = math.copysign(dist, v)
        poses = swept_arc_poses(length, w / v, turn_rad, fp.front, fp.rear, fp.width)
        margin = self.margin_m if margin_m is None else margin_m
        return moves_close_in(local, fp.front, fp.rear, fp.width, margin, poses)

    def _local_points(self) -> np.ndarray | None:
        """The obstacle points in the chair's frame at its pose (None: no points or no
        footprint to check them against)."""
        fp, pts = self.footprint, self._obstacles
        if pts is None or fp is None or len(pts) == 0:
            return None
        return into_frame(pts, *self._pose)

    def _fits(self, heading: float, pts: np.ndarray | None) -> bool:
        """True if the footprint (grown by ``margin_m``) at the goal point facing
        ``heading`` holds none of ``pts`` (always, without points)."""
        return self._fits_at(self.goal, heading, pts)

    def _fits_at(
        self,
        pose: tuple[float, float, float],
        heading: float,
        pts: np.ndarray | None,
        margin_m: float | None = None,
    ) -> bool:
        """True if the footprint (grown by ``margin_m``, by default the docker's) at
        ``pose``'s point facing ``heading`` holds none of ``pts`` (always, without points)."""
        margin = self.margin_m if margin_m is None else margin_m
        fp = self.footprint
        if pts is None or fp is None or len(pts) == 0:
            return True
        local = into_frame(pts, pose[0], pose[1], heading)
        return not bool(in_footprint(local, fp.front, fp.rear, fp.width, margin).any())

    def _backwards_to(self, direction: float, dist: float) -> bool:
        """Drive backwards to a target in ``direction``? Within ``reverse_reach_m``, the
        way that leaves the chair closer to the goal heading (a target behind a chair
        facing the door: back up; a pose across a corridor facing the other way: turn
        first, then back into it, never nose up to the wall or the car door in front);
        keeps its choice unless the other way is better by ``SWITCH_RAD``. A manoeuvre's
        pose is driven to the way the search planned it, however far (its heading is the
        drive's): a 1.15 m back-up planned past the reach turned the chair round twice."""
        if dist > self.limits.reverse_reach_m and self.goal == self._target:
            self._backwards = False
            return False
        goal = self.goal[2]
        fwd = angle_between(direction, goal)
        rev = angle_between(direction + math.pi, goal)
        if self._backwards is None or abs(fwd - rev) > SWITCH_RAD:
            self._backwards = rev < fwd
        return self._backwards

    def _speed(self, remaining: float) -> float:
        return min(self._cap, max(MIN_SPEED, self.limits.speed_gain * remaining))


def _moves(poses: list[tuple[float, float, float]], start: tuple[float, float, float]) -> bool:
    """True if any of a manoeuvre's ``poses`` lies further from ``start`` than a pose of
    it is reached within (a search whose goal does not fit may end where it starts)."""
    return any(
        math.hypot(p[0] - start[0], p[1] - start[1]) > VIA_TOLERANCE_M
        or abs(wrap_angle(p[2] - start[2])) > VIA_HEADING_RAD
        for p in poses
    )


def _ends_on(end: tuple[float, float, float], goal: tuple[float, float, float]) -> bool:
    """True if a manoeuvre ending at ``end`` leaves at most ``ENDS_ON_M`` across the goal's
    heading (what is left along it, the final stage drives out)."""
    c, s = math.cos(goal[2]), math.sin(goal[2])
    return abs(-(end[0] - goal[0]) * s + (end[1] - goal[1]) * c) <= ENDS_ON_M
