"""Scripted pedestrians walk their loops deterministically and are seen and hit."""

from __future__ import annotations

import numpy as np
import pytest

from shared.config import load
from shared.site import load_site
from sim.simulation import Simulation
from tests.conftest import ROOT

SITE = load_site(ROOT / "sites" / "two_rooms")


def sim_with(pedestrian: str, x: float = 1.5, y: float = 2.7) -> Simulation:
    return Simulation(
        load(
            None,
            [
                "sim.start.place=",
                f"sim.start.x={x}",
                f"sim.start.y={y}",
                f"sim.pedestrians=[{pedestrian}]",
            ],
        ),
        SITE,
    )


def test_pedestrian_walks_its_loop_and_is_scanned() -> None:
    sim = sim_with("{waypoints: [[4, 1.0], [4, 4.4]], speed: 0.5}")
    person = sim.pedestrians[0]
    for _ in range(100):  # 2 s at 0.5 m/s: 1 m along the first leg
        r = sim.step()
    assert person.position == pytest.approx((4.0, 2.0), abs=1e-6)
    pts = r.scan
    pts = pts[np.abs(pts[:, 2]) < 0.3]
    bearing = np.arctan2(pts[:, 1], pts[:, 0])
    towards = pts[np.abs(bearing - np.arctan2(2.0 - 2.7, 4.0 - 1.5)) < 0.02]
    assert np.linalg.norm(towards[:, :2], axis=1).min() < np.hypot(2.5, 0.7)  # the person


def test_walking_into_the_chair_is_a_collision() -> None:
    sim = sim_with("{waypoints: [[1.5, 0.5], [1.5, 4.9]], speed: 0.8, radius: 0.3}")
    hits = sum(sim.step().new_collision for _ in range(400))
    assert hits >= 1


def test_a_pedestrian_of_one_waypoint_stands_there_and_is_scanned() -> None:
    """A generated world's people stand: one waypoint, no loop to walk."""
    sim = sim_with("{waypoints: [[4, 2.7]], radius: 0.25}")
    person = sim.pedestrians[0]
    for _ in range(100):
        r = sim.step()
    assert person.position == (4.0, 2.7)
    pts = r.scan[np.abs(r.scan[:, 2]) < 0.3]
    ahead = pts[np.abs(np.arctan2(pts[:, 1], pts[:, 0])) < 0.02]
    assert np.linalg.norm(ahead[:, :2], axis=1).min() == pytest.approx(2.5 - 0.25, abs=0.05)


def test_bad_pedestrian_is_refused() -> None:
    for bad in ("[]", "[[1, 1, 1]]"):
        with pytest.raises(ValueError, match="waypoints"):
            sim_with(f"{{waypoints: {bad}}}")
