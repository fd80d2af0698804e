"""Odometry-mode localisation composes increments onto the anchor pose."""

from __future__ import annotations

import math

import pytest

from services.localisation.localiser import OdometryLocaliser


def test_increments_are_rotated_into_the_map_frame() -> None:
    loc = OdometryLocaliser(10.0, 5.0, math.pi / 2, "1")
    loc.update(0.0, 0.0, 0.0)  # odometry frame starts elsewhere
    x, y, th = loc.update(1.0, 0.0, 0.0)  # one metre forward in odom
    assert (x, y) == pytest.approx((10.0, 6.0))
    assert th == pytest.approx(math.pi / 2)
    x, y, th = loc.update(1.0, 0.0, math.pi / 2)  # turn left on the spot
    assert th == pytest.approx(math.pi) or th == pytest.approx(-math.pi)


def test_reset_reanchors() -> None:
    loc = OdometryLocaliser(0, 0, 0, "1")
    loc.update(0, 0, 0)
    loc.update(2, 0, 0)
    loc.reset(5, 5, 0, "2")
    loc.update(2, 0, 0)
    assert loc.update(3, 0, 0) == pytest.approx((6, 5, 0))
    assert loc.floor == "2"
