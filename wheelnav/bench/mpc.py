"""Benchmark the sampling MPC: time per cycle, and closed-loop quality of its two selections.

``python -m wheelnav.bench.mpc [--json] [--repeats N] [--backend numba|numpy]
[--threads N] [--compare]`` times ``SamplingMPC.step`` for the fleet's samples x steps
(``controller.mpc``) and 2000 x 56 on a corridor map with about 400 LiDAR points;
``--compare`` also drives an ideal unicycle through an L-shaped corridor, a 1.0 m doorway
and past a box with MPPI and with the seed's cluster rule, and reports RMS cross-track
error, RMS change of w between cycles and the smallest footprint clearance. Every run uses
the fleet's MPC tuning (``FleetConfig().controller.mpc``) with only the sizes, backend,
threads, selection and seed replaced. The scenes and the closed loop are reused by the tests.
"""

from __future__ import annotations

import argparse
import json
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np
from scipy.ndimage import binary_dilation, distance_transform_edt

from services.controller.mpc import SamplingMPC
from shared.config import FleetConfig, MPCConfig, RobotConfig

RES = 0.05  # map cell size (m), as the seed's maps


def fleet_mpc(**changes) -> MPCConfig:
    """The fleet's MPC tuning (``controller.mpc`` defaults) with ``changes`` replaced."""
    return replace(FleetConfig().controller.mpc, **changes)


SIZES = ((fleet_mpc().samples, fleet_mpc().steps), (2000, 56))  # the fleet's, and a big one


@dataclass
class Scene:
    """A map, its distance field, a path to follow, a start pose and extra obstacle points."""

    name: str
    occupied: np.ndarray  # (H, W) bool, row 0 at the bottom
    origin: tuple[float, float]
    dist: np.ndarray  # metres from each cell centre to the nearest occupied cell centre
    path: np.ndarray  # (N, 2)
    v_ref: np.ndarray  # (N,)
    start: tuple[float, float, float]
    obstacles: np.ndarray | None = None  # (M, 2) points seen by the LiDAR, not in the map


def _grid(x0: float, y0: float, x1: float, y1: float, free: list[tuple]) -> tuple:
    """Occupancy of the box [x0, x1] x [y0, y1]: walls except the ``free`` rectangles."""
    w, h = round((x1 - x0) / RES), round((y1 - y0) / RES)
    cx = x0 + (np.arange(w) + 0.5) * RES
    cy = y0 + (np.arange(h) + 0.5) * RES
    occ = np.ones((h, w), dtype=bool)
    for fx0, fy0, fx1, fy1, is_free in free:
        cols = (cx >= fx0) & (cx <= fx1)
        rows = (cy >= fy0) & (cy <= fy1)
        occ[np.ix_(rows, cols)] = not is_free
    return occ, (x0, y0)


def _path(corners: list[tuple[float, float]], cruise: float = 0.5) -> tuple:
    """Waypoints every 0.5 m along ``corners`` (as the planner spaces them), slowing at the end."""
    pts = [np.array(corners[0], dtype=float)]
    for a, b in zip(corners[:-1], corners[1:], strict=True):
        a, b = np.asarray(a, float), np.asarray(b, float)
        n = max(1, math.ceil(np.linalg.norm(b - a) / 0.5))
        pts += [a + (b - a) * (i / n) for i in range(1, n + 1)]
    pts = np.array(pts)
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))])
    v = cruise * np.clip((s[-1] - s) / 1.0, 0.2, 1.0)
    v[-1] = 0.0
    return pts, v


def _scene(
    name: str,
    occ: np.ndarray,
    origin: tuple[float, float],
    corners: list[tuple[float, float]],
    start: tuple[float, float, float],
    obstacles: np.ndarray | None = None,
) -> Scene:
    """A scene from its occupancy, with the distance field and a path along ``corners``."""
    path, v = _path(corners)
    dist = distance_transform_edt(~occ).astype(np.float32) * RES
    return Scene(name, occ, origin, dist, path, v, start, obstacles)


