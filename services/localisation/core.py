"""The localisation's core, odometry mode: the map pose from odometry increments.

The pose is anchored at an initial map pose; every odometry message moves it by the
odometry's own increment (rotated into the map frame), so drift is the odometry's.
Map mode (LiDAR against the floor map) replaces this later behind the same interface.
"""

from __future__ import annotations

import math

import numpy as np


class OdometryLocaliser:
    """Tracks the map pose by composing odometry increments onto an anchor pose."""

    def __init__(self, x: float, y: float, theta: float, floor: str) -> None:
        self.covariance = np.diag([1e-4, 1e-4, 1e-4])
        self.reset(x, y, theta, floor)

    def reset(self, x: float, y: float, theta: float, floor: str) -> None:
        """Re-anchor at a map pose (initial pose request, floor change)."""
        self.pose = (x, y, theta)
        self.floor = floor
        self._last_odom: tuple[float, float, float] | None = None

    def update(self, ox: float, oy: float, otheta: float) -> tuple[float, float, float]:
        """Apply the odometry pose (ox, oy, otheta); returns the new map pose."""
        if self._last_odom is not None:
            lx, ly, lt = self._last_odom
            c, s = math.cos(-lt), math.sin(-lt)
            dx, dy = c * (ox - lx) - s * (oy - ly), s * (ox - lx) + c * (oy - ly)
            dtheta = math.atan2(math.sin(otheta - lt), math.cos(otheta - lt))
            x, y, t = self.pose
            c, s = math.cos(t), math.sin(t)
            t_new = math.atan2(math.sin(t + dtheta), math.cos(t + dtheta))
            self.pose = (x + c * dx - s * dy, y + s * dx + c * dy, t_new)
        self._last_odom = (ox, oy, otheta)
        return self.pose
