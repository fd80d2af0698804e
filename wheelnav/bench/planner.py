"""``wheelnav bench planner``: A* and inflation timings on a seed-sized map, against pyastar2d.

The map is 800 x 4000 cells at 0.05 m (40 m x 200 m, the seed building's size): a
corridor along the building, rooms on both sides with 1.0-1.5 m doors, and furniture in
the rooms, drawn deterministically from a seed. Both planners get the same inflated grid
and the same endpoints (a room at one end to a room at the other). pyastar2d charges 1
for a diagonal step, so only its time is compared, not its path.

wheelnav's planner builds landmark distances (the ALT heuristic) once per floor when it
loads the site; that one-off cost is reported apart (``landmarks_ms``), and the plain
octile A* is timed too, so the effect of each part is visible.
"""

from __future__ import annotations

import argparse
import json
import statistics
import time
from collections.abc import Callable

import numpy as np

from services.planner.grid_astar import Landmarks, astar, path_cost
from services.planner.inflation import inflate
from sim.sitegen import draw

RESOLUTION = 0.05
RADIUS_M = 0.375  # the default chair: half of 0.65 m plus a 0.05 m margin


def seed_sized_map(seed: int = 0) -> tuple[np.ndarray, tuple[float, float], tuple[float, float]]:
    """An 800 x 4000 building and two far-apart room centres (x, y) in metres."""
    rng = np.random.default_rng(seed)
    w, h, t = 200.0, 40.0, 0.2
    walls = [
        (0, 0, w, t),
        (0, h - t, w, h),
        (0, 0, t, h),
        (w - t, 0, w, h),
        (0, 18.0, w, 18.2),
        (0, 21.8, w, 22.0),
    ]  # corridor between y = 18.2 and 21.8
    gaps = []
    for x0 in np.arange(0.0, w, 8.0):
        walls += [(x0, 0, x0 + t, 18.0), (x0, 22.0, x0 + t, h)]  # room partitions
        for y_wall in (18.0, 21.8):
            door = rng.uniform(1.0, 1.5)
            dx = x0 + rng.uniform(1.0, 8.0 - door - 1.0)
            gaps.append((dx, y_wall, dx + door, y_wall + t))
        for y0, y1 in ((1.0, 17.0), (23.0, 39.0)):  # furniture, kept off the door side
            for _ in range(3):
                fx, fy = x0 + rng.uniform(1.0, 6.0), rng.uniform(y0 + 1.0, y1 - 5.0 + (y0 > 20) * 4)
                walls.append((fx, fy, fx + rng.uniform(0.5, 1.5), fy + rng.uniform(0.5, 1.5)))
    occ = draw((w, h), walls, gaps, RESOLUTION)
    return occ, (4.0, 2.5), (196.0, 37.5)


def _median_ms(fn: Callable[[], object], repeats: int) -> tuple[float, object]:
    times, out = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        times.append(1000 * (time.perf_counter() - t0))
    return statistics.median(times), out


def run_planner_bench(
    repeats: int = 5, seed: int = 0, progress: Callable[[str], None] = print
) -> dict:
    """Time inflation, our A* (first call and steady state) and pyastar2d; return the figures."""
    try:
        import pyastar2d
    except ImportError:
        raise ImportError(
            "the planner benchmark compares with pyastar2d: pip install -e '.[bench]'"
        ) from None
    progress("building the 800 x 4000 map ...")
    occ, start_xy, goal_xy = seed_sized_map(seed)
    progress("inflating ...")
    inflation_ms, (lethal, _cost) = _median_ms(lambda: inflate(occ, RESOLUTION, RADIUS_M), repeats)
    cell = lambda p: (int(p[1] / RESOLUTION), int(p[0] / RESOLUTION))  # noqa: E731
    start, goal = cell(start_xy), cell(goal_xy)
    if lethal[start] or lethal[goal]:
        raise RuntimeError("benchmark endpoints fall in the inflated area; change the seed")
    astar(np.zeros((3, 3), dtype=bool), (0, 0), (2, 2))  # JIT compiled or loaded from cache
    progress("landmarks (once per floor) ...")
    t0 = time.perf_counter()
    landmarks = Landmarks(lethal, 4)
    landmarks_ms = 1000 * (time.perf_counter() - t0)
    progress("our A* ...")
    t0 = time.perf_counter()
    path = astar(lethal, start, goal, landmarks=landmarks)
    first_ms = 1000 * (time.perf_counter() - t0)
    ours_ms, path = _median_ms(lambda: astar(lethal, start, goal, landmarks=landmarks), repeats)
    plain_ms, plain = _median_ms(lambda: astar(lethal, start, goal), repeats)
    if abs(path_cost(plain) - path_cost(path)) > 1e-6:
        raise RuntimeError("A* with and without landmarks disagree on the optimal cost")
    progress("pyastar2d ...")
    weights = np.where(lethal, np.inf, 1.0).astype(np.float32)
    peer_ms, peer_path = _median_ms(
        lambda: pyastar2d.astar_path(weights, start, goal, allow_diagonal=True), repeats
    )
    return {
        "grid": list(occ.shape),
        "start_cell": list(start),
        "goal_cell": list(goal),
        "path_cells": int(len(path)),
        "path_m": round(path_cost(path) * RESOLUTION, 2),
        "astar_ms": round(ours_ms, 2),
        "astar_first_call_ms": round(first_ms, 2),
        "astar_octile_only_ms": round(plain_ms, 2),
        "landmarks_ms": round(landmarks_ms, 1),
        "pyastar2d_ms": round(peer_ms, 2),
        "pyastar2d_path_cells": None if peer_path is None else int(len(peer_path)),
        "ratio": round(ours_ms / peer_ms, 3),
        "ratio_first_call": round(first_ms / peer_ms, 3),
        "inflation_ms": round(inflation_ms, 1),
        "repeats": repeats,
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="wheelnav bench planner", description=__doc__.splitlines()[0]
    )
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--json", action="store_true", help="print the figures as JSON")
    args = parser.parse_args(argv)
    quiet = args.json
    result = run_planner_bench(args.repeats, args.seed, (lambda _m: None) if quiet else print)
    if args.json:
        print(json.dumps(result))
        return 0
    print(
        f"grid {result['grid'][0]} x {result['grid'][1]} cells, path {result['path_cells']} "
        f"cells ({result['path_m']} m)"
    )
    print(f"inflation            {result['inflation_ms']:8.1f} ms")
    print(
        f"A* (wheelnav)        {result['astar_ms']:8.2f} ms   first call "
        f"{result['astar_first_call_ms']:.2f} ms"
    )
    print(
        f"A* octile heuristic  {result['astar_octile_only_ms']:8.2f} ms   (same path, "
        f"no landmarks; landmarks take {result['landmarks_ms']:.0f} ms once per floor)"
    )
    print(f"A* (pyastar2d, C++)  {result['pyastar2d_ms']:8.2f} ms")
    print(
        f"ratio wheelnav / pyastar2d: {result['ratio']:.3f} (target <= 1.5); "
        f"first call {result['ratio_first_call']:.3f}"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
