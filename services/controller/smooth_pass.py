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
from services.controller.mpc_scene import footprint_points
from shared.config import DoorScanConfig, Footprint
from shared.door_scan import DoorTracker, find_doorways

RUNNING, THROUGH, FALLBACK = "running", "through", "fallback"
PREDICT_DT_S = 0.1  # the step of the pass's prediction (an ideal unicycle)
PREDICT_STEPS = 300  # at most (30 s of it)
REPREDICT_M = 0.02  # predicted again before the jamb when the door estimate moves this
ON_LINE_M, ON_LINE_RAD = 0.002, 0.002  # on the line and along it: the prediction is done
STOP_SLACK_M = 0.05  # a front this far past the stop line has committed to the door


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
    corner_excess_m: float = 0.03  # the most a corner may stray off the line in the jamb
    outline_clearance_m: float = 0.05  # ... or closer to a jamb, the centre not yet in it
    jamb_depth_m: float = 0.1  # the jamb either side of the plane until the reveal is seen
    open_by_m: float = 0.3  # the front stops this far before the plane until seen open


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
        st = self.settings
        outline, _ = footprint_points(Footprint(st.chair_width, st.rear_m, st.front_m), 0.02)
        self._outline = outline.astype(np.float64).T  # (2, N): x forwards, y to the left
        self._predicted: np.ndarray | None = None  # the door estimate last predicted on
        self.jamb = st.jamb_depth_m  # the jamb either side of the plane
        self.open = False  # the doorway as the latest scan that showed it saw it

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
            if best.depth is not None:  # the reveal seen: the wall's own thickness
                self.jamb = best.depth / 2
            self.open = best.open
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

    def _turn_limit(self, curve, segments: np.ndarray) -> float:
        """The most speed at which the turn the curve asks for here (speed x curvature) is
        one the chair makes: at most ``max_turn_rate``, and slow enough to stop turning at
        ``turn_accel`` by the end of the bend it is in (the heading still to turn that
        way): a chair still turning at 1 rad/s as it comes onto the door's line swings
        past it (campaign b0.m00: 16 deg, a corner 3.2 cm from the jamb). ``segments``:
        the lengths between the curve's points."""
        k = curve.curvature
        if abs(k[0]) < 1e-6:
            return math.inf
        same = np.sign(k) == np.sign(k[0])
        bend = int(np.argmin(same)) if not same.all() else len(k)  # its points
        turning = np.abs(k[:-1]) * segments  # the heading turned per segment
        to_turn = float(turning[: bend - 1].sum())
        w = min(self.settings.max_turn_rate, math.sqrt(2 * self.settings.turn_accel * to_turn))
        return w / abs(float(k[0]))

    def jambs(self) -> np.ndarray:
        """The door's two jambs (2, 2; map frame) as the pass knows the door now: the scan's
        centre and width once it shows them, the map's before."""
        along = np.array([-self.normal[1], self.normal[0]]) * (self.width / 2)
        return np.stack([self.centre - along, self.centre + along])

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
        if self._before_jamb(pose) and self._moved_since_predicted():
            self._predicted = self.centre.copy()
            centred, outline = self.predicted_excess(pose)
            if centred > self._allowed() or outline > self._allowed_outline():
                return 0.0, 0.0, FALLBACK  # it would still be turning in the doorway
        v, w, state = self._command(pose)
        stop = self._stop_short(pose)
        if v > stop:
            v, w = stop, w * stop / v
        return v, w, state

    def _stop_short(self, pose: tuple[float, float, float]) -> float:
        """The most speed from which the front stops ``open_by_m`` before the door plane
        (braking at ``decel``) while the scans have not shown the doorway open; no limit
        once they have or once the front is past that line. The navigator verifies the
        door before the front is its ``smooth_commit_m`` before the plane and stops the
        chair if it cannot; this holds if the navigator has died in between."""
        if self.open:
            return math.inf
        to_line = -self.settings.open_by_m - float(self._frame(*pose)[0].max())
        if to_line < -STOP_SLACK_M:
            return math.inf  # committed: stopping now would leave it in the doorway
        return math.sqrt(2 * self.settings.decel * max(to_line, 0.0))

    def _command(self, pose: tuple[float, float, float]) -> tuple[float, float, str]:
        """The cycle's (v, w, state) on the current door estimate."""
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
        v = min(limit, self._doorway_limit(past), self._turn_limit(curve, step))
        # steer with the curve's own curvature where the chair stands: the curve starts
        # along the chair's heading, so following it is turning at v x its curvature
        return v, v * float(curve.curvature[0]), RUNNING

    # -- will it line up before the doorway? ----------------------------------------------

    def predicted_excess(self, pose: tuple[float, float, float]) -> tuple[float, float]:
        """How far a point of the footprint's outline would stray beyond the half width
        off the line within the jamb's depth of the door plane, at most, were the chair
        from ``pose`` to follow this pass exactly (an ideal unicycle, the door where it is
        estimated now, every ``PREDICT_DT_S``) until it is on the line or through: while
        the footprint's centre is in the jamb (passing), and while only its outline is
        (its front entering, still turning).

        The curve alone does not tell: it is re-planned every cycle and the speed is cut
        where it turns, so a chair facing 66 degrees off the door 1 m before it turns
        nearly in place and is on the line in time (campaign b0.m00), while one beside the
        line facing along the wall still turns in the doorway (b8908.m01)."""
        x, y, th = pose
        centred = outline = 0.0
        for _ in range(PREDICT_STEPS):
            excess, centre_in = self._excess_at(x, y, th)
            if centre_in:
                centred = max(centred, excess)
            else:
                outline = max(outline, excess)
            if self._rear_past_jamb((x, y, th)) or self._on_line(x, y, th):
                break
            v, w, state = self._command((x, y, th))
            if state != RUNNING:
                break
            mid = th + 0.5 * w * PREDICT_DT_S
            x += v * PREDICT_DT_S * math.cos(mid)
            y += v * PREDICT_DT_S * math.sin(mid)
            th += w * PREDICT_DT_S
        return centred, outline

    def _gap(self) -> float | None:
        """The gap a side on the pass's line: the scan's width (else the mapped one) less
        the line's offset and the chair; None while the width is unknown."""
        s = self.settings
        if self.width <= 0:
            return None
        return self.width / 2 - abs(s.offset_m) - s.chair_width / 2

    def _allowed(self) -> float:
        """How far a corner may stray beyond the half width off the line while the
        footprint's centre is in the jamb: ``corner_excess_m``, less where the gap a side
        leaves less (the campaign's limit while passing: the gap less 3 cm)."""
        gap = self._gap()
        excess = self.settings.corner_excess_m
        return excess if gap is None else max(0.0, min(excess, gap))

    def _allowed_outline(self) -> float:
        """... and while only its outline is: as close as ``outline_clearance_m`` to a
        jamb (the campaign's limit away from doors), or the first limit where that is more
        (a narrow door)."""
        gap = self._gap()
        if gap is None:
            return self._allowed()
        return max(self._allowed(), gap - self.settings.outline_clearance_m)

    def _moved_since_predicted(self) -> bool:
        """No prediction yet, or the door estimate has moved ``REPREDICT_M`` since it."""
        return self._predicted is None or bool(
            np.linalg.norm(self.centre - self._predicted) > REPREDICT_M
        )

    def _frame(self, x: float, y: float, th: float) -> tuple[np.ndarray, np.ndarray]:
        """The outline's points as (along the normal from the plane, left of the line)."""
        s = self.settings
        left = np.array([-self.normal[1], self.normal[0]])
        rel = np.array([x, y]) - (self.centre + s.offset_m * left)
        turn = th - math.atan2(self.normal[1], self.normal[0])
        c, sn = math.cos(turn), math.sin(turn)
        fx, fy = self._outline
        along = float(rel @ self.normal) + c * fx - sn * fy
        lat = float(rel @ left) + sn * fx + c * fy
        return along, lat

    def _excess_at(self, x: float, y: float, th: float) -> tuple[float, bool]:
        """How far the outline strays beyond the half width off the line within the jamb
        (0 if none of it is there), and whether the footprint's centre is in the jamb."""
        along, lat = self._frame(x, y, th)
        in_jamb = np.abs(along) <= self.jamb
        if not in_jamb.any():
            return 0.0, False
        centre = (along.min() + along.max()) / 2  # the outline's corners are on it
        excess = float(np.abs(lat[in_jamb]).max()) - self.settings.chair_width / 2
        return excess, bool(abs(centre) <= self.jamb)

    def _on_line(self, x: float, y: float, th: float) -> bool:
        """On the line and along it (within ``ON_LINE_M`` and ``ON_LINE_RAD``): from here
        the pass runs straight, its corners no further off than now."""
        left = np.array([-self.normal[1], self.normal[0]])
        lat = float((np.array([x, y]) - self.centre) @ left) - self.settings.offset_m
        turn = abs(math.remainder(th - math.atan2(self.normal[1], self.normal[0]), math.tau))
        return abs(lat) <= ON_LINE_M and turn <= ON_LINE_RAD

    def _before_jamb(self, pose: tuple[float, float, float]) -> bool:
        return bool(self._frame(*pose)[0].max() < -self.jamb)

    def _rear_past_jamb(self, pose: tuple[float, float, float]) -> bool:
        return bool(self._frame(*pose)[0].min() > self.jamb)
