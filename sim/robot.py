"""The wheelchair's motion: a unicycle at the rear-axle point with limits, lag and a watchdog.

Pure and deterministic: :meth:`Chair.step` advances the state by ``dt`` from the last
command. The command watchdog brings the chair to a stop (at the emergency deceleration)
when no command has arrived for ``watchdog_s`` of simulation time.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from shared.config import RobotConfig


@dataclass
class ChairState:
    x: float
    y: float
    theta: float
    v: float = 0.0
    w: float = 0.0


SET_OFF_MPS = 0.02  # the chair sets off (casters swing round) when it speeds up past this
KICK_DECAY_S = 0.5  # the casters' yaw kick fades with this time constant


def _approach(current: float, target: float, max_step: float) -> float:
    return current + max(-max_step, min(max_step, target - current))


class Chair:
    """Unicycle dynamics with speed and acceleration limits and a first-order motor lag."""

    def __init__(
        self,
        robot: RobotConfig,
        state: ChairState,
        motor_lag_s: float,
        watchdog_s: float,
        caster: float = 0.0,
        rng=None,
    ) -> None:
        self.robot = robot
        self.state = state
        self.motor_lag_s = motor_lag_s
        self.watchdog_s = watchdog_s
        self.caster = caster  # std of the yaw-rate kick (rad/s) when the chair sets off
        self.rng = rng
        self._kick = 0.0
        self.cmd = (0.0, 0.0)
        self.last_cmd_time: float | None = None
        self.watchdog_tripped = False

    def command(self, v: float, w: float, now: float) -> None:
        """Set the commanded speeds (clamped to the robot's limits)."""
        r = self.robot
        self.cmd = (
            max(-r.max_reverse_speed, min(r.max_speed, v)),
            max(-r.max_turn_rate, min(r.max_turn_rate, w)),
        )
        self.last_cmd_time = now
        self.watchdog_tripped = False

    def step(self, dt: float, now: float) -> ChairState:
        """Advance by ``dt``; ``now`` is the simulation time at the start of the step."""
        r, s = self.robot, self.state
        was_v = s.v
        stale = self.last_cmd_time is None or now - self.last_cmd_time > self.watchdog_s
        if stale:
            self.watchdog_tripped = self.last_cmd_time is not None
            self.cmd = (0.0, 0.0)
            s.v = _approach(s.v, 0.0, r.estop_decel * dt)
            s.w = _approach(s.w, 0.0, r.estop_decel * 2.0 * dt)
        else:
            alpha = dt / (self.motor_lag_s + dt)
            v_target = s.v + alpha * (self.cmd[0] - s.v)
            w_target = s.w + alpha * (self.cmd[1] - s.w)
            s.v = _approach(s.v, v_target, r.max_accel * dt)
            s.w = _approach(s.w, w_target, r.max_turn_accel * dt)
        if self.caster > 0 and self.rng is not None and abs(s.v) > SET_OFF_MPS >= abs(was_v):
            self._kick = float(self.rng.normal(0.0, self.caster))  # casters swing round
        self._kick *= math.exp(-dt / KICK_DECAY_S)
        w = s.w + self._kick
        mid = s.theta + 0.5 * w * dt
        s.x += s.v * dt * math.cos(mid)
        s.y += s.v * dt * math.sin(mid)
        s.theta = math.atan2(math.sin(s.theta + w * dt), math.cos(s.theta + w * dt))
        return s


class WheelOdometry:
    """Odometry as wheel encoders give it: the true motion with scale error, turn-rate bias
    and noise, integrated from the start pose (so it drifts, as a real chair's does)."""

    def __init__(
        self,
        start: ChairState,
        scale_error: float,
        turn_bias: float,
        noise_v: float,
        noise_w: float,
        rng,
    ) -> None:
        self.x, self.y, self.theta = start.x, start.y, start.theta
        self.scale = 1.0 + scale_error
        self.turn_bias = turn_bias
        self.noise_v = noise_v
        self.noise_w = noise_w
        self.rng = rng
        self.v = self.w = 0.0

    def step(self, v: float, w: float, dt: float) -> None:
        """Integrate one step of the true speeds (v, w) as the encoders measure them."""
        moving = abs(v) > 1e-6 or abs(w) > 1e-6
        nv, nw = self.rng.normal(0.0, [self.noise_v, self.noise_w]) if moving else (0.0, 0.0)
        self.v = v * self.scale + nv
        self.w = w + (self.turn_bias if moving else 0.0) + nw
        mid = self.theta + 0.5 * self.w * dt
        self.x += self.v * dt * math.cos(mid)
        self.y += self.v * dt * math.sin(mid)
        self.theta = math.atan2(
            math.sin(self.theta + self.w * dt), math.cos(self.theta + self.w * dt)
        )
