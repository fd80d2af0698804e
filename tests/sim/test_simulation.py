"""The headless pybullet simulator: motion, watchdog, collisions, LiDAR."""

from __future__ import annotations

import math

import numpy as np
import pytest

from shared.config import load
from shared.site import load_site
from sim.simulation import ClearanceSeen, Simulation
from sim.world import merge_boxes
from tests.conftest import ROOT

SITE = load_site(ROOT / "sites" / "two_rooms")


def make(x: float = 2.0, y: float = 2.7, theta: float = 0.0, **over) -> Simulation:
    extra = [f"{k}={v}" for k, v in over.items()]
    return Simulation(
        load(
            None,
            [
                "sim.start.place=",
                f"sim.start.x={x}",
                f"sim.start.y={y}",
                f"sim.start.theta={theta}",
                *extra,
            ],
        ),
        SITE,
    )


def test_merge_boxes_covers_exactly() -> None:
    rng = np.random.default_rng(3)
    occ = rng.random((40, 60)) < 0.3
    occ[10:20, :] = True
    cover = np.zeros_like(occ)
    boxes = merge_boxes(occ)
    for r0, c0, r1, c1 in boxes:
        assert not cover[r0:r1, c0:c1].any()  # no overlaps
        cover[r0:r1, c0:c1] = True
    assert np.array_equal(cover, occ)
    assert len(boxes) < occ.sum() / 2


def range_ahead(sim: Simulation) -> float:
    for _ in range(sim.scan_every):
        r = sim.step()
    pts = r.scan
    assert pts.dtype == np.float32 and pts.shape[1] == 3
    level = pts[np.abs(pts[:, 2]) < 0.3]  # the rings near the horizontal
    ahead = level[np.abs(np.arctan2(level[:, 1], level[:, 0])) < 0.01]
    return float(ahead[:, 0].mean())


def test_lidar_sees_a_wall_at_the_known_distance() -> None:
    # the dividing wall's face is at x = 6.1; the sensor is at x = 3.0 (noise sigma 1 cm)
    assert range_ahead(make(x=3.0, y=1.0, **{"sim.lidar_noise_m": 0.01})) == pytest.approx(
        3.1, abs=0.03
    )
    # through the open doorway it sees the far wall at x = 12.2
    assert range_ahead(make(x=3.0, y=2.7)) == pytest.approx(9.2, abs=0.03)


def test_driving_into_a_wall_is_a_collision() -> None:
    sim = make(x=4.5, y=1.0, theta=0.0)
    collisions = 0
    for _ in range(300):
        sim.command(0.5, 0.0)
        collisions += sim.step().new_collision
    assert collisions == 1 and sim.collisions == 1
    assert sim.min_clearance < 0


def test_watchdog_stops_the_chair_within_half_a_second() -> None:
    sim = make()
    for _ in range(100):
        sim.command(0.5, 0.0)
        sim.step()
    last_cmd = sim.time
    assert sim.state.v == pytest.approx(0.5, abs=0.01)
    while sim.state.v > 0:
        sim.step()
        assert sim.time - last_cmd < 1.0
    assert sim.time - last_cmd <= 0.5
    assert sim.time - last_cmd >= 0.3


def test_start_inside_a_wall_is_refused() -> None:
    with pytest.raises(ValueError, match="inside a wall"):
        make(x=6.2, y=1.0)


def test_same_seed_same_run() -> None:
    def run() -> tuple:
        sim = make(**{"sim.seed": 4})
        for i in range(60):
            sim.command(0.4, 0.3 * math.sin(i / 10))
            r = sim.step()
        return sim.state.x, sim.state.y, r.scan.tobytes() if r.scan is not None else None

    assert run() == run()


def test_clearance_in_an_opening_and_away_says_to_what_and_where() -> None:
    # the chair's footprint centre in door_ab (1.0 m at x = 6.2): measured for the door;
    # a sliding leaf leaves the clear width whole, an open hinged one takes half its thickness
    assert make(x=5.9, y=2.6).door_clearance["door_ab"].free == 1.0
    sim = make(x=5.9, y=2.6, **{"building.doors": "{door_ab: {motion: hinged, start_open: true}}"})
    seen = sim.door_clearance["door_ab"]
    assert seen.free == pytest.approx(1.0 - 0.025) and seen.nearest in ("wall", "door door_ab")
    assert seen.at == pytest.approx((5.9, 2.6, 0.0))
    assert 0.0 < seen.clearance < (1.0 - 0.65) / 2  # 0.1 m off the centre line
    assert sim.min_clearance_away == math.inf  # nothing measured away from the doors yet
    away = make(x=2.0, y=2.7)
    assert away.away.nearest == "wall" and away.away.at == pytest.approx((2.0, 2.7, 0.0))
    before = make(x=6.2 - 0.76 - 0.3, y=2.7)  # its front 0.3 m short of the door plane
    assert "door_ab" not in before.door_clearance and before.min_clearance_away < 2.0
    assert seen.entered is True  # its centre in the doorway: judged as passing it
    nose = make(x=6.2 - 0.76 + 0.1, y=2.7)  # only its front 0.1 m into the doorway
    assert not nose.door_clearance["door_ab"].entered
    assert nose.door_clearance["door_ab"].outline == nose.door_clearance["door_ab"].clearance
    assert away.min_clearance_away == away.away.clearance < 2.0


def test_a_doorway_once_entered_counts_only_the_time_its_centre_stood_in_it() -> None:
    # camp23 b2.m08: turning 0.6 m before a 1.2 m door (only its outline in the doorway's
    # zone) the chair came 0.118 m from a jamb; that was judged as its centring in the door
    seen = ClearanceSeen(1.2)
    seen.see_in_opening(0.118, "wall", (9.8, 11.1, 2.5), centre_in=False)
    assert (seen.clearance, seen.outline, seen.entered) == (0.118, 0.118, False)
    seen.see_in_opening(0.26, "wall", (9.2, 11.3, 3.1), centre_in=True)
    assert (seen.clearance, seen.at, seen.entered) == (0.26, (9.2, 11.3, 3.1), True)
    seen.see_in_opening(0.09, "wall", (8.6, 11.3, 3.1), centre_in=False)  # leaving it
    seen.see_in_opening(0.24, "wall", (9.1, 11.3, 3.1), centre_in=True)
    assert (seen.clearance, seen.outline) == (0.24, 0.09)
