"""Manoeuvres in tight rooms: the search finds turns and straight drives where turn-drive-
turn does not fit, and every pose along them keeps the margin."""

from __future__ import annotations

import math

import numpy as np

from services.controller.manoeuvre import (
    ManoeuvreBody,
    Room,
    plan_manoeuvre,
    simple_manoeuvre,
)
from shared.config import RobotConfig
from shared.geometry import footprint_gap, wrap_angle

RES = 0.05
FP = RobotConfig().footprint
BODY = ManoeuvreBody(FP.front, FP.rear, FP.width, 0.05)


def series_room() -> tuple[np.ndarray, tuple[float, float]]:
    """Campaign b4.m07's room between two doors in series, 2.08 x 2.0 m inside (x 0-2.08,
    y 0-2.0) with 0.2 m walls, a 0.9 m door in the left wall (y 0.88-1.78) and one in the
    right wall (y 0.08-0.98), and 1 m of free space beyond each door."""
    x0, y0 = -1.4, -0.4
    w, h = round(4.9 / RES), round(2.8 / RES)
    cx = x0 + (np.arange(w) + 0.5) * RES
    cy = y0 + (np.arange(h) + 0.5) * RES
    gx, gy = np.meshgrid(cx, cy)
    free = (gx > 0) & (gx < 2.08) & (gy > 0) & (gy < 2.0)
    free |= (gx > -1.2) & (gx <= 0) & (gy > 0.88) & (gy < 1.78)  # the left door and beyond
    free |= (gx >= 2.08) & (gx < 3.3) & (gy > 0.08) & (gy < 0.98)  # the right door and beyond
    return ~free, (x0, y0)


def clearance(occ: np.ndarray, origin, pose) -> float:
    """The footprint's distance to the nearest occupied cell (its nearest point)."""
    r, c = np.nonzero(occ)
    x = origin[0] + (c + 0.5) * RES
    y = origin[1] + (r + 0.5) * RES
    th = pose[2]
    dx, dy = x - pose[0], y - pose[1]
    body = np.column_stack(
        (dx * math.cos(th) + dy * math.sin(th), -dx * math.sin(th) + dy * math.cos(th))
    )
    return float(footprint_gap(body, FP.front, FP.rear, FP.width).min()) - RES * math.sqrt(0.5)


def along(poses):
    """Every pose the chair passes through: turns in 1-degree steps, drives in 1 cm steps."""
    for a, b in zip(poses[:-1], poses[1:], strict=True):
        if math.hypot(b[0] - a[0], b[1] - a[1]) < 1e-9:  # a turn on the spot
            d = wrap_angle(b[2] - a[2])
            for i in range(int(abs(math.degrees(d))) + 1):
                yield (a[0], a[1], a[2] + math.copysign(math.radians(i), d))
        else:  # a straight drive along a's heading, forwards or back
            heading = math.atan2(b[1] - a[1], b[0] - a[0])
            assert abs(math.sin(wrap_angle(heading - a[2]))) < 0.02, (a, b)
            assert abs(wrap_angle(b[2] - a[2])) < 1e-9, (a, b)
            n = int(math.hypot(b[0] - a[0], b[1] - a[1]) / 0.01) + 1
            for i in range(n + 1):
                yield (a[0] + (b[0] - a[0]) * i / n, a[1] + (b[1] - a[1]) * i / n, a[2])


def test_between_two_doors_in_series_it_turns_where_the_room_allows() -> None:
    occ, origin = series_room()
    room = Room(occ, RES, origin, BODY)
    start, goal = (1.01, 1.33, 0.0), (1.19, 0.53, 0.0)  # door 1's exit, door 2's approach
    assert simple_manoeuvre(room, start, goal) is None  # no room to turn at either pose
    poses = plan_manoeuvre(room, start, goal)
    assert poses is not None
    assert math.hypot(poses[-1][0] - goal[0], poses[-1][1] - goal[1]) < RES
    assert abs(wrap_angle(poses[-1][2] - goal[2])) < 1e-6
    worst = min(clearance(occ, origin, p) for p in along([start, *poses]))
    assert worst >= 0.05 - 0.01  # the margin, less what 5-degree heading steps can miss


def test_in_open_space_it_is_turn_drive_turn() -> None:
    occ = np.zeros((100, 100), dtype=bool)
    room = Room(occ, RES, (-2.5, -2.5), BODY)
    poses = plan_manoeuvre(room, (0.0, 0.0, 0.0), (0.8, 0.6, math.pi / 2))
    assert poses is not None and len(poses) == 3
    assert poses[0][:2] == (0.0, 0.0) and poses[1][:2] == (0.8, 0.6)


def test_a_goal_in_a_wall_or_out_of_reach_gives_none() -> None:
    occ, origin = series_room()
    room = Room(occ, RES, origin, BODY)
    assert plan_manoeuvre(room, (1.01, 1.33, 0.0), (1.0, -0.2, 0.0)) is None  # in the wall
    boxed = np.ones((60, 60), dtype=bool)
    boxed[10:50, 10:50] = False
    boxed[:, 29:31] = True  # two closed halves
    small = Room(boxed, RES, (0.0, 0.0), ManoeuvreBody(0.3, 0.1, 0.3, 0.02))
    assert plan_manoeuvre(small, (0.9, 1.5, 0.0), (2.1, 1.5, 0.0)) is None


def test_a_goal_too_near_a_wall_ends_the_search_within_a_docking_tolerance() -> None:
    """Campaign b2.m00: the second door's approach pose stood 5 cm from the tip of an open
    leaf, inside the margin, and no manoeuvre was planned at all."""
    occ, origin = series_room()
    room = Room(occ, RES, origin, BODY)
    goal = (1.19, 0.39, 0.0)  # the footprint 0.065 m above the room's bottom wall
    assert not room.fits(*goal[:2], 0)
    poses = plan_manoeuvre(room, (1.01, 1.33, 0.0), goal)
    assert poses is not None
    end = poses[-1]
    assert 0 < math.hypot(end[0] - goal[0], end[1] - goal[1]) <= 0.15
    assert abs(wrap_angle(end[2] - goal[2])) <= math.radians(5) + 1e-9
    assert room.fits(end[0], end[1], round(end[2] / (2 * math.pi) * 72) % 72)
