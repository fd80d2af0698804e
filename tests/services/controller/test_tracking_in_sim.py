"""The controller's tracker in the real (headless pybullet) simulator, at the real loop rate."""

from __future__ import annotations

import numpy as np

from services.controller.node import scan_to_world
from services.controller.tracking import Tracker
from shared.config import load
from shared.messages import PointCloud, Pose2D, PoseEstimate
from shared.site import load_site
from sim.simulation import Simulation
from tests.conftest import ROOT

SITE = load_site(ROOT / "sites" / "two_rooms")


def drive(
    path: np.ndarray,
    v_ref: float,
    start: tuple[float, float, float],
    ticks: int,
    obstacle_free: bool = False,
) -> tuple[Simulation, list[float]]:
    """Close the loop: true pose, VLP-16 scans as obstacles, the tracker at 25 Hz."""
    x, y, th = start
    cfg = load(
        None, ["sim.start.place=", f"sim.start.x={x}", f"sim.start.y={y}", f"sim.start.theta={th}"]
    )
    sim = Simulation(cfg, SITE)
    tracker = Tracker(cfg.controller, cfg.robot, SITE)
    v = np.full(len(path), v_ref)
    v[-1] = 0.0
    tracker.set_path("p", path, v)
    scan, speeds = None, []
    for i in range(ticks):
        r = sim.step()
        scan = r.scan if r.scan is not None else scan
        if i % 2:
            continue
        s = sim.state
        pose = PoseEstimate(r.stamp, Pose2D(s.x, s.y, s.theta, "1"), np.eye(3))
        obstacles = (
            scan_to_world(PointCloud(0.0, "l", scan), pose, 0.5, 4.0)
            if (scan is not None and not obstacle_free)
            else None
        )
        cmd = tracker.step(s.x, s.y, s.theta, "1", s.v, s.w, obstacles, True, 0.04)
        sim.command(cmd.v, cmd.w)
        speeds.append(s.v)
    return sim, speeds


def test_mpc_takes_the_chair_through_a_1m_door_without_touching_it() -> None:
    path = np.linspace((5.2, 2.7), (7.4, 2.7), 10)
    sim, _speeds = drive(path, 0.2, (5.2, 2.7, 0.0), 500)
    assert sim.state.x > 7.2  # through the 1.0 m doorway at x = 6.2
    assert sim.collisions == 0 and sim.min_clearance > 0.1
