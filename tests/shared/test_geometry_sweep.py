"""The compiled sweep test answers as the vectorised statement of it does."""

from __future__ import annotations

import math

import numpy as np

from shared.geometry import arc_poses, footprint_gap, moves_close_in

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
