"""The scan segmentation under the doorway finder, on drawn scans (pure geometry)."""

from __future__ import annotations

import numpy as np
import pytest

from shared.config import ConfigError, DoorScanConfig, FleetConfig, from_dict
from shared.door_scan import DoorTracker, Doorway, find_doorways, planar_scan, segment


def _cast(
    walls: list[tuple[tuple[float, float], tuple[float, float]]], n: int = 1440
) -> np.ndarray:
    """A planar scan from the origin against segments: the nearest hit per beam."""
    out = []
    for a in np.linspace(-np.pi, np.pi, n, endpoint=False):
        d = np.array([np.cos(a), np.sin(a)])
        best = np.inf
        for p, q in walls:
            p, q = np.array(p), np.array(q)
            m = np.array([d, p - q]).T
            if abs(np.linalg.det(m)) < 1e-12:
                continue
            t, u = np.linalg.solve(m, p)
            if t > 0 and 0 <= u <= 1:
                best = min(best, t)
        if np.isfinite(best):
            out.append(d * best)
    return np.array(out)


def test_nearest_return_per_bin_in_the_height_band() -> None:
    pts = np.array([[2.0, 0.0, 0.0], [1.0, 0.0, 0.1], [3.0, 0.0, 2.0], [np.nan, 0, 0]])
    assert planar_scan(pts).tolist() == [[1.0, 0.0]]


def test_a_corner_is_two_stretches_and_a_wall_with_a_gap_is_a_doorway() -> None:
    corner = _cast([((2, -2), (2, 2)), ((2, 2), (-2, 2))])
    assert len(segment(planar_scan(corner))) == 2
    # a wall at x = 2 with a 0.9 m gap, a room beyond it (x = 5)
    walls = [((2, -3), (2, 0.0)), ((2, 0.9), (2, 3)), ((5, -3), (5, 3))]
    (door,) = find_doorways(_cast(walls))
    assert abs(door.width - 0.9) < 0.02 and np.allclose(door.centre, [2.0, 0.45], atol=0.02)
    assert door.open and np.allclose(door.normal, [1.0, 0.0], atol=0.01)
    # the same gap with a leaf 5 cm behind the face: closed; a 2 m gap: no door
    closed = find_doorways(_cast([*walls, ((2.05, 0.0), (2.05, 0.9))]))
    assert len(closed) == 1 and not closed[0].open
    assert find_doorways(_cast([((2, -3), (2, 0.0)), ((2, 2.0), (2, 3)), ((5, -3), (5, 3))])) == []


def test_the_finder_reads_its_config() -> None:
    """controller.door_scan: a 0.9 m gap is no doorway to a finder that wants 1.0 m and
    more, and a 2 m gap is one to a finder that allows 2.2 m; bad ranges name the key."""
    walls = [((2, -3), (2, 0.0)), ((2, 0.9), (2, 3)), ((5, -3), (5, 3))]
    assert find_doorways(_cast(walls), DoorScanConfig(min_width_m=1.0)) == []
    wide = [((2, -3), (2, 0.0)), ((2, 2.0), (2, 3)), ((5, -3), (5, 3))]
    (door,) = find_doorways(_cast(wide), DoorScanConfig(max_width_m=2.2))
    assert abs(door.width - 2.0) < 0.02
    with pytest.raises(ConfigError, match="min_width_m"):
        from_dict(FleetConfig, {"controller": {"door_scan": {"min_width_m": 2.0}}})
    with pytest.raises(ConfigError, match="controller.door_scan.split_m"):
        from_dict(FleetConfig, {"controller": {"door_scan": {"split_m": -1}}})


def _sighting(centre_y: float, range_m: float) -> tuple[Doorway, tuple[float, float, float]]:
    """A 0.9 m doorway on the wall x = 5 centred at ``centre_y``, seen from ``range_m``
    before it (the sensor on the door's line, facing it)."""
    half = np.array([0.0, 0.45])
    centre = np.array([range_m, 0.0])
    door = Doorway(
        centre - half, centre + half, centre, 0.9, np.array([0.0, 1.0]), np.array([1.0, 0.0])
    )
    return door, (5.0 - range_m, centre_y, 0.0)


def test_near_sightings_count_more_than_far_ones() -> None:
    """Twenty sightings from 4 m, 3 cm off (far: beams spread, another frame), then five
    from 1 m on the door: the fused door is 6 mm off (weights 20 / 16 against 5; the plain
    mean is 2.4 cm off); the weight stops growing at near_m."""
    tracker = DoorTracker()
    for _ in range(20):
        door, pose = _sighting(0.03, 4.0)
        tracker.add([door], pose)
    for _ in range(5):
        door, pose = _sighting(0.0, 1.0)
        tracker.add([door], pose)
    (est,) = tracker.estimates()
    assert est.sightings == 25 and est.centre[1] == pytest.approx(0.006)
    assert est.width == pytest.approx(0.9) and est.sigma_m > 0
    equal = DoorTracker(near_m=5.0)  # every sighting nearer than 5 m weighs the same
    for y, r in [(0.03, 4.0)] * 20 + [(0.0, 1.0)] * 5:
        equal.add([_sighting(y, r)[0]], _sighting(y, r)[1])
    assert equal.estimates()[0].centre[1] == pytest.approx(0.024)
