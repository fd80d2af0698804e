"""The localisation's core: odometry mode and map mode.

Odometry mode: the pose is anchored at an initial map pose and every odometry message
moves it by the odometry's own increment (rotated into the map frame), so drift is the
odometry's. Map mode: the same between scans, and every scan is matched against the
floor map (services/localisation/matcher.py) to correct the pose; scans that stop
matching (too few points on walls, or a correction too large to be believed) are
counted, and after ``lost_after_scans`` of them in a row the pose is flagged lost.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from services.localisation.matcher import DistanceField, Match, match_scan
from shared.geometry import angle_between, wrap_angle


class OdometryLocaliser:
    """Tracks the map pose by composing odometry increments onto an anchor pose."""

    def __init__(self, x: float, y: float, theta: float, floor: str) -> None:
        self.covariance = np.diag([1e-4, 1e-4, 1e-4])
        self.reset(x, y, theta, floor)

    def reset(
        self,
        x: float,
        y: float,
        theta: float,
        floor: str,
        odom: tuple[float, float, float] | None = None,
    ) -> None:
        """Re-anchor at a map pose (initial pose request, floor change); with ``odom``,
        the odometry pose of that moment (a resumed pose: the motion since then counts)."""
        self.pose = (x, y, theta)
        self.floor = floor
        self._last_odom: tuple[float, float, float] | None = odom

    def update(self, ox: float, oy: float, otheta: float) -> tuple[float, float, float]:
        """Apply the odometry pose (ox, oy, otheta); returns the new map pose."""
        if self._last_odom is not None:
            lx, ly, lt = self._last_odom
            c, s = math.cos(-lt), math.sin(-lt)
            dx, dy = c * (ox - lx) - s * (oy - ly), s * (ox - lx) + c * (oy - ly)
            dtheta = wrap_angle(otheta - lt)
            x, y, t = self.pose
            c, s = math.cos(t), math.sin(t)
            t_new = wrap_angle(t + dtheta)
            self.pose = (x + c * dx - s * dy, y + s * dx + c * dy, t_new)
        self._last_odom = (ox, oy, otheta)
        return self.pose

    def correct(self, x: float, y: float, theta: float) -> None:
        """Move the map pose (a scan match) without losing the odometry baseline."""
        self.pose = (x, y, theta)


@dataclass
class MapModeSettings:
    """Acceptance rules for scan matches (from the localisation config)."""

    min_inlier_ratio: float = 0.5
    max_correction_m: float = 0.5
    max_correction_rad: float = 0.3
    lost_after_scans: int = 5
    cutoff_m: float = 0.4
    prior_weight: float = 20.0
    max_points: int = 1000  # a 3-D cloud is thinned to this many points (evenly) to match


class MapLocaliser:
    """Odometry between scans, scan-to-map matching at every scan, and a lost flag."""

    def __init__(
        self,
        field: DistanceField,
        x: float,
        y: float,
        theta: float,
        floor: str,
        settings: MapModeSettings,
    ) -> None:
        self.odometry = OdometryLocaliser(x, y, theta, floor)
        self.field = field
        self.settings = settings
        self.misses = 0
        self.last_match: Match | None = None

    @property
    def pose(self) -> tuple[float, float, float]:
        return self.odometry.pose

    @property
    def floor(self) -> str:
        return self.odometry.floor

    @property
    def lost(self) -> bool:
        return self.misses >= self.settings.lost_after_scans

    @property
    def covariance(self) -> np.ndarray:
        if self.last_match is None or self.misses:
            return self.odometry.covariance * (1 + 10 * self.misses)
        return self.last_match.covariance

    def reset(
        self,
        field: DistanceField,
        x: float,
        y: float,
        theta: float,
        floor: str,
        odom: tuple[float, float, float] | None = None,
    ) -> None:
        """Re-initialise on a (possibly new) floor map, e.g. after an elevator ride
        (``odom``: as ``OdometryLocaliser.reset``)."""
        self.field = field
        self.odometry.reset(x, y, theta, floor, odom)
        self.misses = 0
        self.last_match = None

    def update_odometry(self, ox: float, oy: float, otheta: float) -> tuple[float, float, float]:
        return self.odometry.update(ox, oy, otheta)

    def update_scan(self, points: np.ndarray) -> bool:
        """Match a scan (N, 2+) in the sensor frame; True if the pose was corrected."""
        s = self.settings
        if len(points) > s.max_points:
            points = points[np.linspace(0, len(points) - 1, s.max_points).astype(int)]
        m = match_scan(
            self.field, points, self.pose, cutoff_m=s.cutoff_m, prior_weight=s.prior_weight
        )
        x, y, th = self.pose
        jump = math.hypot(m.x - x, m.y - y)
        turn = angle_between(m.theta, th)
        good = (
            m.inlier_ratio >= s.min_inlier_ratio
            and jump <= s.max_correction_m
            and turn <= s.max_correction_rad
        )
        if not good:
            self.misses += 1
            return False
        self.misses = 0
        self.last_match = m
        self.odometry.correct(m.x, m.y, m.theta)
        return True
