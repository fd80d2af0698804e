"""``wheelnav bench sim``: real-time factor of the headless simulator with the 3D LiDAR at 10 Hz.

Two maps: the seed floor (``sites/seed_floor`` when it loads, else the same hallway and
elevator room drawn here) and the 800 x 4000 seed-sized building of the planner benchmark.
On each, the real :class:`~sim.simulation.Simulation` runs with its planar LiDAR replaced
by a VLP-16-like :class:`~sim.lidar3d.MultiRingLidar` (16 rings over +-15 deg, 0.2 deg
steps, mount height from the config) and the chair driven along the corridor at a
constant command: chair dynamics and clearance at 50 Hz, a 3D scan at 10 Hz. The
real-time factor is simulated seconds over wall seconds; the ray-casting time is the
median of the scans; the load time is building the simulator (the pybullet world).
"""

from __future__ import annotations

import argparse
import json
import statistics
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from shared.config import ConfigError, load
from shared.site import load_site
from sim.lidar3d import MultiRingLidar
from sim.simulation import Simulation
from sim.sitegen import draw, write_map

SEED_SITE = Path(__file__).resolve().parents[2] / "sites" / "seed_floor"
SEED_START = (-4.0, 3.0, 0.0)  # west end of the hallway, facing along it
LARGE_START = (2.0, 20.0, 0.0)  # west end of the 800 x 4000 building's corridor
SPEED = 0.6  # m/s, the default chair's top speed
RESOLUTION = 0.05


def draw_seed_floor(folder: Path) -> Path:
    """The seed floor's hallway and elevator room as a map_server map; returns its YAML.

    Hallway x -6.5..84.2, y -1..6.9; elevator room x 28..39, y 6.9..13.8; a 1.5 m door
    centred at (31.1, 6.9). Walls 0.2 m thick on those lines.
    """
    ox, oy = -7.5, -2.0
    half = 0.1

    def local(x0: float, y0: float, x1: float, y1: float) -> tuple[float, float, float, float]:
        return x0 - ox, y0 - oy, x1 - ox, y1 - oy

    size = (85.2 - ox, 14.8 - oy)
    solid = [local(-6.5 - half, -1.0 - half, 84.2 + half, 13.8 + half)]
    free = [
        local(-6.5 + half, -1.0 + half, 84.2 - half, 6.9 - half),
        local(28.0 + half, 6.9 + half, 39.0 - half, 13.8 - half),
        local(31.1 - 0.75, 6.9 - half, 31.1 + 0.75, 6.9 + half),
    ]
    occ = draw(size, solid, free, RESOLUTION)
    return write_map(occ, folder, "seed_floor", RESOLUTION, (ox, oy, 0.0))


def large_map(folder: Path) -> Path:
    """The planner benchmark's 800 x 4000 building as a map_server map; returns its YAML."""
    from wheelnav.bench.planner import seed_sized_map

    occ, _start, _goal = seed_sized_map(0)
    return write_map(occ, folder, "large", RESOLUTION)


class _TimedLidar:
    """Wraps a LiDAR to record the wall time and point count of each scan."""

    def __init__(self, lidar: MultiRingLidar) -> None:
        self.lidar = lidar
        self.ms: list[float] = []
        self.points: list[int] = []

    def scan(self, x: float, y: float, theta: float, base_z: float = 0.0) -> np.ndarray:
        t0 = time.perf_counter()
        pts = self.lidar.scan(x, y, theta, base_z)
        self.ms.append(1000 * (time.perf_counter() - t0))
        self.points.append(len(pts))
        return pts


