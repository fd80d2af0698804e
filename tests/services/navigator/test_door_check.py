"""The LiDAR door check on real simulated scans: open, closed, and unknown when unsure."""

from __future__ import annotations

import numpy as np

from services.navigator.door_check import CLOSED, OPEN, UNKNOWN, door_state_from_scan, lane_blocked
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


def test_lane_blocked_by_a_closed_or_half_open_leaf_not_by_the_jambs() -> None:
    pose = (5.2, 2.7, 0.0)
    half, front = 0.65 / 2 + 0.05, 0.76
    assert lane_blocked(scan(0.0), pose, DOOR, 0.0, 1.5, half, front)
    assert lane_blocked(scan(0.5), pose, DOOR, 0.0, 1.5, half, front)
    assert not lane_blocked(scan(1.0), pose, DOOR, 0.0, 1.5, half, front)


def test_lane_is_clear_once_the_front_is_past_the_door() -> None:
    pose = (6.0, 2.7, 0.0)  # front at 6.76 m, door plane at 6.2 m
    assert not lane_blocked(scan(0.0, x=6.0), pose, DOOR, 0.0, 1.5, 0.375, 0.76)


def test_lane_behind_when_reversing_towards_the_door() -> None:
    # facing away from the door, backing towards it: the lane runs behind the chair
    pose = (5.6, 2.7, np.pi)
    closed = scan(0.0, x=5.6, theta=np.pi)
    assert lane_blocked(closed, pose, DOOR, 0.0, 1.5, 0.375, 0.35)
    assert not lane_blocked(scan(1.0, x=5.6, theta=np.pi), pose, DOOR, 0.0, 1.5, 0.375, 0.35)
