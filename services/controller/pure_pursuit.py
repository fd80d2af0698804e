"""Pure pursuit: follow a path with a pure-pursuit law and the path's speed profile.

The simple, exact tracker beside the MPC (services/controller/tracking.py picks): it
drives reverse paths, precise passes through doors and into lift cars, and the last
part of every path. It projects the pose onto the path (progress never goes
backwards), faces the path before setting off, steers towards a point ``lookahead_m``
further on, turns on the spot when that point is far off the heading, takes the speed
from the path's ``v_ref`` and stops within ``goal_tolerance_m`` of the last waypoint.
On a precise path (a pass through a door, into or out of a lift car) the turn rate is
``pass_heading_gain`` times the angle to that point: pure pursuit's curvature law is
soft at door speed (2 v / d per radian), so a yaw kick as the casters swing round at
set-off would still turn the nose 2-3 deg off the line as it enters the doorway.
A stale pose gives a zero command.
"""

from __future__ import annotations

import math

import numpy as np

from services.controller.command import Command
from shared.config import ControllerConfig, RobotConfig
from shared.geometry import wrap_angle

TURN_IN_PLACE_RAD = math.radians(60)


class PathFollower:
    """Tracks one path at a time; ``set_path`` replaces it, an empty path means stop."""

    def __init__(self, cfg: ControllerConfig, robot: RobotConfig) -> None:
        self.cfg = cfg
        self.robot = robot
        self.path_id = ""
        self.reverse = False
        self.precise = False
        self._pts = np.zeros((0, 2))
        self._v = np.zeros(0)
        self._s = np.zeros(0)
        self._progress_s = 0.0
        self._arrived = False

    def set_path(
        self,
        path_id: str,
        waypoints: np.ndarray,
        v_ref: np.ndarray,
        reverse: bool = False,
        precise: bool = False,
    ) -> None:
        """Start following ``waypoints`` (N, 2) with speeds ``v_ref`` (N,), backwards if
        ``reverse`` (out of a lift car, where the chair cannot turn), holding the line
        stiffly if ``precise`` (a pass)."""
        self.path_id = path_id
        self.reverse = reverse
        self.precise = precise
        self._pts = np.asarray(waypoints, dtype=float)
        self._v = np.asarray(v_ref, dtype=float)
        legs = np.linalg.norm(np.diff(self._pts, axis=0), axis=1) if len(self._pts) else []
        self._s = np.concatenate([[0.0], np.cumsum(legs)]) if len(self._pts) else np.zeros(0)
        self._progress_s = 0.0
        self._arrived = False

    @property
    def active(self) -> bool:
        return len(self._pts) > 0

    def step(self, x: float, y: float, theta: float, pose_fresh: bool = True) -> Command:
        """The command for pose (x, y, theta); zero when idle, arrived or the pose is stale."""
        if not self.active:
            return Command(0.0, 0.0, "idle")
        total = float(self._s[-1])
        s, cross = self._project(np.array([x, y]))
        self._progress_s = max(self._progress_s, s)
        goal = self._pts[-1]
        to_goal = float(math.hypot(goal[0] - x, goal[1] - y))
        progress = self._progress_s / total if total > 0 else 1.0
        tol = self.cfg.goal_tolerance_m
        # half way along, or near the end of a path hardly longer than the tolerance (a
        # loop back to its start is not over at its start)
        near_end = progress > 0.5 or total - self._progress_s <= 2 * tol
        if self._arrived or (to_goal <= tol and near_end):
            self._arrived = True
            return Command(0.0, 0.0, "arrived", 1.0, to_goal, cross)
        if not pose_fresh:
            return Command(0.0, 0.0, "stale", progress, to_goal, cross)
        if self.reverse:  # steer the chair's back as if it were its front, then drive backwards
            theta = wrap_angle(theta + math.pi)
        target = self._point_at(self._progress_s + self.cfg.lookahead_m)
        if to_goal < self.cfg.lookahead_m:
            target = goal
        alpha = wrap_angle(math.atan2(target[1] - y, target[0] - x) - theta)
        r = self.robot
        w_max = r.max_turn_rate
        starting = self._progress_s < self.cfg.start_align_m
        limit = math.radians(self.cfg.start_align_deg) if starting else TURN_IN_PLACE_RAD
        if abs(alpha) > limit:  # face the path before setting off (doors, lift cars)
            w = max(-w_max, min(w_max, self.cfg.heading_gain * alpha))
            return Command(0.0, w, "following", progress, to_goal, cross)
        v_max = r.max_reverse_speed if self.reverse else r.max_speed
        v_ref = float(np.interp(self._progress_s, self._s, self._v))
        v_ref = max(v_ref, min(0.1, v_max)) if to_goal > self.cfg.goal_tolerance_m else 0.0
        v = min(v_ref, v_max) * max(0.0, math.cos(alpha))
        if self.precise:
            w = self.cfg.pass_heading_gain * alpha
        else:
            dist = max(float(math.hypot(target[0] - x, target[1] - y)), 1e-6)
            w = 2.0 * v * math.sin(alpha) / dist  # pure-pursuit curvature times speed
        w = max(-w_max, min(w_max, w))
        return Command(-v if self.reverse else v, w, "following", progress, to_goal, cross)

    def _project(self, p: np.ndarray) -> tuple[float, float]:
        """Arc length of the closest path point at or ahead of current progress, and distance."""
        a, b = self._pts[:-1], self._pts[1:]
        if len(a) == 0:
            return 0.0, float(np.linalg.norm(p - self._pts[0]))
        d = b - a
        seg_len2 = np.maximum((d * d).sum(axis=1), 1e-12)
        t = np.clip(((p - a) * d).sum(axis=1) / seg_len2, 0.0, 1.0)
        closest = a + d * t[:, None]
        dist = np.linalg.norm(closest - p, axis=1)
        s = self._s[:-1] + t * np.sqrt(seg_len2)
        window = s >= self._progress_s - 0.5  # no jumping back along the path
        dist = np.where(window, dist, np.inf)
        i = int(np.argmin(dist))
        return float(s[i]), float(dist[i])

    def _point_at(self, s: float) -> np.ndarray:
        s = min(s, float(self._s[-1]))
        return np.array(
            [np.interp(s, self._s, self._pts[:, 0]), np.interp(s, self._s, self._pts[:, 1])]
        )