def l_corridor_scene() -> Scene:
    """A 1.8 m wide corridor turning left by 90 degrees; path along its centre line."""
    occ, origin = _grid(
        -2.0, -2.0, 7.5, 8.5, [(-1.5, -0.9, 5.9, 0.9, True), (4.1, -0.9, 5.9, 8.0, True)]
    )
    return _scene("l_corridor", occ, origin, [(0, 0), (5, 0), (5, 6.5)], (0.0, 0.0, 0.0))


def door_scene() -> Scene:
    """A 2 m corridor cut by a 0.2 m wall with a 1.0 m doorway; the chair starts off-centre."""
    occ, origin = _grid(
        -2.0,
        -1.5,
        9.0,
        1.5,
        [(-1.5, -1.0, 8.5, 1.0, True), (3.9, -1.0, 4.1, 1.0, False), (3.9, -0.5, 4.1, 0.5, True)],
    )
    return _scene("door_1.0m", occ, origin, [(0, 0), (7.5, 0)], (0.0, 0.45, -0.3))


def box_scene() -> Scene:
    """A 3 m corridor with a 0.4 m box on the path, known only from LiDAR points."""
    occ, origin = _grid(-2.0, -2.0, 9.0, 2.0, [(-1.5, -1.5, 8.5, 1.5, True)])
    side = np.linspace(-0.2, 0.2, 9)
    box = np.concatenate(
        [
            np.c_[side, -0.2 + 0 * side],
            np.c_[side, 0.2 + 0 * side],
            np.c_[-0.2 + 0 * side, side],
            np.c_[0.2 + 0 * side, side],
        ]
    ) + (3.0, 0.05)
    return _scene("box", occ, origin, [(0, 0), (6.5, 0)], (0.0, 0.0, 0.0), box)


def scenes() -> list[Scene]:
    """The closed-loop scenes of the selection comparison."""
    return [l_corridor_scene(), door_scene(), box_scene()]


def lidar_scan(
    scene: Scene, x: float, y: float, beams: int = 360, range_m: float = 12.0, seed: int = 0
) -> np.ndarray:
    """World-frame hit points of a planar scan from (x, y) against the scene's walls."""
    rng = np.random.default_rng(seed)
    ang = np.linspace(-math.pi, math.pi, beams, endpoint=False)
    r = np.arange(0.1, range_m, RES / 2)
    px = x + np.cos(ang)[:, None] * r
    py = y + np.sin(ang)[:, None] * r
    h, w = scene.occupied.shape
    col = ((px - scene.origin[0]) / RES).astype(int)
    row = ((py - scene.origin[1]) / RES).astype(int)
    inside = (col >= 0) & (col < w) & (row >= 0) & (row < h)
    hit = np.zeros_like(inside)
    hit[inside] = scene.occupied[row[inside], col[inside]]
    has = hit.any(axis=1)
    first = hit.argmax(axis=1)
    d = r[first[has]] + rng.normal(0.0, 0.01, has.sum())
    return np.c_[x + np.cos(ang[has]) * d, y + np.sin(ang[has]) * d]


# --------------------------------------------------------------------------------------
# Closed loop on an ideal unicycle
# --------------------------------------------------------------------------------------


def _wall_points(scene: Scene) -> np.ndarray:
    """Centres of occupied cells next to free space (the wall faces)."""
    face = scene.occupied & binary_dilation(~scene.occupied)
    r, c = np.nonzero(face)
    return np.c_[scene.origin[0] + (c + 0.5) * RES, scene.origin[1] + (r + 0.5) * RES]


def footprint_clearance(
    robot: RobotConfig, x: float, y: float, th: float, walls: np.ndarray, points: np.ndarray
) -> float:
    """Distance from the footprint rectangle to the nearest wall cell or point (m).

    Exact for points; for wall cells a lower bound (the distance to the cell centre less
    half a cell diagonal, as the cell is a square). Inside the rectangle it is negative.
    """
    fp = robot.footprint
    best = math.inf
    for pts, shrink in ((walls, RES * math.sqrt(0.5)), (points, 0.0)):
        if len(pts) == 0:
            continue
        dx, dy = pts[:, 0] - x, pts[:, 1] - y
        bx = dx * math.cos(th) + dy * math.sin(th)
        by = -dx * math.sin(th) + dy * math.cos(th)
        cx = (fp.front - fp.rear) / 2
        ex = np.abs(bx - cx) - (fp.front + fp.rear) / 2
        ey = np.abs(by) - fp.width / 2
        out = np.hypot(np.maximum(ex, 0), np.maximum(ey, 0))
        inside = np.minimum(np.maximum(ex, ey), 0)
        best = min(best, float((out + inside).min()) - shrink)
    return best


