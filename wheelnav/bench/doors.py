"""``wheelnav bench doors``: the narrow-door campaign (issue 14), one door at a time.

One door of width W in a straight wall between two rooms, hinged (its leaf swinging to a
seeded side: into the approach room or away from it) or sliding; the chair's reference
point starts 2-7 m before the door plane wherever its footprint keeps 10 cm from the walls,
heading uniform, and is sent to a place 2.5 m past the door. Each run is a whole mission on
the fleet in lockstep (as ``wheelnav mission`` runs it); from the simulator's truth (the
report's trace) it measures, where the chair's body centre crosses the door plane, the
lateral offset from the true door centre and the heading off the door's normal, the least
clearance in the opening, and the time from the start until the body centre is 1 m past
the door. A table row per width and door kind gives pass rate, collisions, offsets (RMS
and max), heading RMS, least clearance against the opening's limit and the median time.

Each start is run with each door procedure (``--procedures``: smooth and stop-turn-go,
side by side; a smooth run that shows a correct, turn or verify phase fell back to
stop-turn-go and is counted so). ``--map-off-m``: the stack's map (and its door entry)
places the door up to that far along the wall from where the simulator's world has it.
``--set KEY=VALUE`` overrides a config value in every run (for example
``launcher.in_process=true``: the same reports, faster); the door procedure is
``--procedures``' to set.
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import sys
import tempfile
from pathlib import Path
from typing import Any, TextIO

import numpy as np
import yaml

from shared import config as config_mod
from shared.config import ConfigError, FleetConfig, RobotConfig
from shared.service import add_override_argument
from sim.sitegen import draw, write_map
from wheelnav.campaign.results import door_requirement_m

WIDTHS = (0.80, 0.90, 1.00)
KINDS = ("hinged", "sliding")
WALL_X = 8.0  # the door's wall: x from 7.9 to 8.1; the approach room is x < 7.9
ROOM = (8.0, 8.0)  # the approach room's size (x, y); the room past the door is 5 m deep
WALL_M = 0.2
CELL_M = 0.05  # the drawn map's resolution (sim.sitegen.draw's default)
START_M = (2.0, 7.0)  # the reference point's distance before the door plane
KEEP_M = 0.1  # the footprint's least distance from a wall at the start
GOAL_PAST_M = 2.5
PAST_M = 1.0  # the time is taken until the body centre is this far past the door plane


def door_site(folder: Path, width: float, kind: str, door_y: float, swing: str) -> Path:
    """Draw the two rooms with the door (centred at ``door_y`` on the wall) into
    ``folder``; returns the site.yaml path."""
    w, h, t = WALL_X + 5.0, ROOM[1], WALL_M
    walls = [(0, 0, w, t), (0, h - t, w, h), (0, 0, t, h), (w - t, 0, w, h)]
    walls.append((WALL_X - t / 2, 0, WALL_X + t / 2, h))
    gaps = [(WALL_X - t / 2, door_y - width / 2, WALL_X + t / 2, door_y + width / 2)]
    write_map(draw((w, h), walls, gaps), folder, "floor1")
    door = {
        "id": "door",
        "floor": "1",
        "p1": [WALL_X, round(door_y - width / 2, 3)],
        "p2": [WALL_X, round(door_y + width / 2, 3)],
        "type": "manual",
        "motion": kind,
    }
    if kind == "hinged":
        door["swing"] = swing
    site = {
        "name": f"door_{width:.2f}_{kind}",
        "floors": [{"name": "1", "elevation": 0.0, "map": "floor1.yaml"}],
        "doors": [door],
        "places": {"beyond": {"floor": "1", "x": WALL_X + GOAL_PAST_M, "y": door_y, "theta": 0.0}},
    }
    path = folder / "site.yaml"
    path.write_text(yaml.safe_dump(site, sort_keys=False))
    return path


def draw_door_y(rng: np.random.Generator, width: float) -> float:
    """The door's centre along its wall: uniform, at least 2.5 m from the room's ends,
    moved to where its jambs fall on the map's cell edges (the simulator builds its walls
    from the cells, so the entry is where the gap is)."""
    y = float(rng.uniform(2.5, ROOM[1] - 2.5))
    return round(round((y - width / 2) / CELL_M) * CELL_M + width / 2, 6)


def footprint_corners(x: float, y: float, theta: float, robot: RobotConfig) -> np.ndarray:
    """The footprint's four corners (4, 2) at pose (x, y, theta)."""
    fp = robot.footprint
    body = np.array(
        [[fp.front, fp.width / 2], [fp.front, -fp.width / 2], [-fp.rear, -fp.width / 2]]
        + [[-fp.rear, fp.width / 2]]
    )
    c, s = math.cos(theta), math.sin(theta)
    return body @ np.array([[c, s], [-s, c]]) + [x, y]


