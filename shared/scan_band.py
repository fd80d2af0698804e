"""The returns of a 3-D scan in a height band around the sensor (and within a range of it).

The localisation matches, and the guard checks, only the returns within ``band_m`` of the
sensor's height (walls and jambs, not the floor returns of the downward rings); the guard
also only those its checks can reach. A VLP-16 scan holds about 26,000 returns 10 times a
second: one compiled pass instead of numpy's temporaries (an absolute value, a hypot, two
comparisons and a mask), with the same tests in the cloud's own float type, so the same
points bit for bit (tests/shared/test_scan_band.py).
"""

from __future__ import annotations

import math

import numba
import numpy as np


def band_points(points: np.ndarray, band_m: float, reach_m: float | None = None) -> np.ndarray:
    """The rows of ``points`` (N, 3; sensor frame) with ``|z| < band_m`` and, with
    ``reach_m``, ``hypot(x, y) < reach_m``: ``points[mask]`` as numpy would select them."""
    kind = points.dtype.type  # the thresholds in the cloud's type, as numpy compares
    if reach_m is None:
        return _band(points, kind(band_m), kind(0.0), False)
    return _band(points, kind(band_m), kind(reach_m), True)


def warm_up() -> None:
    """Compile (or load) the kernel now for float32 clouds (the LiDAR's) and float64 ones."""
    for kind in (np.float32, np.float64):
        band_points(np.ones((2, 3), dtype=kind), 0.5)
        band_points(np.ones((2, 3), dtype=kind), 0.5, 2.0)


@numba.njit(cache=True)
def _band(pts, band, reach, use_reach):
    keep = np.empty(pts.shape[0], dtype=np.bool_)
    m = 0
    for i in range(pts.shape[0]):
        ok = abs(pts[i, 2]) < band
        if ok and use_reach:
            ok = math.hypot(pts[i, 0], pts[i, 1]) < reach
        keep[i] = ok
        m += ok
    out = np.empty((m, pts.shape[1]), dtype=pts.dtype)
    j = 0
    for i in range(pts.shape[0]):
        if keep[i]:
            out[j] = pts[i]
            j += 1
    return out
