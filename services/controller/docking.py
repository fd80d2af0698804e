"""Docking: drive to one pose, slowly and exactly (the seed's Phase 0 position correction).

The seed corrected its position before a door by turning towards the target, driving
forwards or backwards to it and stopping within 0.15 m and 5 deg, at fixed speeds. Here
the same manoeuvre is damped: speeds fall in proportion to the remaining error (with a
floor so the chair does not creep), so it stops without overshoot on a chair with motor
lag. Stages:

* ``move``: turn towards the target (away from it when it lies behind and within
  ``reverse_reach_m``: the chair backs up instead of turning round), then drive while
  steering. Within ``near_m`` only the error along the heading is driven out, so a
  centimetre of noise cannot make the chair turn on the spot.
* ``turn``: turn on the spot to the goal heading.

Idle motion for automatic doors (small moves back and forth) uses the same manoeuvre with
a low speed cap. Pure: the tracker hands in poses and gets commands.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from services.controller.core import Command, _wrap

ALIGN_RAD = math.radians(10)  # turn on the spot first when the target is further off
MIN_SPEED = 0.03  # m/s: below this the chair barely moves against its motor lag
MIN_TURN = 0.08  # rad/s
LEAVE_FACTOR = 2.0  # the turn stage goes back to moving if the error grows past this


@dataclass
class DockLimits:
    """Tolerances, gains and speed caps of one docking manoeuvre."""

    position_tolerance_m: float = 0.05
    heading_tolerance_rad: float = math.radians(1.0)
    max_speed: float = 0.15
    max_turn: float = 0.3
    speed_gain: float = 0.8  # 1/s: v = gain * remaining distance
    turn_gain: float = 1.5  # 1/s: w = gain * heading error
    near_m: float = 0.12
    reverse_reach_m: float = 1.0


class Docker:
    """Drives to one pose (x, y, heading); ``set_goal`` starts, ``clear`` stops."""

    def __init__(self, limits: DockLimits | None = None) -> None:
        self.limits = limits or DockLimits()
        self.goal: tuple[float, float, float] | None = None
        self.stage = "move"
        self._start_error = 0.0
        self._arrived = False

    @property
    def active(self) -> bool:
        return self.goal is not None

    def set_goal(self, x: float, y: float, heading: float, max_speed: float | None = None) -> None:
        """Dock at (x, y) facing ``heading``; ``max_speed`` caps the speed (idle motion)."""
        self.goal = (x, y, heading)
        self.stage = "move"
        self._start_error = -1.0
        self._arrived = False
        self._cap = self.limits.max_speed if max_speed is None else max_speed

    def clear(self) -> None:
        self.goal = None

    def step(self, x: float, y: float, theta: float, pose_fresh: bool = True) -> Command:
        """The command for pose (x, y, theta); zero when idle, arrived or the pose is stale."""
        if self.goal is None:
            return Command(0.0, 0.0, "idle")
        lim = self.limits
        gx, gy, gth = self.goal
        ex, ey = gx - x, gy - y
        dist = math.hypot(ex, ey)
        if self._start_error < 0:
            self._start_error = max(dist, 1e-6)
        heading_err = _wrap(gth - theta)
        progress = max(0.0, min(1.0, 1.0 - dist / self._start_error))
        if self._arrived:
            return Command(0.0, 0.0, "arrived", 1.0, dist, 0.0)
        if not pose_fresh:
            return Command(0.0, 0.0, "stale", progress, dist, 0.0)
        if self.stage == "turn" and dist > LEAVE_FACTOR * lim.position_tolerance_m:
            self.stage = "move"
        if self.stage == "move":
            v, w, done = self._move(ex, ey, dist, theta)
            if not done:
                return Command(v, w, "following", progress, dist, 0.0)
            self.stage = "turn"
        if abs(heading_err) <= lim.heading_tolerance_rad:
            self._arrived = True
            return Command(0.0, 0.0, "arrived", 1.0, dist, 0.0)
        rate = max(MIN_TURN, min(lim.max_turn, lim.turn_gain * abs(heading_err)))
        w = math.copysign(rate, heading_err)
        return Command(0.0, w, "following", progress, dist, 0.0)

    def _move(self, ex: float, ey: float, dist: float, theta: float) -> tuple[float, float, bool]:
        """(v, w, done) of the move stage."""
        lim = self.limits
        hx, hy = math.cos(theta), math.sin(theta)
        along = ex * hx + ey * hy
        if dist <= lim.near_m:  # close: drive out the error along the heading only
            if abs(along) <= lim.position_tolerance_m:
                return 0.0, 0.0, True
            v = math.copysign(self._speed(abs(along)), along)
            return v, 0.0, False
        bearing = _wrap(math.atan2(ey, ex) - theta)
        backwards = abs(bearing) > math.pi / 2 and dist <= lim.reverse_reach_m
        if backwards:
            bearing = _wrap(bearing + math.pi)
        w = max(-lim.max_turn, min(lim.max_turn, lim.turn_gain * bearing))
        if abs(bearing) > ALIGN_RAD:  # face the target (or away from it) first
            return 0.0, math.copysign(max(MIN_TURN, abs(w)), w), False
        v = self._speed(dist) * math.cos(bearing)
        return (-v if backwards else v), w, False

    def _speed(self, remaining: float) -> float:
        return min(self._cap, max(MIN_SPEED, self.limits.speed_gain * remaining))