def draw_start(rng: np.random.Generator, robot: RobotConfig) -> tuple[float, float, float]:
    """A start 2-7 m before the door plane, any heading, the footprint 10 cm off walls."""
    lo, hi = WALL_M / 2 + KEEP_M, ROOM[1] - WALL_M / 2 - KEEP_M
    for _ in range(10_000):
        x = WALL_X - rng.uniform(*START_M)
        pose = (float(x), float(rng.uniform(lo, hi)), float(rng.uniform(-math.pi, math.pi)))
        corners = footprint_corners(*pose, robot)
        inside = corners.min() >= lo and corners[:, 1].max() <= hi
        if inside and corners[:, 0].max() <= WALL_X - WALL_M / 2 - KEEP_M:
            return pose
    raise RuntimeError("no start pose fits the approach room")


def crossing(trace: list[dict], robot: RobotConfig, plane_x: float) -> dict | None:
    """Where the body centre first crosses x = ``plane_x`` going forward: its y, the
    heading and the time, interpolated between trace samples (None if it never does)."""
    ahead = (robot.footprint.front - robot.footprint.rear) / 2
    prev = None
    for p in trace:
        cx = p["x"] + ahead * math.cos(p["theta"])
        cy = p["y"] + ahead * math.sin(p["theta"])
        if prev is not None and prev[1] < plane_x <= cx:
            f = (plane_x - prev[1]) / (cx - prev[1])
            dtheta = math.atan2(math.sin(p["theta"] - prev[3]), math.cos(p["theta"] - prev[3]))
            return {
                "t": prev[0] + f * (p["t"] - prev[0]),
                "y": prev[2] + f * (cy - prev[2]),
                "theta": prev[3] + f * dtheta,
            }
        prev = (p["t"], cx, cy, p["theta"])
    return None


def measure(report: dict, door_y: float, width: float, robot: RobotConfig) -> dict[str, Any]:
    """One run's figures from its report (truth trace, door clearance)."""
    at = crossing(report.get("trace", []), robot, WALL_X)
    past = crossing(report.get("trace", []), robot, WALL_X + PAST_M)
    seen = next((d for d in report.get("door_clearance", []) if d["door"] == "door"), None)
    free = (seen or {}).get("free_width_m") or width
    return {
        "passed": bool(report["success"]) and at is not None,
        "collisions": report.get("collisions", 0),
        "lateral_m": None if at is None else round(at["y"] - door_y, 4),
        "heading_deg": None if at is None else round(math.degrees(at["theta"]), 2),
        "clearance_m": None if seen is None else seen["min_clearance_m"],
        "required_m": round(door_requirement_m(free, robot.footprint.width), 4),
        "time_s": None if past is None else round(past["t"], 2),
        "reason": report.get("reason", ""),
    }


def summarise(runs: list[dict]) -> dict[str, Any]:
    """A table row for the runs of one width and door kind."""
    lat = [abs(r["lateral_m"]) for r in runs if r["lateral_m"] is not None]
    head = [abs(r["heading_deg"]) for r in runs if r["heading_deg"] is not None]
    clear = [r["clearance_m"] for r in runs if r["clearance_m"] is not None]
    times = [r["time_s"] for r in runs if r["time_s"] is not None]

    def rms(v: list[float]) -> float | None:
        return round(math.sqrt(sum(x * x for x in v) / len(v)), 4) if v else None

    return {
        "runs": len(runs),
        "passed": sum(r["passed"] for r in runs),
        "collisions": sum(r["collisions"] for r in runs),
        "lateral_rms_m": rms(lat),
        "lateral_max_m": max(lat) if lat else None,
        "heading_rms_deg": rms(head),
        "min_clearance_m": min(clear) if clear else None,
        "clearance_short": sum(
            r["clearance_m"] is not None and r["clearance_m"] < r["required_m"] for r in runs
        ),
        "median_time_s": round(statistics.median(times), 2) if times else None,
        "fell_back": sum(bool(r.get("fell_back")) for r in runs),
    }