def _cross_track(path: np.ndarray, x: float, y: float) -> float:
    a, b = path[:-1], path[1:]
    d = b - a
    t = np.clip(((x - a[:, 0]) * d[:, 0] + (y - a[:, 1]) * d[:, 1]) / (d * d).sum(1), 0, 1)
    return float(np.hypot(a[:, 0] + t * d[:, 0] - x, a[:, 1] + t * d[:, 1] - y).min())


def closed_loop(
    cfg: MPCConfig,
    scene: Scene,
    robot: RobotConfig | None = None,
    period_s: float = 0.1,
    max_time_s: float = 60.0,
    trace: list | None = None,
) -> dict:
    """Drive an ideal unicycle with the MPC until it arrives, blocks or times out.

    The unicycle takes each command exactly for ``period_s``; clearance is checked every
    quarter period. Returns the end state and the tracking, smoothness and safety figures;
    ``trace`` (if given) receives (x, y, theta, v, w) of every command.
    """
    robot = robot or RobotConfig()
    mpc = SamplingMPC(cfg, robot)
    mpc.set_path(scene.path, scene.v_ref)
    mpc.set_distance_field(scene.dist, RES, scene.origin)
    walls = _wall_points(scene)
    points = scene.obstacles if scene.obstacles is not None else np.zeros((0, 2))
    x, y, th = scene.start
    v = w = 0.0
    cross, ws, clear = [], [], []
    cmd = None
    sub = 4
    for _ in range(int(max_time_s / period_s)):
        cmd = mpc.step(x, y, th, v, w, scene.obstacles, period_s)
        if cmd.state != "following":
            break
        if trace is not None:
            trace.append((x, y, th, cmd.v, cmd.w))
        cross.append(_cross_track(scene.path, x, y))
        ws.append(cmd.w)
        v, w = cmd.v, cmd.w
        for _ in range(sub):
            h = period_s / sub
            x += v * h * math.cos(th + 0.5 * w * h)
            y += v * h * math.sin(th + 0.5 * w * h)
            th += w * h
            near = walls[np.abs(walls - (x, y)).max(axis=1) < 2.0]
            clear.append(footprint_clearance(robot, x, y, th, near, points))
    goal = scene.path[-1]
    cross_a = np.array(cross or [0.0])
    return {
        "scene": scene.name,
        "state": cmd.state if cmd else "none",
        "time_s": round(len(ws) * period_s, 2),
        "goal_error_m": round(math.hypot(goal[0] - x, goal[1] - y), 3),
        "rms_cross_track_m": round(float(np.sqrt(np.mean(cross_a**2))), 4),
        "max_cross_track_m": round(float(cross_a.max()), 4),
        "rms_dw": round(float(np.sqrt(np.mean(np.diff(ws) ** 2))) if len(ws) > 1 else 0.0, 4),
        "min_clearance_m": round(min(clear) if clear else math.inf, 4),
    }


def compare_selections(
    cfg: MPCConfig | None = None, seeds: tuple[int, ...] = (0, 1, 2), progress=print
) -> dict:
    """Closed-loop figures of MPPI and the cluster rule on the same scenes and seeds
    (the fleet's tuning unless ``cfg`` is given)."""
    cfg = cfg or fleet_mpc()
    out: dict[str, list[dict]] = {}
    for selection in ("mppi", "cluster"):
        rows = []
        for scene in scenes():
            for seed in seeds:
                row = closed_loop(replace(cfg, selection=selection, seed=seed), scene)
                row["seed"] = seed
                rows.append(row)
                progress(f"{selection:8s} {json.dumps(row)}")
        out[selection] = rows
    return out


# --------------------------------------------------------------------------------------
# Timing
# --------------------------------------------------------------------------------------


