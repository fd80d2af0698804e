"""What the driver tells the chair, and what it makes of what the chair says (pure).

* :func:`velocity_command`: a ``cmd_vel`` (m/s, rad/s counter-clockwise) as the SDK's
  SetVelocity values (units of 0.004 km/h: front speed, and side = the wheels' speed
  difference, positive turning right), clamped to the driver's limits and the chair's.
* :class:`Base`: the command watchdog (no ``cmd_vel`` for ``command_timeout_s`` of the
  driver's own monotonic clock: stop the chair, the contract of docs/ARCHITECTURE.md),
  the rider (a deflected joystick: hand the chair back to its joystick and send nothing
  else until it has been at rest for ``joystick_release_s``), the emergency stop (a stop
  every cycle while it is active, whatever ``cmd_vel`` says; cleared, it drives again only
  on a command that comes after), wheel odometry, and the chair's condition for the status
  message. It never reads a clock: every method takes ``now``.

Before the first ``cmd_vel`` the driver sends nothing (the chair stays with its rider);
after it, it keeps sending: the command while fresh, a stop when it is stale (a stop
every cycle also keeps the chair's own 1 s timeout from handing it back mid-mission).
While no data set arrives (``data_timeout_s``) it sends a stop too: it does not drive a
chair it cannot see, nor move it where odometry would miss the motion. The rider comes
before the emergency stop: a deflected joystick is handed the chair even then (the stop
is the fleet's, and the WHILL gives its own joystick the last word anyway).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from services.whill_driver.config import WhillConfig
from services.whill_driver.odometry import Sample, WheelOdometry
from shared.messages import DriverStatus, Odometry, Pose2D, Twist

UNITS_PER_MPS = 3.6 / 0.004  # SetVelocity units (0.004 km/h) per m/s: 900
FRONT_RANGE = (-500, 1500)  # the chair's SetVelocity ranges, units
SIDE_RANGE = (-750, 750)


def _clamp(value: float, lo: float, hi: float) -> float:
    return max(lo, min(hi, value))


def velocity_command(v: float, w: float, cfg: WhillConfig) -> tuple[int, int]:
    """SetVelocity (front, side) for forward speed ``v`` and turn rate ``w``, each
    clamped to the driver's limits and then to the chair's ranges."""
    v = _clamp(v, -cfg.max_reverse_speed, cfg.max_speed)
    w = _clamp(w, -cfg.max_turn_rate, cfg.max_turn_rate)
    front = round(_clamp(v * UNITS_PER_MPS, *FRONT_RANGE))
    side = round(_clamp(-w * cfg.track_m * UNITS_PER_MPS, *SIDE_RANGE))
    return int(front), int(side)


@dataclass(frozen=True)
class Action:
    """What to send the chair this cycle: ``velocity`` (front, side) or ``release`` (hand
    it back to its joystick)."""

    kind: str
    front: int = 0
    side: int = 0


STOP = Action("velocity", 0, 0)
RELEASE = Action("release")


class Base:
    """The driver's core: commands in, odometry and status out, on the caller's clock."""

    def __init__(self, cfg: WhillConfig) -> None:
        self.cfg = cfg
        self.odometry = WheelOdometry(
            cfg.wheel_radius_m, cfg.track_m, cfg.left_wheel_sign, cfg.right_wheel_sign
        )
        self.command: tuple[int, int] | None = None  # the last cmd_vel as SetVelocity
        self.command_at = -math.inf
        self.stopped = False  # the watchdog has stopped the chair (until a new command)
        self.rider = False  # the rider holds the joystick
        self.estop = False  # the emergency stop is active
        self.joystick_at = -math.inf  # when it was last seen deflected
        self.sample: Sample | None = None
        self.sample_at = -math.inf
        self.events: list[tuple[str, str, str]] = []  # (kind, detail, severity), to drain

    # -- inputs ----------------------------------------------------------------------------

    def on_cmd_vel(self, twist: Twist, now: float) -> None:
        """A velocity command arrived at ``now`` (its stamp is the sender's clock: unused)."""
        self.command = velocity_command(twist.v, twist.w, self.cfg)
        self.command_at = now
        if self.stopped:
            self.stopped = False
            self._event("commands_resumed", "cmd_vel again: driving")

    def on_sample(self, s: Sample, now: float) -> None:
        """A data set 1 arrived at ``now``."""
        previous, self.sample, self.sample_at = self.sample, s, now
        self.odometry.update(s)
        deadband = self.cfg.joystick_deadband
        if abs(s.joy_front) > deadband or abs(s.joy_side) > deadband:
            self.joystick_at = now
            if not self.rider:
                self.rider = True
                self._event(
                    "joystick_taken",
                    f"the rider holds the joystick (front {s.joy_front}, side {s.joy_side}):"
                    " the chair is theirs",
                    "warning",
                )
        if s.error_code and (previous is None or previous.error_code != s.error_code):
            self._event("chair_error", f"the chair reports error code {s.error_code}", "error")

    def on_estop(self, active: bool, reason: str = "") -> None:
        """The emergency stop was set (``active``) or cleared; ``reason`` says by whom."""
        if active == self.estop:
            return
        self.estop = active
        if active:
            self._event(
                "emergency_stop", f"{reason or 'emergency stop'}: stopping the chair", "warning"
            )
        else:
            self.command = None  # nothing from before the stop: drive on a new command
            self._event("emergency_stop", "emergency stop cleared: waiting for cmd_vel", "warning")

    def on_link_lost(self) -> None:
        """The serial link went down: the next data set starts the wheel angles afresh."""
        self.odometry.restart()
        self.sample_at = -math.inf

    # -- outputs ---------------------------------------------------------------------------

    def step(self, now: float) -> Action | None:
        """What to send the chair at ``now`` (None: nothing this cycle)."""
        if self.rider and now - self.joystick_at >= self.cfg.joystick_release_s:
            self.rider = False
            self.command = None  # drive again only on a command that comes after
            self._event("joystick_released", "the joystick is at rest: waiting for cmd_vel")
        if self.rider:
            return RELEASE
        if self.estop:
            return STOP
        if self.command is None:
            return None
        if now - self.command_at > self.cfg.command_timeout_s:
            if not self.stopped:
                self.stopped = True
                self._event(
                    "command_timeout",
                    f"no cmd_vel for {self.cfg.command_timeout_s:g} s: stopping the chair",
                    "warning",
                )
            return STOP
        if not self.data_fresh(now):
            return STOP  # blind (no data from the chair): no motion odometry would not see
        return Action("velocity", *self.command)

    def data_fresh(self, now: float) -> bool:
        """Whether a data set 1 arrived within ``data_timeout_s``."""
        return now - self.sample_at <= self.cfg.data_timeout_s

    def odometry_message(self, stamp: float) -> Odometry:
        """The wheel odometry now, stamped with the driver's clock."""
        o = self.odometry
        return Odometry(stamp, Pose2D(o.x, o.y, o.theta), o.v, o.w, "odom")

    def status_message(self, stamp: float, serial_ok: bool) -> DriverStatus:
        """Battery, speed mode, error code, the rider, the link."""
        s = self.sample
        return DriverStatus(
            stamp,
            battery_percent=int(_clamp(s.battery_level, 0, 100)) if s else 0,
            speed_mode=s.speed_mode if s else 0,
            error_code=s.error_code if s else 0,
            joystick_active=self.rider,
            serial_ok=serial_ok,
        )

    def drain_events(self) -> list[tuple[str, str, str]]:
        """The events since the last call: (kind, detail, severity)."""
        out, self.events = self.events, []
        return out

    def _event(self, kind: str, detail: str, severity: str = "info") -> None:
        self.events.append((kind, detail, severity))
