"""Plane geometry used by several services."""

from __future__ import annotations

import math


def wrap_angle(a: float) -> float:
    """``a`` (radians) brought into [-pi, pi]."""
    return math.atan2(math.sin(a), math.cos(a))


def angle_between(a: float, b: float) -> float:
    """The unsigned angle (radians, 0..pi) from heading ``b`` to heading ``a``."""
    return abs(wrap_angle(a - b))
