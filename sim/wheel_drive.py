"""The simulated chair moved by an emulated WHILL's wheels (the simulator's hardware path).

On the hardware path the WHILL driver commands the chair over its serial protocol and the
emulated Model CR (sim/whill_emulator.py) executes the commands as the chair would: its
accelerations, its own 1 s timeout, its rider's joystick. It keeps each wheel's turn;
:class:`WheelDrive` reads them every simulator step and moves the pybullet chair along
the arc they describe. The chair is where its wheels took it whatever the simulator's step
rate: a late step moves it further, never somewhere else.

The floor is not the wheels. As the simulator's own odometry errs from the truth
(sim/robot.py, WheelOdometry), the ground motion here errs from the wheels' by the same
figures, inverted: the chair travels short by ``scale_error`` and turns off by
``turn_bias`` while it moves, and its casters kick its heading when it sets off (as
sim/robot.py's Chair). The driver's odometry, made from the wheels, then drifts from the
truth as the simulator's does. (The odometry's random noise has no counterpart here.)

Pure: each reading of the wheels is passed in (:class:`Wheels`); no clock is read.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from sim.robot import KICK_DECAY_S, SET_OFF_MPS, ChairState
from sim.whill_emulator import ChairModel

STILL = 1e-9  # m or rad: a step that turned the wheels less than this is no motion


@dataclass(frozen=True)
class Wheels:
    """One reading of the emulated chair: its time (s, its own clock; None before its
    first step), each wheel's turn (rad, unwrapped, forward positive), its speeds, and
    whether its own timeout has stopped it (no motion command since)."""

    t: float | None
    right_angle: float
    left_angle: float
    v: float = 0.0
    w: float = 0.0
    timed_out: bool = False


def wheels_of(chair: ChairModel) -> Wheels:
    """The reading of ``chair`` now (hold the emulator's lock while calling it)."""
    timed_out = chair.timeout_at is not None and (
        chair.last_command_at is None or chair.timeout_at > chair.last_command_at
    )
    return Wheels(chair.t, chair.right_angle, chair.left_angle, chair.v, chair.w, timed_out)


class WheelDrive:
    """Moves ``state`` (the chair's true pose at the rear-axle point) by the wheels'
    turns that ``read`` returns, with the ground's errors; a drive for sim/simulation.py."""

    def __init__(
        self,
        state: ChairState,
        read: Callable[[], Wheels],
        wheel_radius_m: float,
        track_m: float,
        scale_error: float = 0.0,
        turn_bias: float = 0.0,
        caster: float = 0.0,
        rng: np.random.Generator | None = None,
    ) -> None:
        self.state = state
        self.read = read
        self.radius = wheel_radius_m
        self.track = track_m
        self.scale = 1.0 + scale_error
        self.turn_bias = turn_bias
        self.caster = caster  # std of the yaw-rate kick (rad/s) when the chair sets off
        self.rng = rng
        self.watchdog_tripped = False  # the chair's own timeout stopped it
        self._kick = 0.0
        self._last = read()

    def step(self, dt: float, now: float) -> ChairState:
        """Move the chair by what its wheels turned since the last step (``dt`` and
        ``now``, the simulator's, are not used: the wheels carry their own time)."""
        wheels, last = self.read(), self._last
        self._last = wheels
        self.watchdog_tripped = wheels.timed_out
        known = wheels.t is not None and last.t is not None
        elapsed = max(0.0, wheels.t - last.t) if known else 0.0
        d_right = (wheels.right_angle - last.right_angle) * self.radius
        d_left = (wheels.left_angle - last.left_angle) * self.radius
        s = self.state
        was_v, s.v = s.v, wheels.v / self.scale
        moving = abs(d_right) > STILL or abs(d_left) > STILL
        if self.caster > 0 and self.rng is not None and abs(s.v) > SET_OFF_MPS >= abs(was_v):
            self._kick = float(self.rng.normal(0.0, self.caster))  # casters swing round
        kick = self._kick
        self._kick *= math.exp(-elapsed / KICK_DECAY_S)
        bias = self.turn_bias if moving else 0.0
        s.w = wheels.w - bias + kick
        ds = (d_right + d_left) / 2 / self.scale
        turn = (d_right - d_left) / self.track - (bias - kick) * elapsed
        chord = ds * _sinc(turn / 2)  # the arc's chord: exact at a constant curvature
        mid = s.theta + turn / 2
        s.x += chord * math.cos(mid)
        s.y += chord * math.sin(mid)
        s.theta = math.atan2(math.sin(s.theta + turn), math.cos(s.theta + turn))
        return s


def _sinc(x: float) -> float:
    return math.sin(x) / x if abs(x) > 1e-9 else 1.0
