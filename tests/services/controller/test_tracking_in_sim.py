"""The controller's tracker in the real (headless pybullet) simulator, at the real loop rate."""

from __future__ import annotations

import math

import numpy as np
import pytest

from services.controller.node import scan_to_world
from services.controller.safety import guard
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


def smooth_tracker(cfg) -> Tracker:
    """A tracker given the smooth pass the navigator sends for door_ab (1.0 m at x = 6.2):
    the approach line 1.0 m before it, the end 1.2 m past."""
    tracker = Tracker(cfg.controller, cfg.robot, SITE)
    tracker.set_path(
        "smooth",
        np.array([[5.2, 2.7], [7.4, 2.7]]),
        np.array([0.5, 0.0]),
        precise=True,
        door=[6.2, 2.7, 0.0, 1.0, 1.0, 1.2],
    )
    return tracker


def test_a_smooth_pass_tells_the_guard_where_its_door_is() -> None:
    """The jambs of door_ab (1.0 m at x = 6.2, y 2.2-3.2) in the robot frame of a chair at
    (5.2, 2.7) facing +y, and the reach of the narrow margin: the door's width and
    ``precise_near_door_m``. No smooth pass, no door: None."""
    cfg = load()
    tracker = smooth_tracker(cfg)
    jambs, reach = tracker.precise_near(5.2, 2.7, math.pi / 2)
    assert sorted(map(tuple, np.round(jambs, 6).tolist())) == [(-0.5, -1.0), (0.5, -1.0)]
    assert reach == 1.0 + cfg.controller.precise_near_door_m
    tracker.set_path("leg", np.array([[5.2, 2.7], [7.4, 2.7]]), np.array([0.5, 0.0]))
    assert tracker.precise_near(5.2, 2.7, 0.0) is None


def test_a_smooth_pass_path_goes_through_the_door_it_sees_without_stopping() -> None:
    # the path the navigator sends for a smooth pass: door_ab (1.0 m at x = 6.2), the
    # approach line 1.0 m before it, the end 1.2 m past; the chair starts 0.3 m aside
    cfg = load(
        None, ["sim.start.place=", "sim.start.x=3.8", "sim.start.y=2.4", "sim.start.theta=0.2"]
    )
    sim = Simulation(cfg, SITE)
    sim.set_door_openings(["door_ab"], [1.0])
    tracker = smooth_tracker(cfg)
    assert tracker.precise
    state, slowest, fresh_scan = "following", 1.0, None
    for i in range(2000):
        r = sim.step()
        fresh_scan = r.scan if r.scan is not None else fresh_scan
        if i % 2:
            continue
        s = sim.state
        cmd = tracker.step(s.x, s.y, s.theta, "1", s.v, s.w, None, True, 0.04, fresh_scan)
        fresh_scan, state = None, cmd.state
        if state != "following":
            break
        sim.command(cmd.v, cmd.w)
        if s.x > 4.5:
            slowest = min(slowest, s.v)
    assert state == "arrived" and sim.state.x >= 6.2 + 1.2 - 0.05
    assert sim.collisions == 0 and slowest > 0.15  # it never stopped on the way
    seen = sim.door_clearance["door_ab"]
    assert seen.clearance >= (1.0 - 0.65) / 2 - 0.03  # the opening's limit


def test_a_smooth_pass_facing_away_from_the_door_falls_back() -> None:
    cfg = load(None, [])
    tracker = smooth_tracker(cfg)
    cmd = tracker.step(3.0, 2.7, 3.1, "1", 0.0, 0.0, None, True, 0.04, None)
    assert cmd.state == "fallback" and cmd.v == 0.0


@pytest.mark.parametrize("pinch", [0.045, 0.048, 0.052])
def test_a_turn_on_the_spot_beside_a_wall_keeps_5_cm_from_it(pinch: float) -> None:
    # camp23 b2.m00 and b8.m03: docking turned on the spot beside a wall and a rear corner
    # passed 0.0465 m from it (the limit away from doors is 0.05). Turning left by 90 deg
    # at (3.0, y0) facing +x, the rear right corner (0.478 m from the pose point) sweeps
    # straight down at y0 - 0.478: ``pinch`` from room A's south wall (face at y = 0.2)
    y0 = 0.2 + 0.478 + pinch
    cfg = load(
        None, ["sim.start.place=", "sim.start.x=3.0", f"sim.start.y={y0}", "sim.start.theta=0"]
    )
    sim = Simulation(cfg, SITE)
    tracker = Tracker(cfg.controller, cfg.robot, SITE)
    tracker.set_path("dock", np.array([[3.0, y0]]), np.array([0.15]), dock_heading=math.pi / 2)
    scan, state = None, "following"
    for i in range(40 * 50):
        r = sim.step()
        scan = r.scan if r.scan is not None else scan
        if i % 2:
            continue
        s = sim.state
        pose = PoseEstimate(r.stamp, Pose2D(s.x, s.y, s.theta, "1"), np.eye(3))
        obstacles = (
            scan_to_world(PointCloud(0.0, "l", scan), pose, 0.5, 4.0) if scan is not None else None
        )
        cmd = tracker.step(s.x, s.y, s.theta, "1", s.v, s.w, obstacles, True, 0.04)
        state = cmd.state
        if state == "arrived":
            break
        v, w, _ = guard(
            cmd.v,
            cmd.w,
            state,
            r.stamp,
            True,
            r.stamp,
            scan,
            cfg.robot,
            cfg.controller,
            0.5,
            tracker.precise,
            tracker.turn_margin(),
        )  # as the node does
        sim.command(v, w)
    assert state == "arrived"
    assert sim.min_clearance >= 0.05, sim.min_clearance
