"""Door leaves in the simulated world: a closed door is seen and hit, an open one is not."""

from __future__ import annotations

import numpy as np
import pytest

from shared.config import load
from shared.site import load_site
from sim.simulation import Simulation
from tests.conftest import ROOT

SITE = load_site(ROOT / "sites" / "two_rooms")


def sim_at(x: float, y: float, motion: str = "hinged") -> Simulation:
    return Simulation(
        load(
            None,
            [
                "sim.start.place=",
                f"sim.start.x={x}",
                f"sim.start.y={y}",
                f"building.doors={{door_ab: {{motion: {motion}}}}}",
            ],
        ),
        SITE,
    )


def range_ahead(sim: Simulation) -> float:
    for _ in range(sim.scan_every):
        r = sim.step()
    level = r.scan[np.abs(r.scan[:, 2]) < 0.3]  # the rings near the horizontal
    ahead = level[np.abs(np.arctan2(level[:, 1], level[:, 0])) < 0.01]
    return float(ahead[:, 0].mean())


@pytest.mark.parametrize("motion", ["hinged", "sliding"])
def test_closed_door_is_in_the_scan_and_open_one_is_not(motion: str) -> None:
    sim = sim_at(3.0, 2.7, motion)
    sim.set_door_openings(["door_ab"], [0.0])
    assert range_ahead(sim) == pytest.approx(6.2 - 0.025 - 3.0, abs=0.04)
    sim.set_door_openings(["door_ab"], [1.0])
    assert range_ahead(sim) == pytest.approx(9.2, abs=0.04)


def test_driving_into_a_closed_door_is_a_collision() -> None:
    sim = sim_at(4.8, 2.7)
    sim.set_door_openings(["door_ab"], [0.0])
    hits = 0
    for _ in range(200):
        sim.command(0.4, 0.0)
        hits += sim.step().new_collision
    assert hits == 1


def test_unknown_door_names_are_ignored() -> None:
    sim = sim_at(3.0, 2.7)
    sim.set_door_openings(["elsewhere"], [1.0])
    assert set(sim.doors) == {"door_ab"}
