"""The compiled distance transform equals scipy's, value for value."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.ndimage import distance_transform_edt

from services.controller.edt import distance_transform


@pytest.mark.parametrize("density", [0.0005, 0.01, 0.2, 0.7])
def test_equals_scipy_on_random_grids(density: float) -> None:
    rng = np.random.default_rng(int(density * 1e4))
    for _ in range(40):
        rows, cols = rng.integers(1, 90, 2)
        free = rng.random((rows, cols)) > density
        free[rng.integers(rows), rng.integers(cols)] = False
        expected = distance_transform_edt(free).astype(np.float32)
        assert np.array_equal(distance_transform(free), expected)


def test_single_point_and_lines() -> None:
    free = np.ones((50, 70), dtype=bool)
    free[10, 60] = False
    free[40, :] = False
    assert np.array_equal(distance_transform(free), distance_transform_edt(free).astype(np.float32))


def test_a_grid_with_nothing_occupied_is_refused() -> None:
    with pytest.raises(ValueError, match="occupied"):
        distance_transform(np.ones((4, 4), dtype=bool))
