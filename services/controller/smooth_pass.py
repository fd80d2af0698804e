"""A door passed without stopping: the scan's doorway, a Bézier onto its centre line, through.

Every cycle the doorways in the latest scan are fused into the door estimate
(``shared.door_scan``); the estimate nearest the mapped door decides. The goal is on the
door's centre line ``lookahead_m`` before the approach line (``lead_m`` before its plane),
facing through it; the chair follows the
smoothest curve onto it (``door_bezier``), re-planned from the current pose and the latest
estimate each cycle; on the line, the goal moves ``lookahead_m`` ahead along it, through
the doorway until the reference point is ``through_m`` past the plane. The chair turns at
its speed times the curve's curvature where it stands (the curve starts along its
heading: no lookahead point to cut the corner to, as pure pursuit's was); the speed is
the path's, less where the curve's curvature asks more than the lateral acceleration
allows, and in the doorway as much as the gap a side allows (``PassSettings``; braking
into it). Facing away from the door (no curve) it asks for stop-turn-go instead. Pure: no
I/O; poses in the map frame, scan points in the sensor frame at the pose.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from services.controller.door_bezier import door_curve
from shared.config import DoorScanConfig
from shared.door_scan import DoorTracker, find_doorways

RUNNING, THROUGH, FALLBACK = "running", "through", "fallback"


@dataclass(frozen=True)
class PassSettings:
    """How a smooth pass drives. ``door_speed``: the most anywhere (the path's speed);
    in the doorway, while any of the chair is within ``zone_m`` of the door plane, at most
    ``gap_rate`` times the gap a side ((door width - chair width) / 2: the seed's 0.2 m/s
    at the paper's 7.5 cm is 2.67 per second) and ``doorway_speed``; braking into it at
    ``decel``."""

    door_speed: float = 0.2
    lateral_accel: float = 0.3
    lead_m: float = 1.5  # the curve ends this far before the door plane, on the line
    through_m: float = 1.2  # done when the reference point is this far past the plane
    lookahead_m: float = 0.5
    join_m: float = 0.5  # the scan's doorway is the mapped one within this distance
    door_width: float = 0.0  # the mapped width (0: unknown: the doorway speed applies)
    chair_width: float = 0.65
    front_m: float = 0.76
    rear_m: float = 0.35
    gap_rate: float = 0.2 / 0.075
    doorway_speed: float = 0.2
    zone_m: float = 0.3
    decel: float = 0.3
    offset_m: float = 0.0  # the line this far left of the doorway's middle (facing through)
    max_turn_rate: float = 1.0  # the chair's (robot.max_turn_rate)
    turn_accel: float = 1.0  # the turn is slowed to a stop at this as the bend runs out


class SmoothPass:
    """One pass through one door: ``step`` each control cycle until it is through."""

    def __init__(
        self,
        door_centre: tuple[float, float],
        door_normal: float,
        settings: PassSettings | None = None,
        scan: DoorScanConfig | None = None,
    ) -> None:
        self.settings = settings or PassSettings()
        self.scan_cfg = scan or DoorScanConfig()
        self.mapped = np.array(door_centre, dtype=float)
        self.normal = np.array([math.cos(door_normal), math.sin(door_normal)])
        self.tracker = DoorTracker(self.scan_cfg.join_m, self.scan_cfg.near_m)
        self.centre = self.mapped.copy()  # the mapped door until the scan shows it
        self.width = self.settings.door_width  # as the scan shows it, once it does
        self.seen = 0  # sightings fused into the estimate used

    def _update_door(self, pose: tuple[float, float, float], scan: np.ndarray | None) -> None:
        if scan is None or len(scan) == 0:
            return
        self.tracker.add(find_doorways(scan, self.scan_cfg), pose)
        near = [
            e
            for e in self.tracker.estimates()
            if np.linalg.norm(e.centre - self.mapped) <= self.settings.join_m
        ]
        if near:
            best = max(near, key=lambda e: e.sightings)
            self.centre, self.seen, self.width = best.centre, best.sightings, best.width
            n = best.normal if np.dot(best.normal, self.normal) > 0 else -best.normal
            self.normal = n

    def doorway_speed(self) -> float:
        """The most in the doorway: the side gap times ``gap_rate``, at most
        ``doorway_speed`` when the width is unknown or the gap is that of the paper's door."""
        s = self.settings
        if self.width <= 0:
            return min(s.doorway_speed, s.door_speed)
        gap = max(0.0, (self.width - s.chair_width) / 2)
        return max(min(s.door_speed, s.gap_rate * gap), 0.05)

    def _doorway_limit(self, past: float) -> float:
        """The speed limit where the reference point is ``past`` the door plane: the
        doorway speed while the footprint is within ``zone_m`` of the plane (before it,
        from the approach line's start on), braking into it before, the door speed once
        the rear is out of it."""
        s = self.settings
        v_door = self.doorway_speed()
        # the approach line's start (lead_m) is where the front stands clear of all the
        # door sweeps (a hinged leaf opening towards the chair): from there it is the door's
        before = max(s.zone_m, s.lead_m - s.front_m)
        to_zone = -(past + s.front_m) - before  # the front's way to the zone
        if to_zone > 0:
            return math.sqrt(v_door**2 + 2 * s.decel * to_zone)
        if past - s.rear_m > s.zone_m:
            return s.door_speed
        return v_door

    def _turn_limit(self, curve) -> float:
        """The most speed at which the turn the curve asks for here (speed x curvature) is
        one the chair makes: at most ``max_turn_rate``, and slow enough to stop turning at
        ``turn_accel`` by the end of the bend it is in (the heading still to turn that
        way): a chair still turning at 1 rad/s as it comes onto the door's line swings
        past it (campaign b0.m00: 16 deg, a corner 3.2 cm from the jamb)."""
        k = curve.curvature
        if abs(k[0]) < 1e-6:
            return math.inf
        same = np.sign(k) == np.sign(k[0])
        bend = int(np.argmin(same)) if not same.all() else len(k)  # its points
        turning = np.abs(k[:-1]) * np.hypot(*np.diff(curve.points, axis=0).T)  # per segment
        to_turn = float(turning[: bend - 1].sum())
        w = min(self.settings.max_turn_rate, math.sqrt(2 * self.settings.turn_accel * to_turn))
        return w / abs(float(k[0]))

    def to_go(self, pose: tuple[float, float, float]) -> float:
        """How far the reference point still is from the pass's end, along the door's
        normal (from before the plane: the lead and the curve's start not counted)."""
        past = float(np.dot(np.array(pose[:2]) - self.centre, self.normal))
        return max(0.0, self.settings.through_m - past)

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
        # the goal: on the centre line lookahead_m before the approach line's start
        # (lead_m before the plane: from there the front is in the door's zone, beside a
        # leaf swung open towards it), the chair aligned by then; once the chair is within
        # lookahead_m of it, lookahead_m ahead of the chair along the line (the curve keeps
        # re-planning onto the line, as the paper's does, and never ends under the chair)
        along = min(
            max(-(s.lead_m + s.lookahead_m), past + s.lookahead_m), s.through_m + s.lookahead_m
        )
        left = np.array([-self.normal[1], self.normal[0]])
        goal = self.centre + s.offset_m * left + along * self.normal
        curve = door_curve(pose, (float(goal[0]), float(goal[1]), heading))
        if curve is None:
            return 0.0, 0.0, FALLBACK
        step = np.hypot(*np.diff(curve.points, axis=0).T)
        ahead = np.concatenate([[0.0], np.cumsum(step)]) <= s.lookahead_m
        limit = float(curve.speed_limit(s.door_speed, s.lateral_accel)[ahead].min())
        v = min(limit, self._doorway_limit(past), self._turn_limit(curve))
        # steer with the curve's own curvature where the chair stands: the curve starts
        # along the chair's heading, so following it is turning at v x its curvature
        return v, v * float(curve.curvature[0]), RUNNING
