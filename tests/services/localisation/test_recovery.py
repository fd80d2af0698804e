"""The map-mode localiser on the real simulator where its pose is in doubt (issue 15).

No fleet: the simulator drives the chair and renders its scans, and the localiser gets
the simulated wheel odometry and the scans as the localisation node hands them on (the
band around the sensor's height). Truth is the simulator's chair.

- A hall wider than twice the LiDAR's range: in its middle no wall is in reach, the scans
  are empty, and that is no disagreement with the map (issue 15: "localisation lost in a
  large open hall 6 s after the start ... and never regained").
- A kidnapping: the chair standing still is moved 2 m and 30 deg; the localiser finds it
  lost, relocalises on the map and tracks on from the true pose.
- Turning on the spot among things the map lacks: the scans are cluttered (too few points
  on the map's walls to correct the pose), the heading goes on on odometry and drifts with
  every turn, and a match a little over the clutter rule's 2 deg is no reason to call the
  pose lost (world-differs campaign b7405w.m02: lost at 2.05 deg in a 2.6 m room after
  turning about, the true pose 1 cm off).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from services.localisation.localiser import MapLocaliser, MapModeSettings
from services.localisation.matcher import DistanceField
from shared.config import LocalisationConfig, load
from shared.geometry import angle_between
from sim.simulation import Simulation
from tests.services.planner.test_door_poses import make_site

T = 0.2  # wall thickness


def localiser(site, pose: tuple[float, float, float]) -> MapLocaliser:
    settings = MapModeSettings.from_config(LocalisationConfig())
    return MapLocaliser(DistanceField.for_floor(site, "1"), *pose, "1", settings)


def simulation(
    site,
    pose: tuple[float, float, float],
    seed: int = 3,
    lidar: str = "vlp16",
    extra: tuple[str, ...] = (),
) -> Simulation:
    over = [
        *extra,
        f"sim.lidar={lidar}",
        "sim.start.place=",
        f"sim.start.x={pose[0]}",
        f"sim.start.y={pose[1]}",
        f"sim.start.theta={pose[2]}",
        "sim.start.floor='1'",
        f"sim.seed={seed}",
    ]
    return Simulation(load(None, over), site)


def step(sim: Simulation, loc: MapLocaliser) -> None:
    """One simulator tick into the localiser, as the node does it."""
    result = sim.step()
    o = sim.odometry
    loc.update_odometry(o.x, o.y, o.theta)
    if result.scan is not None:
        pts = result.scan
        loc.update_scan(pts[np.abs(pts[:, 2]) < LocalisationConfig().scan_band_m])


def error(sim: Simulation, loc: MapLocaliser) -> tuple[float, float]:
    s = sim.state
    x, y, th = loc.pose
    return math.hypot(x - s.x, y - s.y), math.degrees(angle_between(th, s.theta))


def test_crossing_a_hall_with_no_wall_in_reach_is_not_getting_lost(tmp_path: Path) -> None:
    # corner to corner across a 30 x 30 m hall with the planar LiDAR (12 m): for 8 m in the
    # middle no wall is in reach and the scans are empty; in the far corner two walls fix
    # the whole pose again
    size = 30.0
    walls = [(0, 0, size, T), (0, size - T, size, size), (0, 0, T, size), (size - T, 0, size, size)]
    site = make_site(tmp_path, walls, [], [], (size, size))
    start = (1.5, 1.5, math.pi / 4)
    sim, loc = simulation(site, start, lidar="planar"), localiser(site, start)
    blind = lost = 0
    worst = 0.0
    while sim.state.x < size - 2.5 and sim.time < 120.0:
        if sim.tick % 10 == 0:
            sim.command(0.5, 0.0)
        step(sim, loc)
        s = sim.state
        blind += min(s.x - T, size - T - s.x, s.y - T, size - T - s.y) > sim.lidar.range_m
        lost += loc.lost
        worst = max(worst, error(sim, loc)[0])
    for _ in range(100):  # 2 s standing in the corner
        step(sim, loc)
    sim.close()
    assert sim.state.x >= size - 2.5
    assert blind > 500  # more than 10 s out of the LiDAR's reach
    assert lost == 0, f"flagged lost for {lost} ticks (worst error {worst:.2f} m)"
    end_m, end_deg = error(sim, loc)
    assert end_m < 0.05 and end_deg < 1.0, (end_m, end_deg, worst)


def test_a_kidnapped_chair_is_found_lost_and_relocalised(tmp_path: Path) -> None:
    # a room with things in it that make every place look different
    walls = [(0, 0, 12, T), (0, 8 - T, 12, 8), (0, 0, T, 8), (12 - T, 0, 12, 8)]
    walls += [(4.0, 5.5, 5.2, 8.0), (8.5, 2.0, 9.1, 2.6), (0, 3.0, 1.5, 3.6), (10.4, 5.0, 12, 5.3)]
    site = make_site(tmp_path, walls, [], [], (12, 8))
    start = (3.0, 2.0, 0.3)
    sim, loc = simulation(site, start), localiser(site, start)
    for _ in range(50):
        step(sim, loc)
    assert error(sim, loc)[0] < 0.02 and not loc.lost
    taken = (start[0] + 2.0 * math.cos(1.0), start[1] + 2.0 * math.sin(1.0), start[2] + 0.52)
    sim.kidnap(*taken)
    was_lost = False
    for _ in range(300):  # 6 s standing
        step(sim, loc)
        was_lost |= loc.lost
    sim.close()
    assert was_lost, "the kidnapping was not noticed"
    assert not loc.lost
    end_m, end_deg = error(sim, loc)
    assert end_m < 0.05 and end_deg < 1.0, (end_m, end_deg)
    assert loc.relocalisations and loc.relocalisations[-1].ok


def test_turning_about_among_unmapped_things_is_not_getting_lost(tmp_path: Path) -> None:
    # a 6 x 6 m room; in the world four unmapped panels 1 m round the chair hide about half
    # of the walls at every heading; the odometry's turn rate reads 0.02 rad/s high (4 % of
    # the turn), so two turns on the spot leave its heading about 29 deg off
    room = [(0, 0, 6, T), (0, 6 - T, 6, 6), (0, 0, T, 6), (6 - T, 0, 6, 6)]
    panels = [(2.6, 4.0, 3.4, 4.1), (2.6, 1.9, 3.4, 2.0)]
    panels += [(1.9, 2.6, 2.0, 3.4), (4.0, 2.6, 4.1, 3.4)]
    (tmp_path / "map").mkdir()
    (tmp_path / "world").mkdir()
    site = make_site(tmp_path / "map", room, [], [], (6, 6))
    world = make_site(tmp_path / "world", room + panels, [], [], (6, 6))
    start = (3.0, 3.0, 0.2)
    sim = simulation(world, start, extra=("sim.odom_turn_bias=0.02",))
    loc = localiser(site, start)
    for _ in range(20):
        step(sim, loc)
    assert loc.cluttered > 0, "the panels do not hide enough of the walls for this test"
    lost, worst = 0, 0.0
    turned = 0.0
    while turned < 4 * math.pi:
        sim.command(0.0, 0.5)
        before = sim.state.theta
        step(sim, loc)
        turned += abs(angle_between(sim.state.theta, before))
        lost += loc.lost
        worst = max(worst, error(sim, loc)[1])
    drifted = math.degrees(angle_between(sim.odometry.theta, sim.state.theta))
    sim.close()
    assert drifted > 20.0, f"the odometry drifted only {drifted:.1f} deg: nothing tested"
    assert lost == 0, f"flagged lost for {lost} ticks (heading {worst:.1f} deg off at worst)"
    assert worst < 1.0, f"heading {worst:.1f} deg off (odometry {drifted:.1f} deg)"


def drive_past_a_moved_wall(tmp_path: Path, overrides: tuple[str, ...]) -> tuple[float, float]:
    """Through a doorway into a corridor whose end wall the world has 15 cm off the map;
    the localiser's (end error, worst error) in metres."""
    # a room at x < 3, a 1 m doorway at its south-east corner into a corridor 2 m wide
    # running 24 m north: standing in it, the corridor's south end wall 1 m away is the one
    # thing that fixes the pose along the corridor (its north end is beyond the LiDAR's
    # band), and the world has that wall 15 cm further north than the map
    shift = 0.15
    room = [(0, 0, 3, T), (0, 4 - T, 3, 4), (0, 0, T, 4), (3 - T / 2, 1.2, 3 + T / 2, 24)]
    corridor = room + [(5, 0, 5 + T, 24), (3, 24 - T, 5, 24)]
    (tmp_path / "map").mkdir(parents=True)
    (tmp_path / "world").mkdir()
    site = make_site(tmp_path / "map", corridor + [(3, 0, 5, T)], [], [], (6, 24.5))
    world = make_site(tmp_path / "world", corridor + [(3, shift, 5, T + shift)], [], [], (6, 24.5))
    start = (1.5, 0.7, 0.0)
    sim = simulation(world, start)
    loc = MapLocaliser(
        DistanceField.for_floor(site, "1"),
        *start,
        "1",
        MapModeSettings.from_config(load(None, list(overrides)).localisation),
    )
    worst = 0.0
    while sim.state.x < 4.0 and sim.time < 30.0:
        if sim.tick % 10 == 0:
            sim.command(0.3, 0.0)
        step(sim, loc)
        worst = max(worst, error(sim, loc)[0])
    for _ in range(150):  # 3 s standing in the corridor
        step(sim, loc)
        worst = max(worst, error(sim, loc)[0])
    end = error(sim, loc)[0]
    sim.close()
    assert sim.state.x >= 4.0 and not loc.lost
    return end, worst


def test_a_wall_the_world_has_off_the_map_does_not_pull_a_tracked_pose(tmp_path: Path) -> None:
    # world-differs campaign b7406w.m04: the scan match followed a wall the world had
    # moved 15 cm; with the tracking gate the wall stays out of the match
    ungated = drive_past_a_moved_wall(tmp_path / "ungated", ("localisation.track_gate_m=0",))
    assert ungated[0] > 0.1, f"without the gate only {ungated[0]:.3f} m off: nothing tested"
    end, worst = drive_past_a_moved_wall(tmp_path / "gated", ("localisation.track_gate_m=0.1",))
    assert worst < 0.02, f"{worst:.3f} m off at worst (ungated: {ungated[0]:.3f} m at the end)"
