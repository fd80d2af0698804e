"""The band filter against the numpy masks it replaced: the same points bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

from shared.scan_band import band_points


def cloud(rng: np.random.Generator, n: int, dtype: type) -> np.ndarray:
    """A VLP-16-like cloud: ranges 0.3-12 m, 16 rings from -15 to +15 deg, some bad returns."""
    az = rng.uniform(-np.pi, np.pi, n)
    el = np.radians(rng.choice(np.linspace(-15, 15, 16), n))
    r = rng.uniform(0.3, 12.0, n)
    pts = np.stack([r * np.cos(el) * np.cos(az), r * np.cos(el) * np.sin(az), r * np.sin(el)], 1)
    pts[rng.integers(n, size=n // 500)] = np.nan
    pts[rng.integers(n, size=n // 500), rng.integers(3)] = np.inf
    return pts.astype(dtype)


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_the_band_and_reach_keep_what_numpys_masks_keep(dtype: type) -> None:
    rng = np.random.default_rng(5)
    for _ in range(20):
        pts = cloud(rng, 26000, dtype)
        for band, reach in ((0.5, None), (0.3, None), (0.3, 2.37), (0.5, 1.9), (1e-3, 50.0)):
            mask = np.abs(pts[:, 2]) < band
            if reach is not None:
                mask &= np.hypot(pts[:, 0], pts[:, 1]) < reach
            got = band_points(pts, band, reach)
            assert got.dtype == pts.dtype
            assert np.array_equal(got, pts[mask], equal_nan=True)
    assert band_points(np.zeros((0, 3), dtype=dtype), 0.5).shape == (0, 3)
