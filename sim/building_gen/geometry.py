"""Plane geometry of the generator: the map grid, rectangles, sample points and free space.

Everything is drawn on the 0.05 m map grid: wall centre lines, rectangle edges and door
ends are multiples of 0.05 m, so the raster holds exactly what the plan says. Free space
is a union of carved rectangles minus obstacles (door leaves, columns, furniture);
:class:`FreeSpace` answers whether a set of sample points lies in it.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

RES = 0.05
WALL = 0.2
HALF = WALL / 2
EPS = 1e-6

Rect = tuple[float, float, float, float]  # x0, y0, x1, y1 (metres), x0 <= x1, y0 <= y1


def snap(value: float, step: float = RES) -> float:
    """``value`` on the ``step`` grid, rounded so equal grid values compare equal."""
    return round(round(value / step) * step, 6)


def pick(rng: np.random.Generator, low: float, high: float, step: float) -> float:
    """A uniform draw from ``low, low + step, ..., high`` (at least ``low``)."""
    n = max(0, math.floor((high - low) / step + 1e-9))
    return round(low + step * int(rng.integers(n + 1)), 6)


def rect(x0: float, y0: float, x1: float, y1: float) -> Rect:
    """The rectangle spanned by two corners given in any order (rounded to the µm)."""
    return (
        round(min(x0, x1), 6),
        round(min(y0, y1), 6),
        round(max(x0, x1), 6),
        round(max(y0, y1), 6),
    )


def grow(r: Rect, d: float) -> Rect:
    return (r[0] - d, r[1] - d, r[2] + d, r[3] + d)


def overlaps(a: Rect, b: Rect) -> bool:
    """Whether the interiors of ``a`` and ``b`` share a positive area (touching is not)."""
    return a[0] < b[2] - EPS and b[0] < a[2] - EPS and a[1] < b[3] - EPS and b[1] < a[3] - EPS


def on_boundary(p: tuple[float, float], r: Rect) -> bool:
    """Whether ``p`` lies on the edge of ``r`` (a door in a space's wall)."""
    x, y = p
    inside = r[0] - 1e-6 <= x <= r[2] + 1e-6 and r[1] - 1e-6 <= y <= r[3] + 1e-6
    edge = min(abs(x - r[0]), abs(x - r[2]), abs(y - r[1]), abs(y - r[3])) < 1e-6
    return inside and edge


def rect_gap(a: Rect, b: Rect) -> float:
    """Euclidean distance between two rectangles (0 when they touch or overlap)."""
    dx = max(0.0, a[0] - b[2], b[0] - a[2])
    dy = max(0.0, a[1] - b[3], b[1] - a[3])
    return math.hypot(dx, dy)


def point_rect_dist(x: float, y: float, r: Rect) -> float:
    """Distance from a point to a rectangle (0 inside)."""
    dx = max(0.0, r[0] - x, x - r[2])
    dy = max(0.0, r[1] - y, y - r[3])
    return math.hypot(dx, dy)


@lru_cache(maxsize=16)
def _disc_offsets(radius: float, step: float) -> np.ndarray:
    n = math.ceil(radius / step)
    grid = np.arange(-n, n + 1) * step
    dx, dy = np.meshgrid(grid, grid)
    inside = dx**2 + dy**2 <= radius**2
    ring = np.linspace(0.0, 2 * math.pi, max(16, math.ceil(2 * math.pi * radius / (step / 2))))
    rim = np.stack([np.cos(ring) * radius, np.sin(ring) * radius], axis=1)
    return np.concatenate([np.stack([dx[inside], dy[inside]], axis=1), rim])


def disc_points(x: float, y: float, radius: float, step: float = RES) -> np.ndarray:
    """Sample points covering the closed disc (a grid inside plus its rim)."""
    return _disc_offsets(round(radius, 6), step) + (x, y)


def rect_points(r: Rect, step: float = RES) -> np.ndarray:
    """Sample points covering the closed rectangle, edges included."""
    xs = np.append(np.arange(r[0], r[2], step), r[2])
    ys = np.append(np.arange(r[1], r[3], step), r[3])
    gx, gy = np.meshgrid(xs, ys)
    return np.stack([gx.ravel(), gy.ravel()], axis=1)


def _inside(points: np.ndarray, rects: np.ndarray, closed: bool) -> np.ndarray:
    """Per point: whether it lies in any of ``rects`` (closed or open rectangles)."""
    if len(rects) == 0 or len(points) == 0:
        return np.zeros(len(points), dtype=bool)
    lo, hi = points.min(axis=0), points.max(axis=0)
    near = rects[
        (rects[:, 0] <= hi[0] + EPS)
        & (rects[:, 2] >= lo[0] - EPS)
        & (rects[:, 1] <= hi[1] + EPS)
        & (rects[:, 3] >= lo[1] - EPS)
    ]
    if len(near) == 0:
        return np.zeros(len(points), dtype=bool)
    px, py = points[:, :1], points[:, 1:]
    e = EPS if closed else -EPS
    hit = (
        (px >= near[:, 0] - e)
        & (px <= near[:, 2] + e)
        & (py >= near[:, 1] - e)
        & (py <= near[:, 3] + e)
    )
    return hit.any(axis=1)


class FreeSpace:
    """One floor's free space while it is being planned: carved rectangles minus obstacles."""

    def __init__(self) -> None:
        self.carves: list[Rect] = []
        self.obstacles: list[Rect] = []

    def free(self, points: np.ndarray) -> bool:
        """True if every point is carved and none lies inside an obstacle."""
        carved = _inside(points, np.asarray(self.carves).reshape(-1, 4), closed=True)
        if not carved.all():
            return False
        blocked = _inside(points, np.asarray(self.obstacles).reshape(-1, 4), closed=False)
        return not blocked.any()

    def any_carved(self, points: np.ndarray) -> bool:
        """True if any point lies in a carved rectangle."""
        return bool(_inside(points, np.asarray(self.carves).reshape(-1, 4), closed=True).any())

    def all_carved(self, points: np.ndarray) -> bool:
        """True if every point lies in a carved rectangle (obstacles aside)."""
        return bool(_inside(points, np.asarray(self.carves).reshape(-1, 4), closed=True).all())
