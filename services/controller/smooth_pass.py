"""A door passed without stopping: the scan's doorway, a Bézier onto its centre line, through.

Every cycle the doorways in the latest scan are fused into the door estimate
(``shared.door_scan``); the estimate nearest the mapped door decides. The goal is on the
door's centre line ``lead_m`` before its plane, facing through it; the chair follows the
smoothest curve onto it (``door_bezier``), re-planned from the current pose and the latest
estimate each cycle, then the centre line itself through the doorway until its reference
point is ``through_m`` past the plane. Steering is pure pursuit on that path; the speed is
the door speed, less where the curve's curvature asks more than the lateral acceleration
allows. Facing away from the door (no curve) it asks for stop-turn-go instead. Pure: no
I/O; poses in the map frame, scan points in the sensor frame at the pose.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from services.controller.door_bezier import door_curve
from shared.door_scan import DoorTracker, find_doorways

RUNNING, THROUGH, FALLBACK = "running", "through", "fallback"


@dataclass(frozen=True)
class PassSettings:
    """How a smooth pass drives (the fleet config's door speed, the footprint's front)."""

    door_speed: float = 0.2
    lateral_accel: float = 0.3
    lead_m: float = 1.5  # the curve ends this far before the door plane, on the line
    through_m: float = 1.2  # done when the reference point is this far past the plane
    lookahead_m: float = 0.4
    join_m: float = 0.5  # the scan's doorway is the mapped one within this distance


class SmoothPass:
    """One pass through one door: ``step`` each control cycle until it is through."""

    def __init__(
        self,
        door_centre: tuple[float, float],
        door_normal: float,
        settings: PassSettings | None = None,
    ) -> None:
        self.settings = settings or PassSettings()
        self.mapped = np.array(door_centre, dtype=float)
        self.normal = np.array([math.cos(door_normal), math.sin(door_normal)])
        self.tracker = DoorTracker()
        self.centre = self.mapped.copy()  # the mapped door until the scan shows it
        self.seen = 0  # sightings fused into the estimate used

    def _update_door(self, pose: tuple[float, float, float], scan: np.ndarray | None) -> None:
        if scan is None or len(scan) == 0:
            return
        self.tracker.add(find_doorways(scan), pose)
        near = [
            e
            for e in self.tracker.estimates()
            if np.linalg.norm(e.centre - self.mapped) <= self.settings.join_m
        ]
        if near:
            best = max(near, key=lambda e: e.sightings)
            self.centre, self.seen = best.centre, best.sightings
            n = best.normal if np.dot(best.normal, self.normal) > 0 else -best.normal
            self.normal = n

    def step(
        self, pose: tuple[float, float, float], scan: np.ndarray | None
    ) -> tuple[float, float, str]:
        """(v, w, state) for this cycle: state RUNNING, THROUGH (stop: done) or FALLBACK."""
        self._update_door(pose, scan)
        s = self.settings
        p = np.array(pose[:2])
        past = float(np.dot(p - self.centre, self.normal))
        if past >= s.through_m:
            return 0.0, 0.0, THROUGH
        heading = math.atan2(self.normal[1], self.normal[0])
        goal = self.centre - s.lead_m * self.normal
        line_end = self.centre + (s.through_m + s.lookahead_m) * self.normal
        if float(np.dot(p - goal, self.normal)) >= -0.05:  # on the line: straight through
            path = np.array([goal, line_end])
            limit = s.door_speed
        else:
            curve = door_curve(pose, (float(goal[0]), float(goal[1]), heading))
            if curve is None:
                return 0.0, 0.0, FALLBACK
            path = np.vstack([curve.points, line_end])
            near = int(np.argmin(np.hypot(*(curve.points - p).T)))
            limit = float(curve.speed_limit(s.door_speed, s.lateral_accel)[near])
        target = _ahead(path, p, s.lookahead_m)
        dx, dy = target - p
        c, sn = math.cos(pose[2]), math.sin(pose[2])
        lateral = -sn * dx + c * dy
        dist2 = max(dx * dx + dy * dy, 1e-6)
        v = limit
        return v, 2.0 * v * lateral / dist2, RUNNING


def _ahead(path: np.ndarray, p: np.ndarray, lookahead: float) -> np.ndarray:
    """The point ``lookahead`` along ``path`` from the path point nearest ``p``."""
    seg = np.diff(path, axis=0)
    length = np.hypot(*seg.T)
    cum = np.concatenate([[0.0], np.cumsum(length)])
    t = np.clip(np.einsum("ij,ij->i", p - path[:-1], seg) / np.maximum(length**2, 1e-12), 0, 1)
    d = np.hypot(*(path[:-1] + t[:, None] * seg - p).T)
    k = int(np.argmin(d))
    at = cum[k] + t[k] * length[k] + lookahead
    i = int(np.searchsorted(cum, at, side="right")) - 1
    if i >= len(seg):
        return path[-1]
    f = (at - cum[i]) / max(length[i], 1e-9)
    return path[i] + f * seg[i]
