"""Plane geometry used by several services."""

from __future__ import annotations

import math

import numba
import numpy as np


def wrap_angle(a: float) -> float:
    """``a`` (radians) brought into [-pi, pi]."""
    return math.atan2(math.sin(a), math.cos(a))


def angle_between(a: float, b: float) -> float:
    """The unsigned angle (radians, 0..pi) from heading ``b`` to heading ``a``."""
    return abs(wrap_angle(a - b))


def into_frame(xy: np.ndarray, x: float, y: float, theta: float) -> np.ndarray:
    """Map-frame points (N, 2) in the frame of a pose (x, y, theta): x forwards, y left."""
    c, s = math.cos(theta), math.sin(theta)
    dx, dy = xy[:, 0] - x, xy[:, 1] - y
    return np.column_stack((c * dx + s * dy, -s * dx + c * dy))


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


SWEEP_STEP_M = 0.01  # a swept footprint's far corner moves at most this far between poses


def turn_steps(turn_rad: float, front: float, rear: float, width: float) -> int:
    """How many poses a turn of ``turn_rad`` (on the spot, or along an arc) is checked at:
    enough that the corner farthest from the rear axle moves at most ``SWEEP_STEP_M``
    between two, never fewer than 4. Between two poses the rectangles leave a notch about
    a third of that deep: four poses over 15 deg moved the corner 5 cm and let a point
    5 mm off its path read 1-2 cm away."""
    reach = math.hypot(max(front, rear), width / 2)
    return max(4, math.ceil(abs(turn_rad) * reach / SWEEP_STEP_M))


def turn_closes_in(
    xy: np.ndarray, front: float, rear: float, width: float, margin: float, angle: float
) -> bool:
    """True if turning on the spot by ``angle`` (radians, about the rear axle; the sign says
    which way) brings a point (N, 2, chair frame) within ``margin`` of the rectangle, or one
    already within it nearer still: beside a wall, a corner swings on into it."""
    if angle == 0.0:
        return False
    n = turn_steps(angle, front, rear, width)
    poses = [(0.0, 0.0, phi) for phi in np.linspace(angle / n, angle, n)]
    return moves_close_in(xy, front, rear, width, margin, poses)


def arc_poses(
    length: float, curvature: float, steps: int = 4, max_turn_rad: float = math.inf
) -> list[tuple[float, float, float]]:
    """Poses (x, y, heading, chair frame) along the arc of ``curvature`` (1/m, left > 0),
    every ``length / steps`` metres of it (``length`` < 0: backwards); once the heading
    has turned ``max_turn_rad`` the rest is straight on (a turn that ends there)."""
    out = []
    bend = math.inf if abs(curvature) < 1e-12 else max_turn_rad / abs(curvature)
    for s in np.linspace(length / steps, length, steps):
        arc = math.copysign(min(abs(s), bend), s)
        phi = curvature * arc
        if abs(phi) < 1e-9:
            x, y = float(arc), 0.0
        else:
            x, y = math.sin(phi) / curvature, (1.0 - math.cos(phi)) / curvature
        on = float(s - arc)  # straight on past the end of the turn
        out.append((x + on * math.cos(phi), y + on * math.sin(phi), phi))
    return out


def swept_arc_poses(
    length: float, curvature: float, max_turn_rad: float, front: float, rear: float, width: float
) -> list[tuple[float, float, float]]:
    """:func:`arc_poses` at as many poses as the turn along them needs (:func:`turn_steps`)."""
    turn = min(abs(length * curvature), max_turn_rad)
    steps = turn_steps(turn, front, rear, width)
    return arc_poses(length, curvature, steps=steps, max_turn_rad=max_turn_rad)


def moves_close_in(
    xy: np.ndarray,
    front: float,
    rear: float,
    width: float,
    margin: float,
    poses: list[tuple[float, float, float]],
) -> bool:
    """True if the rectangle at any of ``poses`` (chair frame) comes within ``margin`` of a
    point (N, 2, chair frame), or nearer to one already within it: what a move sweeps into
    (points it keeps its distance from, a jamb beside a straight pass, do not count).

    Compiled: the controller's guard asks this of every scan point at every step."""
    if len(xy) == 0 or len(poses) == 0:
        return False
    pts = np.ascontiguousarray(xy[:, :2], dtype=np.float64)
    trig = np.array([(px, py, math.cos(phi), math.sin(phi)) for px, py, phi in poses])
    return bool(_moves_close_in(pts, float(front), float(rear), float(width), float(margin), trig))


def warm_up() -> None:
    """Compile (or load) the sweep kernel now, not in the first control cycle that turns:
    in lockstep the compile would hold a tick."""
    moves_close_in(np.zeros((1, 2)), 0.1, 0.1, 0.1, 0.0, [(0.0, 0.0, 0.1)])


@numba.njit(cache=True, inline="always")
def _rect_gap(x: float, y: float, front: float, rear: float, half: float) -> float:
    dx = max(max(-rear - x, x - front), 0.0)
    dy = max(abs(y) - half, 0.0)
    return math.hypot(dx, dy)


@numba.njit(cache=True)
def _moves_close_in(
    xy: np.ndarray, front: float, rear: float, width: float, margin: float, trig: np.ndarray
) -> bool:
    """:func:`moves_close_in` over points (N, 2) and poses (K, 4: x, y, cos, sin)."""
    half = width / 2.0
    for i in range(xy.shape[0]):
        x, y = xy[i, 0], xy[i, 1]
        floor = min(_rect_gap(x, y, front, rear, half), margin) - 1e-3
        for k in range(trig.shape[0]):
            dx, dy = x - trig[k, 0], y - trig[k, 1]
            c, s = trig[k, 2], trig[k, 3]
            if _rect_gap(c * dx + s * dy, -s * dx + c * dy, front, rear, half) < floor:
                return True
    return False
