"""The LiDAR door check on real simulated scans: open, closed, and unknown when unsure."""

from __future__ import annotations

import numpy as np

from services.navigator.door_check import CLOSED, OPEN, UNKNOWN, door_state_from_scan
from shared.config import load
from shared.site import load_site
from sim.simulation import Simulation
from tests.conftest import ROOT

SITE = load_site(ROOT / "sites" / "two_rooms")
DOOR = (6.2, 2.7)


def scan(opening: float, x: float = 5.2, theta: float = 0.0) -> np.ndarray:
    cfg = load(
        None,
        ["sim.start.place=", f"sim.start.x={x}", "sim.start.y=2.7", f"sim.start.theta={theta}"],
    )
    sim = Simulation(cfg, SITE)
    sim.set_door_openings(["door_ab"], [opening])
    for _ in range(sim.scan_every):
        pts = sim.step().scan
    return pts


def test_open_and_closed_door() -> None:
    assert door_state_from_scan(scan(1.0), (5.2, 2.7, 0.0), DOOR, 1.5) == OPEN
    assert door_state_from_scan(scan(0.0), (5.2, 2.7, 0.0), DOOR, 1.5) == CLOSED
    assert door_state_from_scan(scan(0.5), (5.2, 2.7, 0.0), DOOR, 1.5) == CLOSED  # half open


def test_unknown_when_there_is_too_little_to_judge() -> None:
    assert door_state_from_scan(np.zeros((0, 3), np.float32), (5.2, 2.7, 0.0), DOOR, 1.5) == (
        UNKNOWN
    )
    few = np.array([[3.0, 0.0, 0.0]] * 3, np.float32)
    assert door_state_from_scan(few, (5.2, 2.7, 0.0), DOOR, 1.5) == UNKNOWN
