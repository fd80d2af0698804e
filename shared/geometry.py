"""Plane geometry used by several services."""

from __future__ import annotations

import math

import numpy as np


def wrap_angle(a: float) -> float:
    """``a`` (radians) brought into [-pi, pi]."""
    return math.atan2(math.sin(a), math.cos(a))


def angle_between(a: float, b: float) -> float:
    """The unsigned angle (radians, 0..pi) from heading ``b`` to heading ``a``."""
    return abs(wrap_angle(a - b))


def in_footprint(
    xy: np.ndarray, front: float, rear: float, width: float, margin: float = 0.0
) -> np.ndarray:
    """Which points (N, 2, in the chair's frame: x forwards from the rear axle) lie in the
    chair's rectangle grown by ``margin`` on every side."""
    return (
        (xy[:, 0] >= -rear - margin)
        & (xy[:, 0] <= front + margin)
        & (np.abs(xy[:, 1]) <= width / 2 + margin)
    )


def footprint_gap(xy: np.ndarray, front: float, rear: float, width: float) -> np.ndarray:
    """How far each point (N, 2, chair frame as in :func:`in_footprint`) is from the chair's
    rectangle: 0 inside it."""
    dx = np.maximum(np.maximum(-rear - xy[:, 0], xy[:, 0] - front), 0.0)
    dy = np.maximum(np.abs(xy[:, 1]) - width / 2, 0.0)
    return np.hypot(dx, dy)


def turn_closes_in(
    xy: np.ndarray, front: float, rear: float, width: float, margin: float, angle: float
) -> bool:
    """True if turning on the spot by ``angle`` (radians, about the rear axle; the sign says
    which way) brings a point (N, 2, chair frame) within ``margin`` of the rectangle, or one
    already within it nearer still: beside a wall, a corner swings on into it."""
    if len(xy) == 0 or angle == 0.0:
        return False
    gap = footprint_gap(xy, front, rear, width)
    floor = np.minimum(gap, margin) - 1e-3  # how near each point may come
    for phi in np.linspace(angle / 4, angle, 4):
        c, s = math.cos(phi), math.sin(phi)
        turned = np.column_stack((c * xy[:, 0] + s * xy[:, 1], -s * xy[:, 0] + c * xy[:, 1]))
        if (footprint_gap(turned, front, rear, width) < floor).any():
            return True
    return False
