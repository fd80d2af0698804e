"""``wheelnav campaign``: generated buildings x missions, run one after another.

Each building is drawn by :mod:`sim.building_gen` from its seed (the campaign's seed plus
its index), into ``OUT/buildings/b<seed>/`` with its missions as scenario files; each
mission runs as ``wheelnav mission`` would run it, and its row is stored the moment it
ends, so a stopped campaign resumes where it stopped. The expected outcome of every
mission comes from how its building was built, never from a run. With ``world_differs``
the simulator builds a world that differs from the map the stack is given (doors moved,
furniture added and removed, a wall moved, people standing); those buildings go into
``b<seed>w/``, so their rows never mix with those of the same seed's building drawn
without it. ``--set KEY=VALUE`` overrides a config value in every mission (for example
``navigator.door_procedure=smooth``); a row stored with other overrides is run again.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TextIO

from shared import config as config_mod
from shared.config import FleetConfig
from shared.service import add_override_argument
from wheelnav.campaign.results import ResultStore, clearance_note, judge
from wheelnav.campaign.summary import (
    figures,
    format_failures,
    format_figures,
    format_geometry,
    format_table,
    format_tight,
)
from wheelnav.mission.run import MissionRun
from wheelnav.mission.scenario import load_scenario


@dataclass(frozen=True)
class CampaignSpec:
    """What to run: ``buildings`` buildings from ``seed`` on, ``missions`` missions each."""

    out: Path
    buildings: int = 12
    seed: int = 0
    missions: int = 8
    floors_max: int = 3
    only: tuple[str, ...] = ()  # mission ids (or prefixes) to run; empty: all
    world_differs: bool = False  # the simulator's world differs from the stack's map
    overrides: tuple[str, ...] = ()  # KEY=VALUE config overrides for every mission


def check_overrides(spec: CampaignSpec) -> None:
    """Raise ConfigError naming the key if an override is not a valid config value."""
    config_mod.from_dict(FleetConfig, config_mod.apply_overrides({}, list(spec.overrides)))


def reusable(row: dict[str, Any] | None, spec: CampaignSpec) -> bool:
    """A stored row stands for this campaign if it ran with the same overrides (a row from
    before overrides were recorded ran with none)."""
    return row is not None and list(row.get("overrides", [])) == list(spec.overrides)


def building_folder(spec: CampaignSpec, seed: int) -> Path:
    """Where building ``seed`` is drawn: ``b<seed>``, or ``b<seed>w`` with its world."""
    return spec.out / "buildings" / f"b{seed}{'w' if spec.world_differs else ''}"


def mission_id(building: Path, scenario: Path) -> str:
    """A campaign-wide mission name: the building folder and the scenario file's stem."""
    return f"{building.name}.{scenario.stem}"


def generate(spec: CampaignSpec, err: TextIO = sys.stderr) -> list[dict[str, Any]]:
    """Draw every building (deterministic: the same seed gives the same files)."""
    from sim.building_gen import GenOptions, generate_building  # heavy: only when drawing

    buildings = []
    for i in range(spec.buildings):
        seed = spec.seed + i
        folder = building_folder(spec, seed)
        options = GenOptions(
            missions=spec.missions,
            floors=(1, spec.floors_max),
            world_differs=spec.world_differs,
        )
        built = generate_building(seed, folder, options)
        world = f"; {built.world.summary()}" if built.world is not None else ""
        err.write(
            f"building {folder.name}: {built.geometry.get('floors', 1)} floor(s), "
            f"{len(built.geometry.get('door_widths_m', []))} doors, "
            f"{len(built.scenarios)} missions{world}\n"
        )
        buildings.append({"seed": seed, "folder": folder, "built": built})
    return buildings