PROCEDURES = ("smooth", "stop_turn_go")
SLOW_PHASES = ("correct", "turn", "verify")  # a smooth pass that shows these fell back


def fell_back(report: dict) -> bool:
    """True if the door's own phases (its checkpoint's, not a recovery's turn on the way
    to it) show a stop-turn-go step."""
    door = next((c for c in report.get("checkpoints", []) if c.get("id") == "door"), {})
    return bool(set(door.get("phases") or {}) & set(SLOW_PHASES))


def _scenario(
    folder: Path,
    name: str,
    seed: int,
    start: tuple[float, float, float],
    procedure: str,
    world: bool,
) -> Path:
    """The mission of one run: to the place past the door with ``procedure``; ``world``:
    the simulator builds the world site (the door where it is), the stack gets the map."""
    x, y, theta = start
    data = {
        "name": name,
        "site": "map/site.yaml",
        "seed": seed,
        "time_limit_s": 120.0,
        "start": {"x": x, "y": y, "theta": theta, "floor": "1"},
        "goal": {"place": "beyond"},
        "config": {"navigator": {"door_procedure": procedure}},
    }
    if world:
        data["world_site"] = "world/site.yaml"
    path = folder / f"{procedure}.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def run_bench(
    starts: int,
    seed: int,
    widths: tuple[float, ...],
    kinds: tuple[str, ...],
    out: TextIO,
    procedures: tuple[str, ...] = PROCEDURES,
    map_off_m: float = 0.0,
    keep: Path | None = None,
    overrides: tuple[str, ...] = (),
) -> dict[str, Any]:
    """Run every start for every width, kind and procedure (each start with each
    procedure); the mapped door ``map_off_m`` at most along its wall from where it is;
    progress on ``out``, with the command that replays a run that failed or fell back
    (its scenario kept under ``keep``, else in a temporary folder that goes); every run
    with the config ``overrides`` (KEY=VALUE); the figures."""
    from wheelnav.mission.run import MissionRun  # the fleet: only when running
    from wheelnav.mission.scenario import load_scenario

    robot = RobotConfig()
    rng = np.random.default_rng(seed)
    rows: dict[str, Any] = {}
    with tempfile.TemporaryDirectory(prefix="wheelnav-doors-") as temporary:
        tmp = keep or temporary
        for width in widths:
            for kind in kinds:
                runs: dict[str, list[dict]] = {proc: [] for proc in procedures}
                for i in range(starts):
                    door_y = draw_door_y(rng, width)
                    swing = str(rng.choice(["left", "right"]))  # left: into the approach room
                    off = float(rng.uniform(-map_off_m, map_off_m)) if map_off_m > 0 else 0.0
                    folder = Path(tmp) / f"{width:.2f}_{kind}_{i}"
                    door_site(folder / "map", width, kind, door_y + off, swing)
                    if off:
                        door_site(folder / "world", width, kind, door_y, swing)
                    start = draw_start(rng, robot)
                    for proc in procedures:
                        name = f"door_{width:.2f}_{kind}_{i}_{proc}"
                        scenario = _scenario(folder, name, seed + i, start, proc, bool(off))
                        loaded = load_scenario(scenario, list(overrides))
                        report = MissionRun(loaded, quiet=True).run()
                        row = measure(report, door_y, width, robot)
                        row.update(
                            start=[round(v, 3) for v in start],
                            swing=swing,
                            map_off_m=round(off, 3),
                            fell_back=proc == "smooth" and fell_back(report),
                        )
                        runs[proc].append(row)
                        print(
                            f"{width:.2f} m {kind} {proc} {i + 1}/{starts}: "
                            + ("passed" if row["passed"] else f"FAILED ({row['reason']})")
                            + f", lateral {row['lateral_m']} m, heading {row['heading_deg']} deg"
                            + (", fell back" if row["fell_back"] else ""),
                            file=out,
                            flush=True,
                        )
                        if keep and (row["fell_back"] or not row["passed"]):
                            print(f"  replay: wheelnav mission {scenario}", file=out)
                for proc in procedures:
                    rows[f"{width:.2f} {kind} {proc}"] = {
                        "summary": summarise(runs[proc]),
                        "runs": runs[proc],
                    }
    return {
        "seed": seed,
        "starts": starts,
        "map_off_m": map_off_m,
        "overrides": list(overrides),
        "rows": rows,
    }


