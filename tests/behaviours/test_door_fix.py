"""The door's shift from the map, as the scans' doorways show it (behaviours/door_fix.py)."""

from __future__ import annotations

import math

import pytest

from behaviours.door_fix import DoorFix, DoorSightings

WALL = math.pi / 2  # a door at (2, 0) passed along +x: its wall runs along y


def sightings(reach_m: float = 0.3, min_width_m: float = 0.65) -> DoorSightings:
    return DoorSightings((2.0, 0.0), 0.0, reach_m, min_width_m)


def test_the_shift_is_the_median_offset_along_the_wall() -> None:
    seen = sightings()
    for y in (0.09, 0.11, 0.10, 0.30):  # one stray sighting at the reach's edge
        assert seen.add([(2.03, y, WALL, 0.75)])
    assert seen.shift(5) is None  # not enough sightings yet
    dx, dy = seen.shift(3)
    assert dx == pytest.approx(0.0, abs=1e-12) and dy == pytest.approx(0.105)


def test_a_doorway_that_is_not_this_door_is_not_counted() -> None:
    seen = sightings()
    assert not seen.add([])
    assert not seen.add([(2.0, 0.9, WALL, 0.9)])  # the next door along the wall
    assert not seen.add([(2.0, 0.1, 0.0, 0.9)])  # a gap in a wall across this one
    assert not seen.add([(2.0, 0.1, WALL, 0.5)])  # narrower than the chair: not passable
    assert not seen.add([(2.5, 0.0, WALL, 0.9)])  # beyond the reach across the wall
    assert seen.add([(2.0, 0.9, WALL, 0.9), (2.0, -0.12, WALL + math.pi, 0.8)])
    assert seen.offsets == [pytest.approx(-0.12)]  # either way round, the nearest one


def test_the_fix_moves_points_by_its_shift_and_resets() -> None:
    fix = DoorFix()
    assert fix.at(1.0, 2.0) == (1.0, 2.0)
    fix.shift = (0.0, 0.1)
    assert fix.at(1.0, 2.0) == (1.0, pytest.approx(2.1))
    fix.reset()
    assert fix.shift == (0.0, 0.0)