def run_map(site_path: Path, start: tuple[float, float, float], seconds: float) -> dict[str, Any]:
    """Build the simulator on ``site_path``, drive ``seconds`` of sim time; return the figures."""
    x, y, theta = start
    cfg = load(
        None,
        [
            f"site={site_path}",
            "sim.start.place=",
            f"sim.start.x={x}",
            f"sim.start.y={y}",
            f"sim.start.theta={theta}",
        ],
    )
    site = load_site(site_path)
    t0 = time.perf_counter()
    sim = Simulation(cfg, site)
    load_s = time.perf_counter() - t0
    try:
        lidar = MultiRingLidar.for_site(
            sim.world,
            site,
            height_m=cfg.robot.lidar_height_m,
            noise_m=cfg.sim.lidar_noise_m,
            rng=sim.rng,
            ignore_ids=[sim.body],
            unknown_is_occupied=cfg.planner.unknown_is_occupied,
        )
        lidar.scan(x, y, theta, sim.z)  # compiles the kernels (or loads them from numba's cache)
        timed = _TimedLidar(lidar)
        sim.lidar = timed
        ticks = round(seconds / sim.dt)
        t0 = time.perf_counter()
        for _ in range(ticks):
            sim.command(SPEED, 0.0)
            sim.step()
        wall = time.perf_counter() - t0
        return {
            "grid": list(site.floor("").map.shape),
            "load_s": load_s,
            "rtf": sim.time / wall,
            "raycast_ms": statistics.median(timed.ms),
            "points_per_scan": int(statistics.median(timed.points)),
            "scans": len(timed.ms),
            "collisions": sim.collisions,
            "beams": lidar.beams,
            "method": lidar.method,
        }
    finally:
        sim.close()


def _seed_site(folder: Path) -> Path:
    """The bundled seed floor if it loads, else the hallway and elevator room drawn here."""
    try:
        load_site(SEED_SITE)
        return SEED_SITE
    except ConfigError:
        return draw_seed_floor(folder)


def run_sim_bench(seconds: float = 10.0, progress: Callable[[str], None] = print) -> dict:
    """Run the simulator on both maps for ``seconds`` of sim time each; return the figures."""
    with tempfile.TemporaryDirectory(prefix="wheelnav-bench-sim-") as tmp:
        folder = Path(tmp)
        seed_path = _seed_site(folder)
        progress(f"seed floor ({seed_path.name}): {seconds:g} s of sim time ...")
        seed = run_map(seed_path, SEED_START, seconds)
        progress("800 x 4000 map: building it ...")
        large_path = large_map(folder)
        progress(f"800 x 4000 map: {seconds:g} s of sim time ...")
        large = run_map(large_path, LARGE_START, seconds)
    return {
        "rtf_seed_floor": round(seed["rtf"], 1),
        "rtf_large": round(large["rtf"], 1),
        "raycast_ms": round(seed["raycast_ms"], 3),
        "raycast_ms_large": round(large["raycast_ms"], 3),
        "load_s_seed_floor": round(seed["load_s"], 3),
        "load_s_large": round(large["load_s"], 3),
        "points_per_scan": seed["points_per_scan"],
        "points_per_scan_large": large["points_per_scan"],
        "grid_seed_floor": seed["grid"],
        "grid_large": large["grid"],
        "beams_per_scan": seed["beams"],
        "scans": seed["scans"] + large["scans"],
        "collisions": seed["collisions"] + large["collisions"],
        "method": seed["method"],
        "seconds": seconds,
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="wheelnav bench sim", description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=10.0, help="sim time per map (default 10)")
    parser.add_argument("--json", action="store_true", help="print the figures as JSON")
    args = parser.parse_args(argv)
    if args.seconds <= 0:
        parser.error(f"--seconds: must be > 0, got {args.seconds}")
    result = run_sim_bench(args.seconds, (lambda _m: None) if args.json else print)
    if args.json:
        print(json.dumps(result))
        return 0
    print(
        f"3D LiDAR: {result['beams_per_scan']} beams per scan at 10 Hz, "
        f"{result['method']} ray casting; {args.seconds:g} s of sim time per map"
    )
    print(f"{'map':12s} {'cells':>12s} {'load s':>8s} {'rtf':>8s} {'scan ms':>9s} {'points':>8s}")
    for label, key, grid in (
        ("seed floor", "seed_floor", result["grid_seed_floor"]),
        ("800 x 4000", "large", result["grid_large"]),
    ):
        suffix = "" if key == "seed_floor" else "_large"
        print(
            f"{label:12s} {f'{grid[0]} x {grid[1]}':>12s} {result[f'load_s_{key}']:8.3f} "
            f"{result[f'rtf_{key}']:8.1f} {result['raycast_ms' + suffix]:9.3f} "
            f"{result['points_per_scan' + suffix]:8d}"
        )
    verdict = "met" if result["rtf_seed_floor"] >= 10 else "NOT met"
    print(f"target: real-time factor >= 10 on the seed floor: {verdict}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
