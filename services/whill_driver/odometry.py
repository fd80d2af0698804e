"""Wheel odometry from the WHILL's data set 1: the pose in frame ``odom`` and the speeds.

Each data set 1 carries both motors' angle (0.001 rad, wrapping at +-pi) and speed
(0.004 km/h at the tyre), and a millisecond stamp the SDK turns into the time since the
previous set. The speeds give ``v`` and ``w``. The pose integrates the change of the
wheel angles, not speed times time: the angles are absolute, so their rounding does not
add up over a drive (rounded speeds would add about 1 mm/s of drift per wheel). The
wrap of an angle is undone with the speed: the change is the one within half a turn of
speed x time (a wheel turns about 0.25 rad between two sets at full speed, so even a
wrong time does not pick the wrong turn).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

KMH = 1 / 3.6  # m/s per km/h


@dataclass(frozen=True)
class Sample:
    """One data set 1 as the SDK decoded it (its units: rad, km/h, %, mA, ms)."""

    joy_front: int
    joy_side: int
    battery_level: int
    battery_current_ma: float
    right_angle: float
    left_angle: float
    right_speed_kmh: float
    left_speed_kmh: float
    power_on: bool
    speed_mode: int
    error_code: int
    time_diff_ms: float


def wrap(angle: float) -> float:
    """``angle`` (rad) brought into [-pi, pi]."""
    return math.atan2(math.sin(angle), math.cos(angle))


class WheelOdometry:
    """The pose (x, y, theta in frame odom, from where the first set arrived) and speeds.

    ``left_sign`` and ``right_sign`` say which way each motor counts when the chair
    drives forwards (the Model CR's right motor counts backwards).
    """

    def __init__(
        self, wheel_radius_m: float, track_m: float, left_sign: int = 1, right_sign: int = -1
    ) -> None:
        self.radius = wheel_radius_m
        self.track = track_m
        self.left_sign = left_sign
        self.right_sign = right_sign
        self.x = self.y = self.theta = 0.0
        self.v = self.w = 0.0
        self.samples = 0
        self._angles: tuple[float, float] | None = None

    def restart(self) -> None:
        """Forget the last angles (a new link: the next set is a new reference); the pose
        stays where it was."""
        self._angles = None
        self.v = self.w = 0.0

    def update(self, s: Sample) -> None:
        """Move the pose by what the wheels turned since the previous set."""
        left = self.left_sign * s.left_speed_kmh * KMH
        right = self.right_sign * s.right_speed_kmh * KMH
        self.v = (left + right) / 2
        self.w = (right - left) / self.track
        angles = (self.left_sign * s.left_angle, self.right_sign * s.right_angle)
        last, self._angles = self._angles, angles
        self.samples += 1
        if last is None:
            return
        dt = max(0.0, s.time_diff_ms / 1000.0)
        d_left = self._turned(angles[0] - last[0], left * dt) * self.radius
        d_right = self._turned(angles[1] - last[1], right * dt) * self.radius
        ds = (d_left + d_right) / 2
        d_theta = (d_right - d_left) / self.track
        heading = self.theta + d_theta / 2
        self.x += ds * math.cos(heading)
        self.y += ds * math.sin(heading)
        self.theta = wrap(self.theta + d_theta)

    def _turned(self, change: float, travelled_m: float) -> float:
        """The wheel's turn (rad): ``change`` of its wrapped angle, taken within half a turn
        of what ``travelled_m`` at its speed predicts."""
        predicted = travelled_m / self.radius
        return predicted + wrap(change - predicted)
