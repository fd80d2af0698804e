"""Inflation: lethal disc of the robot radius around obstacles, optional exponential cost band."""

from __future__ import annotations

import numpy as np
import pytest

from services.planner.inflation import inflate, obstacle_distance

RES = 0.05


def single_obstacle(size: int = 41) -> tuple[np.ndarray, int]:
    occ = np.zeros((size, size), dtype=bool)
    centre = size // 2
    occ[centre, centre] = True
    return occ, centre


def test_single_cell_inflates_to_a_disc_of_the_radius() -> None:
    occ, c = single_obstacle()
    radius = 0.47  # 9.4 cells: no cell centre lies on the boundary
    lethal, cost = inflate(occ, RES, radius)
    rr, cc = np.mgrid[: occ.shape[0], : occ.shape[1]]
    expected = np.hypot(rr - c, cc - c) * RES < radius
    assert np.array_equal(lethal, expected)
    assert lethal[c, c + 9] and not lethal[c, c + 10]  # 0.45 m inside, 0.50 m outside
    assert lethal[c + 6, c + 6] and not lethal[c + 7, c + 7]  # 0.42 m inside, 0.49 m outside
    assert lethal.dtype == bool
    assert cost.dtype == np.float32 and not cost.any()


def test_occupied_cells_are_lethal_even_with_zero_radius() -> None:
    occ, c = single_obstacle(5)
    lethal, _ = inflate(occ, RES, 0.0)
    assert np.array_equal(lethal, occ)


def test_cost_band_is_zero_when_off() -> None:
    occ, _ = single_obstacle()
    _, cost = inflate(occ, RES, 0.3, cost_band_m=0.0)
    assert cost.dtype == np.float32
    assert not cost.any()


def test_cost_band_decreases_with_distance_and_is_zero_on_lethal_cells() -> None:
    occ, c = single_obstacle(61)
    radius, band, scaling = 0.3, 0.5, 10.0
    lethal, cost = inflate(occ, RES, radius, cost_band_m=band, cost_scaling=scaling)
    assert cost.dtype == np.float32 and (cost >= 0).all()
    assert not cost[lethal].any()
    ray = cost[c, c:]  # along a row away from the obstacle
    d = np.arange(len(ray)) * RES
    inside = (d >= radius) & (d < radius + band)
    assert np.all(np.diff(ray[inside]) < 0)
    np.testing.assert_allclose(ray[inside], np.exp(-scaling * (d[inside] - radius)), rtol=1e-6)
    assert not ray[d >= radius + band + 1e-9].any()
    assert ray[inside][0] == pytest.approx(1.0)  # first free cell sits on the radius


def test_grid_without_obstacles_is_free_and_costless() -> None:
    lethal, cost = inflate(np.zeros((4, 6), dtype=bool), RES, 0.5, cost_band_m=1.0)
    assert not lethal.any() and not cost.any()
    assert np.isinf(obstacle_distance(np.zeros((2, 2), dtype=bool), RES)).all()


def test_bad_input_is_refused() -> None:
    with pytest.raises(ValueError, match="2-D"):
        inflate(np.zeros(5, dtype=bool), RES, 0.3)
    with pytest.raises(ValueError, match="resolution"):
        inflate(np.zeros((3, 3), dtype=bool), 0.0, 0.3)


def test_building_sized_grid_inflates() -> None:
    rng = np.random.default_rng(0)
    occ = np.zeros((800, 4000), dtype=bool)
    occ[0, :] = occ[-1, :] = occ[:, 0] = occ[:, -1] = True
    occ[rng.integers(0, 800, 2000), rng.integers(0, 4000, 2000)] = True
    lethal, cost = inflate(occ, RES, 0.45, cost_band_m=0.3)
    assert lethal.shape == cost.shape == (800, 4000)
    assert lethal.dtype == bool and cost.dtype == np.float32
    assert lethal[occ].all()
    assert not cost[lethal].any() and cost.max() <= 1.0
