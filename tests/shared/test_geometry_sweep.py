"""The compiled sweep test answers as the vectorised statement of it does."""

from __future__ import annotations

import math

import numpy as np

from shared.geometry import (
    SWEEP_STEP_M,
    arc_poses,
    footprint_gap,
    moves_close_in,
    turn_closes_in,
    turn_steps,
)

FRONT, REAR, WIDTH = 0.75, 0.35, 0.62


def reference(xy: np.ndarray, margin: float, poses: list[tuple[float, float, float]]) -> bool:
    """moves_close_in as numpy: any point nearer the moved rectangle than min(its gap now,
    margin) - 1 mm."""
    floor = np.minimum(footprint_gap(xy, FRONT, REAR, WIDTH), margin) - 1e-3
    for px, py, phi in poses:
        c, s = math.cos(phi), math.sin(phi)
        dx, dy = xy[:, 0] - px, xy[:, 1] - py
        moved = np.column_stack((c * dx + s * dy, -s * dx + c * dy))
        if (footprint_gap(moved, FRONT, REAR, WIDTH) < floor).any():
            return True
    return False


def test_matches_the_numpy_statement_on_random_scenes() -> None:
    rng = np.random.default_rng(3)
    hits = 0
    for _ in range(400):
        xy = rng.uniform(-1.5, 1.5, (int(rng.integers(1, 40)), 2))
        poses = arc_poses(float(rng.uniform(-0.6, 0.6)), float(rng.uniform(-3, 3)))
        margin = float(rng.uniform(0.0, 0.1))
        expected = reference(xy, margin, poses)
        assert moves_close_in(xy, FRONT, REAR, WIDTH, margin, poses) == expected
        hits += expected
    assert 50 < hits < 350  # both answers were exercised


def test_no_points_or_no_poses_never_hit() -> None:
    assert not moves_close_in(np.zeros((0, 2)), FRONT, REAR, WIDTH, 0.05, [(0.1, 0.0, 0.0)])
    assert not moves_close_in(np.array([[0.8, 0.0]]), FRONT, REAR, WIDTH, 0.05, [])


def test_an_arc_turns_no_further_than_its_cap_and_goes_straight_on() -> None:
    """A turn that ends (the tracker says how far it has left) is an arc, then a line."""
    free = arc_poses(0.4, 2.0)
    assert free == arc_poses(0.4, 2.0, max_turn_rad=math.inf)
    assert math.isclose(free[-1][2], 0.8)
    capped = arc_poses(0.4, 2.0, max_turn_rad=0.3)
    assert [p[2] for p in capped] == [0.2, 0.3, 0.3, 0.3]
    assert capped[1:] and all(
        math.isclose(math.hypot(b[0] - a[0], b[1] - a[1]), 0.1)
        for a, b in zip(capped[1:], capped[2:], strict=False)
    )  # straight on at the same pace once the turn is done
    back = arc_poses(-0.4, 2.0, max_turn_rad=0.3)
    assert [round(p[2], 9) for p in back] == [-0.2, -0.3, -0.3, -0.3]


def test_a_turn_is_checked_finely_enough_that_a_corner_cannot_slip_past_a_point() -> None:
    """A turn on the spot checked at four poses over 15 deg: the far corner (0.83 m from
    the rear axle) moves 5 cm between two of them, and a point 5 mm off its path between
    them lay 1-2 cm from the rectangle at both: "clear" at a 1 cm margin. The poses are
    now close enough that the corner moves at most SWEEP_STEP_M between them."""
    reach = math.hypot(FRONT, WIDTH / 2)
    corner = math.atan2(WIDTH / 2, FRONT)
    for turn_deg, between in ((15.0, 5.625), (15.0, 9.375), (-15.0, -5.625), (40.0, 31.0)):
        phi = corner + math.radians(between)
        point = np.array([[(reach + 0.005) * math.cos(phi), (reach + 0.005) * math.sin(phi)]])
        assert turn_closes_in(point, FRONT, REAR, WIDTH, 0.01, math.radians(turn_deg)), turn_deg
    steps = turn_steps(math.radians(15), FRONT, REAR, WIDTH)
    assert steps * SWEEP_STEP_M >= reach * math.radians(15)


def test_an_arc_is_checked_finely_enough_that_a_corner_cannot_slip_past_a_point() -> None:
    """The same along an arc: driving 0.3 m at a curvature of 2/m turns the chair 34 deg,
    and four poses left the corner 12 cm between two of them."""
    length, curvature = 0.3, 2.0
    poses = arc_poses(length, curvature, steps=turn_steps(length * curvature, FRONT, REAR, WIDTH))
    coarse = arc_poses(length, curvature)
    # a point 5 mm outside the path of the corner farthest from the turn's centre (the
    # front one on the outside of the turn), where it is between two of the four poses
    cx, cy = 0.0, 1.0 / curvature
    fx, fy = FRONT - cx, -WIDTH / 2 - cy
    radius = math.hypot(fx, fy)
    phi = math.atan2(fy, fx) + curvature * 0.375 * length
    out = np.array([[cx + (radius + 0.005) * math.cos(phi), cy + (radius + 0.005) * math.sin(phi)]])
    assert not moves_close_in(out, FRONT, REAR, WIDTH, 0.01, coarse)  # what four poses saw
    assert moves_close_in(out, FRONT, REAR, WIDTH, 0.01, poses)
