"""A smooth way onto a door's centre line: the cubic Bézier of the door-passing paper.

From the chair's current pose to a goal pose on the door's centre line, ``lead_m`` before
the door plane and facing through the door. The curve starts along the chair's heading and
ends along the door's normal: its inner control points lie on those two tangent lines,
between the chair and their crossing point P_c (the paper's constraints 4b and 4c), so the
curve stays inside the triangle P0-P_c-P3 and bends one way only (4d). Of those, the one
whose curvature changes least (the integral of the squared derivative of curvature, the
paper's objective 4a) is taken, by a search over the two control points' places on their
segments. Re-planned every control cycle from the latest door estimate, the curve absorbs
the door's position as the scans refine it.

When the two tangent lines do not cross ahead of both ends but the chair faces along the
line, beside it (a corridor approach), the paper's family is empty; the curve is then an S
with its inner points on the two tangents (no one-way rule), again the one whose
curvature changes least. Facing away from the door there is no curve: the caller turns
first or falls back to stop-turn-go. Pure: no I/O.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

SAMPLES = 64  # points along the curve for its curvature and for the path
GRID = 24  # places tried for each inner control point on its tangent segment


@dataclass(frozen=True)
class DoorCurve:
    """The chosen curve: its four control points, SAMPLES points along it with the heading
    and the signed curvature (1/m) at each, and its length (m)."""

    control: np.ndarray
    points: np.ndarray
    heading: np.ndarray
    curvature: np.ndarray
    length_m: float

    def speed_limit(self, v_max: float, lateral_accel: float) -> np.ndarray:
        """The speed at each point: ``v_max`` where the curve is straight, less where its
        curvature asks more than ``lateral_accel`` (m/s^2)."""
        k = np.maximum(np.abs(self.curvature), 1e-9)
        return np.minimum(v_max, np.sqrt(lateral_accel / k))


def _bezier(ctrl: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Points, first and second derivatives of cubic Béziers. ``ctrl`` (..., 4, 2)."""
    t = t[:, None]
    p0, p1, p2, p3 = (ctrl[..., i, None, :] for i in range(4))
    u = 1 - t
    pos = u**3 * p0 + 3 * u**2 * t * p1 + 3 * u * t**2 * p2 + t**3 * p3
    d1 = 3 * u**2 * (p1 - p0) + 6 * u * t * (p2 - p1) + 3 * t**2 * (p3 - p2)
    d2 = 6 * u * (p2 - 2 * p1 + p0) + 6 * t * (p3 - 2 * p2 + p1)
    return pos, d1, d2


def _curvature(d1: np.ndarray, d2: np.ndarray) -> np.ndarray:
    cross = d1[..., 0] * d2[..., 1] - d1[..., 1] * d2[..., 0]
    speed = np.maximum(np.hypot(d1[..., 0], d1[..., 1]), 1e-9)
    return cross / speed**3


def warm_up() -> None:
    """Compile (or load) the search kernel now, not in a door pass's first cycle."""
    door_curve((0.0, 0.0, 0.0), (1.0, 1.0, math.pi / 2))


@numba.njit(cache=True)
def _search_costs(ctrl: np.ndarray, t: np.ndarray, one_way: bool) -> np.ndarray:
    """Per candidate (N, 4, 2 control points): the integral of the squared derivative of
    curvature over the samples ``t`` (inf where ``one_way`` and it bends both ways). One
    pass per candidate, as ``_bezier`` and ``_curvature`` compute it, without the (N, S)
    temporaries: the search is re-run every control cycle of a pass."""
    n, m = ctrl.shape[0], t.shape[0]
    out = np.empty(n)
    k = np.empty(m)
    ds = np.empty(m)
    for i in range(n):
        p0x, p0y, p1x, p1y = ctrl[i, 0, 0], ctrl[i, 0, 1], ctrl[i, 1, 0], ctrl[i, 1, 1]
        p2x, p2y, p3x, p3y = ctrl[i, 2, 0], ctrl[i, 2, 1], ctrl[i, 3, 0], ctrl[i, 3, 1]
        left = right = True
        for j in range(m):
            tt = t[j]
            u = 1 - tt
            a, b, c = 3 * u * u, 6 * u * tt, 3 * tt * tt
            d1x = a * (p1x - p0x) + b * (p2x - p1x) + c * (p3x - p2x)
            d1y = a * (p1y - p0y) + b * (p2y - p1y) + c * (p3y - p2y)
            d2x = 6 * u * (p2x - 2 * p1x + p0x) + 6 * tt * (p3x - 2 * p2x + p1x)
            d2y = 6 * u * (p2y - 2 * p1y + p0y) + 6 * tt * (p3y - 2 * p2y + p1y)
            speed = math.hypot(d1x, d1y)
            ds[j] = speed / (m - 1)
            sg = max(speed, 1e-9)
            k[j] = (d1x * d2y - d1y * d2x) / (sg * sg * sg)
            left = left and k[j] >= -1e-9
            right = right and k[j] <= 1e-9
        total = 0.0
        for j in range(1, m):
            dk = (k[j] - k[j - 1]) / max(ds[j], 1e-9)
            total += dk * dk * ds[j]
        out[i] = np.inf if one_way and not (left or right) else total
    return out


