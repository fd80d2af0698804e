"""What the sampling MPC's rollouts are scored against, prepared once per path or per cycle.

* the chair's footprint as the evaluators check it (:class:`Body`): check points on its
  outline, grouped into parts with bounding circles for an early-out test;
* distance fields (:class:`Field`): the map's walls (from the floor map, per floor) and the
  live LiDAR points (stamped into a small grid every cycle);
* the path, simplified once (collinear runs become one segment);
* :class:`Scene`: everything one evaluation reads, as arrays ready for numba.

Readings of a field never exceed the true distance at the point read (values are lowered by
half a cell diagonal per cell that a point can lie anywhere in), so a rollout judged clear
is clear. Pure computation: no I/O, no clock.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from services.controller.edt import distance_transform
from shared.config import Footprint

FAR = 1.0e3  # clearance (m) reported where nothing is near
# The footprint split lengthwise x crosswise for the early-out test; each part has a bounding
# circle. Structure, not tuning: it changes how fast a clearance is found, never its value.
_PARTS = (2, 2)


# --------------------------------------------------------------------------------------
# The footprint
# --------------------------------------------------------------------------------------


def footprint_points(fp: Footprint, spacing: float) -> tuple[np.ndarray, float]:
    """Check points on the footprint's outline (body frame) and half the largest gap.

    Corners plus evenly spaced edge points at most ``spacing`` apart. A point obstacle that
    keeps ``d`` from every check point keeps ``sqrt(d^2 - gap^2)`` from the edges between
    them, so the collision threshold is widened by the half gap instead of adding points.
    """
    length = fp.front + fp.rear
    nx = max(1, math.ceil(length / spacing - 1e-9))
    ny = max(1, math.ceil(fp.width / spacing - 1e-9))
    xs = np.linspace(-fp.rear, fp.front, nx + 1)
    ys = np.linspace(-fp.width / 2, fp.width / 2, ny + 1)
    pts = [(x, ys[0]) for x in xs] + [(x, ys[-1]) for x in xs]
    pts += [(xs[0], y) for y in ys[1:-1]] + [(xs[-1], y) for y in ys[1:-1]]
    return np.array(pts, dtype=np.float32), 0.5 * max(length / nx, fp.width / ny)


@dataclass
class Body:
    """The footprint as the evaluators check it."""

    points: np.ndarray  # (P, 2) float32 check points on the outline, sorted by part
    parts: np.ndarray  # (H, 2) centres of the parts' bounding circles
    part_r: float  # the common radius of those circles
    part_idx: np.ndarray  # (H + 1,) where each part's points start (and the last ends)
    threshold: float  # a check point reading less than this is colliding
    radius: float  # largest |coordinate| of a check point (how far the body reaches)


def footprint_body(fp: Footprint, spacing: float, safety_margin: float) -> Body:
    """Check points at most ``spacing`` apart, colliding within ``safety_margin`` of the outline."""
    pts, half_gap = footprint_points(fp, spacing)
    points, parts, part_r, part_idx = _footprint_parts(fp, pts)
    threshold = math.hypot(safety_margin, half_gap)
    return Body(points, parts, part_r, part_idx, threshold, float(np.abs(points).max()))


def _footprint_parts(
    fp: Footprint, pts: np.ndarray
) -> tuple[np.ndarray, np.ndarray, float, np.ndarray]:
    """Split the footprint into ``_PARTS`` sub-rectangles for the early-out test.

    Returns the check points sorted by part, the parts' centres, the common radius of
    their bounding circles and where each part's points start (and the last ends).
    """
    nx, ny = _PARTS
    length = fp.front + fp.rear
    lx, ly = length / nx, fp.width / ny
    ix = np.minimum(((pts[:, 0] + fp.rear) / lx + 1e-6).astype(int), nx - 1)
    iy = np.minimum(((pts[:, 1] + fp.width / 2) / ly + 1e-6).astype(int), ny - 1)
    part = ix * ny + iy
    order = np.argsort(part, kind="stable")
    centres = np.array(
        [[-fp.rear + (i + 0.5) * lx, -fp.width / 2 + (j + 0.5) * ly]
         for i in range(nx) for j in range(ny)],
        dtype=np.float64,
    )  # fmt: skip
    starts = np.searchsorted(part[order], np.arange(nx * ny + 1)).astype(np.int64)
    return pts[order], centres, math.hypot(lx / 2, ly / 2), starts


# --------------------------------------------------------------------------------------
# Distance fields
# --------------------------------------------------------------------------------------


@dataclass
class Field:
    """A distance field for lookups: values (H, W) float32, origin and resolution."""

    data: np.ndarray
    ox: float
    oy: float
    res: float
    outside: float  # value off the grid


def wall_field(dist: np.ndarray, resolution: float, origin: tuple[float, float]) -> Field:
    """The walls' field from ``dist`` (metres to the nearest wall per cell, row 0 at the bottom).

    Cell (r, c) has its centre at ``origin + ((c + .5) * res, (r + .5) * res)``. A point
    reads the value of the cell it falls in, lowered by half a cell diagonal so that
    the reading never exceeds the distance at the point itself; off the grid is a wall.
    """
    d = np.asarray(dist, dtype=np.float32)
    if d.ndim != 2 or min(d.shape) < 2:
        raise ValueError(f"distance field must be 2-D and at least 2 x 2, got {d.shape}")
    if not resolution > 0:
        raise ValueError(f"resolution must be > 0, got {resolution}")
    d = np.minimum(np.nan_to_num(d, nan=0.0, posinf=FAR), FAR) - np.float32(_half_diag(resolution))
    d = np.ascontiguousarray(d, dtype=np.float32)
    return Field(d, float(origin[0]), float(origin[1]), float(resolution), 0.0)


def obstacle_field(
    obstacles: np.ndarray | None,
    x: float,
    y: float,
    res: float,
    cutoff: float,
    body: Body,
    horizon: float,
) -> Field | None:
    """Distance field of the LiDAR points that a rollout's footprint could come near.

    Points are stamped into a grid of ``res`` over their bounding box, grown by what the
    cost and the early-out test read (``cutoff``, the larger of the obstacle influence and
    the collision threshold, plus a part's radius and three cells), clipped to what the body
    can reach within ``horizon`` metres of travel from (x, y). Values are lowered by a whole cell
    diagonal: half for a point anywhere in its cell, half for the query point anywhere in
    its cell (see ``wall_field``).
    """
    if obstacles is None or len(obstacles) == 0:
        return None
    pts = np.asarray(obstacles)
    grow = cutoff + body.part_r + 3.0 * res
    reach = horizon + body.radius * 1.5 + grow
    free, ox, oy = _stamp(pts[:, 0], pts[:, 1], x, y, reach, grow, res)
    if free.size == 0:
        return None
    dist = distance_transform(free)
    dist *= np.float32(res)
    dist -= np.float32(2.0 * _half_diag(res))
    return Field(dist, float(ox), float(oy), res, FAR)


@numba.njit(cache=True)
def _stamp(px_in, py_in, x, y, reach, grow, res):
    """The grid of ``obstacle_field`` (True: free) and its origin: the finite points
    within ``reach`` of (x, y) on both axes, stamped into cells of ``res`` over their
    bounding box grown by ``grow`` and clipped to that reach (0 x 0 if none). One pass
    to bound them, one to stamp, as the vectorised form did (the same cells)."""
    n = px_in.shape[0]
    keep = np.zeros(n, dtype=np.bool_)
    lo_x = lo_y = np.inf
    hi_x = hi_y = -np.inf
    for i in range(n):
        px, py = np.float64(px_in[i]), np.float64(py_in[i])
        near = abs(px - x) <= reach and abs(py - y) <= reach
        if near and math.isfinite(px) and math.isfinite(py):
            keep[i] = True
            lo_x, lo_y = min(lo_x, px), min(lo_y, py)
            hi_x, hi_y = max(hi_x, px), max(hi_y, py)
    if not keep.any():
        return np.ones((0, 0), dtype=np.bool_), 0.0, 0.0
    ox, oy = max(lo_x - grow, x - reach), max(lo_y - grow, y - reach)
    ex, ey = min(hi_x + grow, x + reach), min(hi_y + grow, y + reach)
    cols = max(int(math.ceil((ex - ox) / res)), 2)
    rows = max(int(math.ceil((ey - oy) / res)), 2)
    free = np.ones((rows, cols), dtype=np.bool_)
    for i in range(n):
        if keep[i]:
            c = int((np.float64(px_in[i]) - ox) / res)
            r = int((np.float64(py_in[i]) - oy) / res)
            free[min(max(r, 0), rows - 1), min(max(c, 0), cols - 1)] = False
    return free, ox, oy


def warm_up() -> None:
    """Compile (or load) the stamping kernel now for float64 points (the controller's
    placed scan) and float32 ones, not in the first control cycle with LiDAR points."""
    for kind in (np.float64, np.float32):
        pts = np.zeros((2, 2), dtype=kind)  # columns of an (N, 2) array, as the scene's
        _stamp(pts[:, 0], pts[:, 1], 0.0, 0.0, 1.0, 0.5, 0.1)


def _half_diag(res: float) -> float:
    """Half a cell diagonal: how far a point can be from the centre of its cell."""
    return res * math.sqrt(0.5)


def slack(f: Field) -> float:
    """How far a reading at a point can undershoot the reading at a nearby centre, less the gap.

    Readings are cell values lowered by half a diagonal (h): reading(q) >= true(q) - 2h >=
    true(p) - |q - p| - 2h >= reading(p) - |q - p| - 2h.
    """
    return 2.0 * _half_diag(f.res)


# An empty field: what the numba kernel reads when there are no walls or no points
EMPTY = Field(np.full((2, 2), FAR, dtype=np.float32), 0.0, 0.0, 1.0, FAR)


# --------------------------------------------------------------------------------------
# The path and the scene
# --------------------------------------------------------------------------------------


def simplify(pts: np.ndarray, tol: float) -> np.ndarray:
    """Indices of the vertices Douglas-Peucker keeps (collinear runs become one segment)."""
    keep = np.zeros(len(pts), dtype=bool)
    keep[0] = keep[-1] = True
    stack = [(0, len(pts) - 1)]
    while stack:
        i, j = stack.pop()
        if j <= i + 1:
            continue
        a, b = pts[i], pts[j]
        d = b - a
        n = math.hypot(d[0], d[1])
        rel = pts[i + 1 : j] - a
        if n < 1e-12:
            dist = np.hypot(rel[:, 0], rel[:, 1])
        else:
            dist = np.abs(rel[:, 0] * d[1] - rel[:, 1] * d[0]) / n
        k = int(np.argmax(dist))
        if dist[k] > tol:
            m = i + 1 + k
            keep[m] = True
            stack += [(i, m), (m, j)]
    return np.flatnonzero(keep)


@dataclass
class Scene:
    """Everything one evaluation needs, prepared once per cycle (arrays ready for numba)."""

    state: np.ndarray  # x, y, theta, v, w
    limits: np.ndarray  # dt, v_min, v_max, w_max, dv_max, dw_max (per step)
    sigma: np.ndarray  # sigma_v, sigma_w, noise_corr
    wall: Field | None
    obs: Field | None
    path_xy: np.ndarray  # (S + 1, 2) window of the simplified path
    path_s: np.ndarray  # (S + 1,) arc length at those vertices
    path_len: np.ndarray  # (S,) segment lengths
    path_cos: np.ndarray  # (S,) segment heading cosines
    path_sin: np.ndarray  # (S,) segment heading sines
    vtab: np.ndarray  # v_ref sampled every vtab_ds metres of arc length
    vtab_ds: float
    goal: np.ndarray  # (2,)
    goal_on: bool
    params: np.ndarray  # s_now, expected progress, huber, threshold, influences, window
    s_exp: np.ndarray  # (T,) arc length v_ref would cover from s_now by each step
    s_wt: np.ndarray  # progress shortfall weights: every step, extra at the last step
    weights: np.ndarray  # one per cost term, indexed by the constants of mpc_costs