def run(spec: CampaignSpec, err: TextIO = sys.stderr, out: TextIO = sys.stdout) -> dict[str, Any]:
    """Generate, run what has not run yet, print the tables; the campaign's JSON document.
    Raises ConfigError, before anything runs, on an override that names no config key."""
    check_overrides(spec)
    buildings = generate(spec, err)
    store = ResultStore(spec.out / "results")
    todo = [
        (b["folder"], path)
        for b in buildings
        for path in b["built"].scenarios
        if not spec.only or any(mission_id(b["folder"], path).startswith(o) for o in spec.only)
    ]
    rows: list[dict[str, Any]] = []
    started = time.monotonic()
    fresh = 0
    for i, (folder, path) in enumerate(todo, 1):
        mid = mission_id(folder, path)
        row = store.get(mid)
        if not reusable(row, spec):
            scenario = load_scenario(path, spec.overrides)
            err.write(f"[{i:3d}/{len(todo)}] {mid} ({scenario.kind or '-'}) ...")
            err.flush()
            report = MissionRun(scenario, quiet=True).run()
            saved = spec.out / "reports" / f"{mid}.json"
            saved.parent.mkdir(parents=True, exist_ok=True)
            saved.write_text(json.dumps(report, indent=1, default=str))
            row = {"id": mid, **judge(scenario, report), "mission": mid, "report": str(saved)}
            row["overrides"] = list(spec.overrides)
            store.put(row)
            fresh += 1
            elapsed = time.monotonic() - started
            eta = (
                elapsed
                / fresh
                * sum(not reusable(store.get(mission_id(f, p)), spec) for f, p in todo)
            )
            err.write(
                f" {row['outcome']} ({'as expected' if row['as_expected'] else 'NOT as expected'}"
                f", {clearance_note(row)}, {row['sim_time_s']:.0f} s sim, "
                f"{report['wall_time_s']:.0f} s wall; "
                f"elapsed {elapsed / 60:.1f} min, about {eta / 60:.0f} min to go)\n"
            )
        else:
            err.write(f"[{i:3d}/{len(todo)}] {mid}: stored ({row['outcome']})\n")
        rows.append(row)
    geometry = [b["built"].geometry for b in buildings]
    result = {
        "spec": {
            "buildings": spec.buildings,
            "seed": spec.seed,
            "missions_per_building": spec.missions,
            "floors_max": spec.floors_max,
            "world_differs": spec.world_differs,
            "overrides": list(spec.overrides),
        },
        "figures": figures(rows, len(todo)),
        "rows": rows,
        "geometry": geometry,
    }
    out.write(format_geometry(geometry) + "\n\n")
    out.write(format_table(rows) + "\n\n")
    out.write(format_figures(result["figures"]) + "\n\n")
    out.write(format_failures(rows) + "\n")
    out.write(format_tight(rows) + "\n")
    (spec.out / "campaign.json").write_text(json.dumps(result, indent=1, default=str))
    return result


def add_commands(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "campaign",
        help="generated buildings x missions, one after another, with a table",
        description=(
            "Draw N seeded buildings (sim/building_gen) with M missions each, run every "
            "mission in lockstep, and print the geometry, a table and the figures. Rows are "
            "stored as they end: run the same command again to resume."
        ),
    )
    p.add_argument("--buildings", type=int, default=12, help="how many buildings (default 12)")
    p.add_argument("--seed", type=int, default=0, help="seed of the first building (default 0)")
    p.add_argument("--missions", type=int, default=8, help="missions per building (default 8)")
    p.add_argument("--floors-max", type=int, default=3, help="most floors a building has")
    p.add_argument("--out", default="campaign", help="folder for buildings, rows and campaign.json")
    p.add_argument("--only", nargs="*", default=[], help="mission ids (or prefixes) to run")
    p.add_argument(
        "--fresh", action="store_true", help="forget stored rows of these missions first"
    )
    p.add_argument(
        "--world-differs",
        action="store_true",
        help="the simulator's world differs from the map: doors moved up to 0.20 m, "
        "furniture added and removed, a wall moved, people standing (buildings b<seed>w)",
    )
    add_override_argument(p)
    p.set_defaults(run=_cli)


def _cli(args: argparse.Namespace) -> int:
    if args.buildings < 1 or args.missions < 1 or args.floors_max < 1:
        print("wheelnav campaign: --buildings, --missions and --floors-max must be >= 1")
        return 2
    spec = CampaignSpec(
        Path(args.out),
        args.buildings,
        args.seed,
        args.missions,
        args.floors_max,
        tuple(args.only),
        args.world_differs,
        tuple(args.overrides),
    )
    check_overrides(spec)  # before --fresh forgets anything
    if args.fresh:
        for path in (spec.out / "results").glob("*.json"):
            if not spec.only or any(path.stem.startswith(o) for o in spec.only):
                path.unlink()
    result = run(spec)
    f = result["figures"]
    return 0 if f["as_expected"] == f["missions_run"] and f["collisions"] == 0 else 1
