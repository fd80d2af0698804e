"""The smooth way onto a door's centre line (the door-passing paper's cubic Bézier)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from services.controller.door_bezier import crossing_point, door_curve

GOAL = (5.0, 0.0, 0.0)  # on the door's centre line (y = 0), facing through it (+x)


def test_on_the_line_and_facing_the_door_is_straight() -> None:
    c = door_curve((1.0, 0.0, 0.0), GOAL)
    assert np.abs(c.curvature).max() < 1e-9 and c.length_m == pytest.approx(4.0)


@pytest.mark.parametrize("start", [(1.0, 1.2, -0.3), (0.5, -1.5, 0.6), (2.0, 0.6, 0.0)])
def test_it_starts_along_the_chair_and_ends_on_the_line_facing_the_door(start) -> None:
    c = door_curve(start, GOAL)
    assert c is not None
    assert np.allclose(c.points[0], start[:2]) and np.allclose(c.points[-1], GOAL[:2])
    assert c.heading[0] == pytest.approx(start[2], abs=1e-6)
    assert c.heading[-1] == pytest.approx(GOAL[2], abs=1e-6)
    assert c.points[:, 0].max() <= GOAL[0] + 1e-9  # never past the goal towards the door
    if crossing_point(start, GOAL) is not None:
        k = c.curvature  # the paper's family: inside the triangle, bending one way only
        assert (k >= -1e-9).all() or (k <= 1e-9).all()
        assert (c.points[:, 1] >= -1e-9).all() or (c.points[:, 1] <= 1e-9).all()


def test_the_smoothest_of_the_family_is_taken() -> None:
    # from 1 m off the line with a 30 deg heading, the curve's curvature stays modest
    c = door_curve((1.0, -1.0, math.radians(30)), GOAL)
    assert np.abs(c.curvature).max() < 2.0
    v = c.speed_limit(0.2, 0.3)
    assert v.max() <= 0.2 and v.min() > 0


def test_facing_away_there_is_none_and_beside_the_line_an_s() -> None:
    assert door_curve((1.0, 1.0, math.pi), GOAL) is None  # facing away from the door
    s_curve = door_curve((1.0, 1.0, 0.0), GOAL)  # beside the line, facing along it
    assert s_curve is not None and s_curve.curvature.min() < 0 < s_curve.curvature.max()
    assert crossing_point((1.0, 1.0, -0.5), GOAL) is not None