def run_mpc_bench(
    repeats: int = 50,
    progress: Callable[[str], None] = print,
    backend: str = "numba",
    sizes: tuple[tuple[int, int], ...] = SIZES,
    threads: int = 0,
) -> dict:
    """Median and 99th-percentile time of one ``step`` per size, on a corridor with a person.

    The scene: the L-shaped corridor's distance field, the chair at 0.4 m/s on the first
    leg, a 360-beam scan of the walls plus a person (about 400 points). A few untimed
    cycles first compile the kernel and settle the warm start.
    """
    scene = l_corridor_scene()
    x, y, th, v, w = 1.0, 0.1, 0.05, 0.4, 0.0
    person = (
        np.array([3.2, 0.35])
        + 0.25
        * np.c_[
            np.cos(np.linspace(0, 2 * np.pi, 40, endpoint=False)),
            np.sin(np.linspace(0, 2 * np.pi, 40, endpoint=False)),
        ]
    )
    scan = np.concatenate([lidar_scan(scene, x, y), person])
    rows = []
    for samples, steps in sizes:
        cfg = fleet_mpc(samples=samples, steps=steps, backend=backend, threads=threads)
        mpc = SamplingMPC(cfg, RobotConfig())
        mpc.set_path(scene.path, scene.v_ref)
        mpc.set_distance_field(scene.dist, RES, scene.origin)
        for _ in range(5):
            mpc.step(x, y, th, v, w, scan, 0.1)
        times = []
        for _ in range(repeats):
            t0 = time.perf_counter()
            mpc.step(x, y, th, v, w, scan, 0.1)
            times.append((time.perf_counter() - t0) * 1e3)
        row = {
            "samples": samples,
            "steps": steps,
            "median_ms": round(float(np.median(times)), 3),
            "p99_ms": round(float(np.percentile(times, 99)), 3),
        }
        progress(
            f"mpc {samples:5d} x {steps:3d} ({backend}, threads {threads or 'all'}, "
            f"{len(scan)} lidar points): "
            f"median {row['median_ms']:.2f} ms, p99 {row['p99_ms']:.2f} ms"
        )
        rows.append(row)
    return {"mpc": rows}


def localisation_bench(repeats: int = 50, progress: Callable[[str], None] = print) -> float:
    """Median time (ms) of one map-mode localisation update (scan match) on two_floors."""
    from pathlib import Path

    from services.localisation.localiser import MapLocaliser, MapModeSettings
    from services.localisation.matcher import DistanceField
    from shared.config import load
    from shared.site import load_site
    from sim.simulation import Simulation

    site = load_site(Path(__file__).resolve().parents[2] / "sites" / "two_floors")
    cfg = load(None, ["sim.start.place=corridor_1_west", "sim.lidar=vlp16"])
    sim = Simulation(cfg, site)
    scan = None
    while scan is None:
        scan = sim.step().scan
    pts = scan[np.abs(scan[:, 2]) < cfg.localisation.scan_band_m]
    s = sim.state
    loc = MapLocaliser(
        DistanceField(site.floor("1").map), s.x, s.y, s.theta, "1", MapModeSettings()
    )
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        loc.update_scan(pts)
        times.append((time.perf_counter() - t0) * 1e3)
    median = round(float(np.median(times)), 3)
    progress(f"localisation update (VLP-16 band, {len(pts)} points): median {median:.2f} ms")
    return median


def main(argv: list[str] | None = None) -> int:
    """Command line: print the timings (and the selection comparison with --compare)."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", action="store_true", help="print one JSON document only")
    ap.add_argument("--repeats", type=int, default=50)
    ap.add_argument("--backend", choices=("numba", "numpy"), default="numba")
    ap.add_argument("--threads", type=int, default=0, help="numba threads (0 = all)")
    ap.add_argument("--compare", action="store_true", help="also compare MPPI and cluster")
    args = ap.parse_args(argv)
    quiet = args.json

    def say(text: str) -> None:
        if not quiet:
            print(text)

    result = run_mpc_bench(args.repeats, say, args.backend, threads=args.threads)
    result["localisation_ms"] = localisation_bench(args.repeats, say)
    if args.compare:
        result["selection"] = compare_selections(progress=say)
    if args.json:
        print(json.dumps(result, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
