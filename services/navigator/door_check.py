"""Is the door ahead open? The seed's LiDAR check, made strict about "unknown".

From a scan (sensor frame) and the chair's pose: keep the points in a height band above
the floor (``band_m``, 0.5-1.7 m) within ``cone_deg`` (+-30 deg) of the bearing to the
door's centre, then a narrow ``window_deg`` (+-4 deg) window around the point nearest
that bearing. The door is "open" only if every point of the window lies deeper than the
door (its distance + ``margin_m``), "closed" if any lies at or before it, and "unknown"
whenever fewer than ``min_points`` survive a stage. Unknown is never treated as open
(the seed's weakness); callers also require several consecutive scans to agree.

Every tuning value comes from one :class:`~shared.config.DoorCheckConfig`
(``navigator.door_check``). When the door's width is known (``width_m > 0``, the
planner's checkpoint width) neither check looks past the opening less
``jamb_allowance_m`` a side, taken in the door's own frame near the door, so a jamb or a
leaf open against its stop is never taken for a closed door or for something in the
doorway; a width of 0 (unknown, e.g. a lift's car door) leaves both
checks as they were without it.
"""

from __future__ import annotations

import math

import numpy as np

from shared.config import DoorCheckConfig

OPEN, CLOSED, UNKNOWN = "open", "closed", "unknown"


def _in_band(points: np.ndarray, sensor_height_m: float, band: list[float]) -> np.ndarray:
    """The points (sensor frame) between ``band`` metres above the floor."""
    height = points[:, 2] + sensor_height_m
    return points[(height >= band[0]) & (height <= band[1])]


def _free_half_width(width_m: float, cfg: DoorCheckConfig) -> float | None:
    """Half the door's opening less the jamb allowance; None if the width is unknown."""
    return width_m / 2 - cfg.jamb_allowance_m if width_m > 0 else None


def door_state_from_scan(
    points: np.ndarray,
    pose: tuple[float, float, float],
    door_xy: tuple[float, float],
    sensor_height_m: float,
    cfg: DoorCheckConfig,
    width_m: float = 0.0,
) -> str:
    """ "open", "closed" or "unknown" for the door centred at ``door_xy`` (map frame).

    With ``width_m`` > 0 the window's half-angle is at most the angle under which half the
    opening (less the jamb allowance) is seen from the door's distance.
    """
    if points is None or len(points) == 0:
        return UNKNOWN
    x, y, th = pose
    pts = _in_band(points, sensor_height_m, cfg.band_m)
    if len(pts) < cfg.min_points:
        return UNKNOWN
    dx, dy = door_xy[0] - x, door_xy[1] - y
    door_dist = math.hypot(dx, dy)
    bearing = math.atan2(dy, dx) - th  # in the sensor frame
    angles = np.arctan2(pts[:, 1], pts[:, 0])
    off = np.abs(np.angle(np.exp(1j * (angles - bearing))))
    cone = pts[off <= math.radians(cfg.cone_deg)]
    off = off[off <= math.radians(cfg.cone_deg)]
    if len(cone) < cfg.min_points:
        return UNKNOWN
    window_deg = cfg.window_deg
    free = _free_half_width(width_m, cfg)
    if free is not None:
        window_deg = min(window_deg, math.degrees(math.atan2(free, door_dist)))
    centre = float(np.arctan2(cone[np.argmin(off), 1], cone[np.argmin(off), 0]))
    ang = np.arctan2(cone[:, 1], cone[:, 0])
    window = cone[np.abs(np.angle(np.exp(1j * (ang - centre)))) <= math.radians(window_deg)]
    if len(window) < cfg.min_points:
        return UNKNOWN
    depth = np.hypot(window[:, 0], window[:, 1])
    return OPEN if bool(np.all(depth > door_dist + cfg.margin_m)) else CLOSED


def lane_blocked(
    points: np.ndarray,
    pose: tuple[float, float, float],
    door_xy: tuple[float, float],
    direction: float,
    sensor_height_m: float,
    half_width_m: float,
    lead_m: float,
    cfg: DoorCheckConfig,
    width_m: float = 0.0,
) -> bool:
    """True if something stands in the chair's lane between its leading edge and the door.

    The lane runs along ``direction`` (map frame, the way the chair moves: backwards out of
    a car it is the heading plus pi), ``half_width_m`` (the chair's clearance half-width)
    each side of the chair's centre line, from ``lead_m`` ahead of the pose point (the
    front, or the back when reversing) to the door plane through ``door_xy`` plus
    ``lane_margin_m``. A leaf swinging or sliding shut enters it; the jambs beside the
    chair do not. When the door's ``width_m`` is known, the last stretch before the plane
    (one door width, where a hinged leaf may stand open) is taken in the door's own frame:
    there only points within the chair's clearance half-width of the door's centre line
    (the way the pass drives) and between the jambs (half the width less
    ``jamb_allowance_m``) count, wherever the chair stands, so a jamb, a leaf open against
    its stop or a wall beside the doorway is never "in the doorway", even with the chair
    or its pose estimate off the centre line. ``lane_min_points`` points make it blocked.
    Once the leading edge is past the door plane plus the margin there is nothing left to
    check (False).
    """
    if points is None or len(points) == 0:
        return False
    x, y, th = pose
    ux, uy = math.cos(direction), math.sin(direction)
    margin = cfg.lane_margin_m
    to_plane = (door_xy[0] - x) * ux + (door_xy[1] - y) * uy + margin
    if to_plane <= lead_m:
        return False
    pts = _in_band(points, sensor_height_m, cfg.band_m)
    a = direction - th  # the lane's direction in the sensor frame
    ca, sa = math.cos(a), math.sin(a)
    along = pts[:, 0] * ca + pts[:, 1] * sa
    across = -pts[:, 0] * sa + pts[:, 1] * ca
    inside = (np.abs(across) <= half_width_m) & (along > lead_m) & (along <= to_plane)
    free = _free_half_width(width_m, cfg)
    if free is not None:
        # the door's frame: ``before`` the plane (negative before it), ``off`` its centre line
        lateral = (door_xy[0] - x) * -uy + (door_xy[1] - y) * ux
        before = along - (to_plane - margin)
        off = np.abs(across - lateral)
        near = before >= -(width_m + cfg.jamb_allowance_m)
        way = min(free, half_width_m)  # the chair passes along the door's centre line
        inside = np.where(near, (off < way) & (along > lead_m) & (along <= to_plane), inside)
    return int(np.count_nonzero(inside)) >= cfg.lane_min_points