def check_overrides(overrides: list[str]) -> None:
    """Refuse an override the fleet config does not take, or one that would undo
    ``--procedures`` (raises ConfigError naming the key)."""
    for item in overrides:
        if item.split("=", 1)[0].strip() == "navigator.door_procedure":
            raise ConfigError("navigator.door_procedure: set it with --procedures, not --set")
    config_mod.from_dict(FleetConfig, config_mod.apply_overrides({}, list(overrides)))


def format_table(result: dict[str, Any]) -> str:
    """The rows side by side, one line per width and kind."""
    head = (
        f"{'door':27s} {'passed':>8s} {'coll':>5s} {'lat rms':>8s} {'lat max':>8s} "
        f"{'head rms':>9s} {'min clr':>8s} {'short':>6s} {'t med':>7s} {'fell back':>9s}"
    )
    lines = [head]

    def f(v: Any, fmt: str) -> str:
        return "-" if v is None else format(v, fmt)

    for name, row in result["rows"].items():
        s = row["summary"]
        lines.append(
            f"{name:27s} {s['passed']:>4d}/{s['runs']:<3d} {s['collisions']:>5d} "
            f"{f(s['lateral_rms_m'], '8.3f')} {f(s['lateral_max_m'], '8.3f')} "
            f"{f(s['heading_rms_deg'], '9.2f')} {f(s['min_clearance_m'], '8.3f')} "
            f"{s['clearance_short']:>6d} {f(s['median_time_s'], '7.1f')} "
            f"{s.get('fell_back', 0):>9d}"
        )
    return "\n".join(lines)


def main(argv: list[str] | None = None, out: TextIO = sys.stdout) -> int:
    p = argparse.ArgumentParser(prog="wheelnav bench doors", description=__doc__.splitlines()[0])
    p.add_argument("--starts", type=int, default=20, help="starts per width and kind")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--widths", type=float, nargs="+", default=list(WIDTHS))
    p.add_argument("--kinds", nargs="+", choices=KINDS, default=list(KINDS))
    p.add_argument(
        "--procedures",
        nargs="+",
        choices=PROCEDURES,
        default=list(PROCEDURES),
        help="door procedures, each run from the same starts (navigator.door_procedure)",
    )
    p.add_argument(
        "--map-off-m",
        type=float,
        default=0.0,
        help="the mapped door at most this far along its wall from the real one (0.1: the issue)",
    )
    p.add_argument("--json", type=Path, help="write the runs and the table's figures here")
    p.add_argument("--keep", type=Path, help="keep every run's site and scenario in this folder")
    add_override_argument(p)
    args = p.parse_args(argv)
    if args.starts < 1:
        p.error("--starts: must be at least 1")
    off_grid = [w for w in args.widths if abs(w / CELL_M - round(w / CELL_M)) > 1e-6]
    if off_grid:
        p.error(f"--widths: {off_grid} not a multiple of the map's {CELL_M} m cells")
    if not 0.0 <= args.map_off_m <= 1.0:
        p.error("--map-off-m: must be between 0 and 1 m")
    try:
        check_overrides(args.overrides)
    except (ConfigError, ValueError) as e:
        p.error(f"--set: {e}")
    result = run_bench(
        args.starts,
        args.seed,
        tuple(args.widths),
        tuple(args.kinds),
        sys.stderr,
        tuple(args.procedures),
        args.map_off_m,
        args.keep.resolve() if args.keep else None,
        tuple(args.overrides),
    )
    print(format_table(result), file=out)
    if args.json:
        args.json.write_text(json.dumps(result, indent=1))
    return 0
