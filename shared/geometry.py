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