def crossing_point(
    start: tuple[float, float, float], goal: tuple[float, float, float]
) -> np.ndarray | None:
    """Where the line ahead of ``start`` meets the line behind ``goal`` (both poses x, y,
    heading), or None if they do not meet ahead of the one and behind the other."""
    p0, p3 = np.array(start[:2]), np.array(goal[:2])
    h0 = np.array([math.cos(start[2]), math.sin(start[2])])
    h3 = np.array([math.cos(goal[2]), math.sin(goal[2])])
    m = np.array([h0, h3]).T  # p0 + a h0 = p3 - b h3, so a h0 + b h3 = p3 - p0
    if abs(np.linalg.det(m)) < 1e-6:
        return None
    a, b = np.linalg.solve(m, p3 - p0)
    if a <= 1e-3 or b <= 1e-3:
        return None
    return p0 + a * h0


def door_curve(
    start: tuple[float, float, float], goal: tuple[float, float, float]
) -> DoorCurve | None:
    """The smoothest one-way bend from ``start`` to ``goal`` (x, y, heading), or None.

    A start already on the goal's line and facing along it gives the straight segment.
    """
    p0, p3 = np.array(start[:2], dtype=float), np.array(goal[:2], dtype=float)
    t = np.linspace(0.0, 1.0, SAMPLES)
    h3 = np.array([math.cos(goal[2]), math.sin(goal[2])])
    off_line = abs(float(h3[0] * (p0 - p3)[1] - h3[1] * (p0 - p3)[0]))
    facing = math.cos(start[2] - goal[2])
    if off_line < 1e-3 and facing > 1 - 1e-6 and np.dot(p3 - p0, h3) > 0:
        ctrl = np.array([p0, p0 + (p3 - p0) / 3, p0 + 2 * (p3 - p0) / 3, p3])
        return _made(ctrl, t)
    h0 = np.array([math.cos(start[2]), math.sin(start[2])])
    pc = crossing_point(start, goal)
    f = np.linspace(0.05, 0.95, GRID)
    a, b = np.meshgrid(f, f, indexing="ij")
    if pc is not None:  # the paper's family: one bend inside the triangle p0, pc, p3
        p1 = p0 + a[..., None] * (pc - p0)
        p2 = p3 + b[..., None] * (pc - p3)
    elif np.dot(h0, p3 - p0) > 0:  # beside the line, facing along it: a gentle S
        reach = float(np.linalg.norm(p3 - p0)) * 0.6
        p1 = p0 + (a * reach)[..., None] * h0
        p2 = p3 - (b * reach)[..., None] * h3
    else:
        return None  # facing away from the door: turn first
    ctrl = np.stack([np.broadcast_to(p0, p1.shape), p1, p2, np.broadcast_to(p3, p1.shape)], -2)
    ctrl = np.ascontiguousarray(ctrl.reshape(-1, 4, 2))
    # constraint 4d (the paper's family): it bends one way only
    cost = _search_costs(ctrl, t, pc is not None)
    best = int(np.argmin(cost))
    if not np.isfinite(cost[best]):
        return None
    return _made(ctrl[best], t)


def _made(ctrl: np.ndarray, t: np.ndarray) -> DoorCurve:
    pos, d1, d2 = _bezier(ctrl, t)
    step = np.hypot(*np.diff(pos, axis=0).T)
    return DoorCurve(
        ctrl,
        pos,
        np.arctan2(d1[:, 1], d1[:, 0]),
        _curvature(d1, d2),
        float(step.sum()),
    )
