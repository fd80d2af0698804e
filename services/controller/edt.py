"""Exact Euclidean distance transform of a boolean grid, compiled.

The MPC stamps the LiDAR points near the chair into a fine grid (2.5 cm: about 300 x 300
cells) every control cycle and needs each free cell's distance to the nearest stamped
one. ``scipy.ndimage.distance_transform_edt`` computes a feature transform on the way and
took most of the cycle's scene preparation; this is the two-pass algorithm of Felzenszwalb
and Huttenlocher ("Distance Transforms of Sampled Functions", 2012) on integer squared
distances, so its values equal scipy's bit for bit (the test compares them).
"""

from __future__ import annotations

import math

import numba
import numpy as np

_INF = 1e30  # a squared distance no grid reaches: "no occupied cell in this column"


def distance_transform(free: np.ndarray) -> np.ndarray:
    """Distance (in cells, float32) from each cell of ``free`` (2-D bool) to the nearest
    False cell, 0 on those; as ``distance_transform_edt(free)``. ``free`` must hold at
    least one False cell."""
    grid = np.ascontiguousarray(free, dtype=np.bool_)
    if grid.ndim != 2 or grid.all():
        raise ValueError("distance_transform needs a 2-D grid with an occupied (False) cell")
    return _transform(grid)


def warm_up() -> None:
    """Compile (or load) the transform's kernels now, not in the first control cycle with
    LiDAR points: a 2 x 2 grid, C-contiguous bool as ``mpc_scene.obstacle_field`` passes."""
    free = np.ones((2, 2), dtype=np.bool_)
    free[0, 0] = False
    distance_transform(free)


@numba.njit(cache=True)
def _columns(free: np.ndarray) -> np.ndarray:
    """Squared distance along each column to the nearest occupied cell (_INF if none);
    swept a row at a time, down then up, so memory is read in order."""
    rows, cols = free.shape
    out = np.empty((rows, cols), dtype=np.float64)
    d = np.full(cols, -1, dtype=np.int64)
    for i in range(rows):
        for j in range(cols):
            if not free[i, j]:
                d[j] = 0
            elif d[j] >= 0:
                d[j] += 1
            out[i, j] = _INF if d[j] < 0 else float(d[j] * d[j])
    d[:] = -1
    for i in range(rows - 1, -1, -1):
        for j in range(cols):
            if not free[i, j]:
                d[j] = 0
            elif d[j] >= 0:
                d[j] += 1
            if d[j] >= 0 and d[j] * d[j] < out[i, j]:
                out[i, j] = float(d[j] * d[j])
    return out


@numba.njit(cache=True)
def _transform(free: np.ndarray) -> np.ndarray:
    rows, cols = free.shape
    g = _columns(free)
    out = np.empty((rows, cols), dtype=np.float32)
    v = np.empty(cols, dtype=np.int64)  # parabolas of the lower envelope
    z = np.empty(cols + 1, dtype=np.float64)  # where each one takes over
    for i in range(rows):
        f = g[i]
        k = -1
        for q in range(cols):
            if f[q] >= _INF:
                continue
            s = -_INF
            while k >= 0:
                p = v[k]
                s = ((f[q] + q * q) - (f[p] + p * p)) / (2.0 * (q - p))
                if s > z[k]:
                    break
                k -= 1
            k += 1
            v[k] = q
            z[k] = s if k > 0 else -_INF
            z[k + 1] = _INF
        m = 0
        for q in range(cols):
            while z[m + 1] < q:
                m += 1
            p = v[m]
            out[i, q] = np.float32(math.sqrt(f[p] + (q - p) * (q - p)))
    return out
