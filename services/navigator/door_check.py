"""Is the door ahead open? The seed's LiDAR check, made strict about "unknown".

From a scan (sensor frame) and the chair's pose: keep the points between 0.5 and 1.7 m
above the floor within +-30 deg of the bearing to the door's centre, then a narrow +-4
deg window around the point nearest that bearing. The door is "open" only if every
point of the window lies deeper than the door (its distance + ``margin_m``), "closed"
if any lies at or before it, and "unknown" whenever fewer than ``min_points`` survive a
stage. Unknown is never treated as open (the seed's weakness); callers also require
several consecutive scans to agree.
"""

from __future__ import annotations

import math

import numpy as np

OPEN, CLOSED, UNKNOWN = "open", "closed", "unknown"


def _in_band(points: np.ndarray, sensor_height_m: float, band: tuple[float, float]) -> np.ndarray:
    """The points (sensor frame) between ``band`` metres above the floor."""
    height = points[:, 2] + sensor_height_m
    return points[(height >= band[0]) & (height <= band[1])]


def door_state_from_scan(
    points: np.ndarray,
    pose: tuple[float, float, float],
    door_xy: tuple[float, float],
    sensor_height_m: float,
    margin_m: float = 0.3,
    min_points: int = 5,
    cone_deg: float = 30.0,
    window_deg: float = 4.0,
    band: tuple[float, float] = (0.5, 1.7),
) -> str:
    """ "open", "closed" or "unknown" for the door centred at ``door_xy`` (map frame)."""
    if points is None or len(points) == 0:
        return UNKNOWN
    x, y, th = pose
    pts = _in_band(points, sensor_height_m, band)
    if len(pts) < min_points:
        return UNKNOWN
    dx, dy = door_xy[0] - x, door_xy[1] - y
    door_dist = math.hypot(dx, dy)
    bearing = math.atan2(dy, dx) - th  # in the sensor frame
    angles = np.arctan2(pts[:, 1], pts[:, 0])
    off = np.abs(np.angle(np.exp(1j * (angles - bearing))))
    cone = pts[off <= math.radians(cone_deg)]
    off = off[off <= math.radians(cone_deg)]
    if len(cone) < min_points:
        return UNKNOWN
    centre = float(np.arctan2(cone[np.argmin(off), 1], cone[np.argmin(off), 0]))
    ang = np.arctan2(cone[:, 1], cone[:, 0])
    window = cone[np.abs(np.angle(np.exp(1j * (ang - centre)))) <= math.radians(window_deg)]
    if len(window) < min_points:
        return UNKNOWN
    depth = np.hypot(window[:, 0], window[:, 1])
    return OPEN if bool(np.all(depth > door_dist + margin_m)) else CLOSED


def lane_blocked(
    points: np.ndarray,
    pose: tuple[float, float, float],
    door_xy: tuple[float, float],
    direction: float,
    sensor_height_m: float,
    half_width_m: float,
    lead_m: float,
    margin_m: float = 0.3,
    min_points: int = 3,
    band: tuple[float, float] = (0.5, 1.7),
) -> bool:
    """True if something stands in the chair's lane between its leading edge and the door.

    The lane runs along ``direction`` (map frame, the way the chair moves: backwards out of
    a car it is the heading plus pi), ``half_width_m`` each side of the chair's centre
    line, from ``lead_m`` ahead of the pose point (the front, or the back when reversing)
    to the door plane through ``door_xy`` plus ``margin_m``. A leaf swinging or sliding
    shut enters it; the jambs beside the chair do not. Once the leading edge is past the
    door plane plus the margin there is nothing left to check (False).
    """
    if points is None or len(points) == 0:
        return False
    x, y, th = pose
    ux, uy = math.cos(direction), math.sin(direction)
    to_plane = (door_xy[0] - x) * ux + (door_xy[1] - y) * uy + margin_m
    if to_plane <= lead_m:
        return False
    pts = _in_band(points, sensor_height_m, band)
    a = direction - th  # the lane's direction in the sensor frame
    ca, sa = math.cos(a), math.sin(a)
    along = pts[:, 0] * ca + pts[:, 1] * sa
    across = -pts[:, 0] * sa + pts[:, 1] * ca
    inside = (np.abs(across) <= half_width_m) & (along > lead_m) & (along <= to_plane)
    return int(np.count_nonzero(inside)) >= min_points
