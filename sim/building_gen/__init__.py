"""A seeded random building generator: whole multi-floor sites plus missions to run on them.

``generate_building(seed, folder)`` draws a site (1-3 floors of corridors, rooms, suites,
halls, furniture and lifts, each floor its own layout) in the site format, and a list of
missions whose expected outcome follows from how the building was built, written as
scenarios under ``folder/missions``. Everything comes from one
``numpy.random.default_rng(seed)``: the same seed gives byte-identical files. The point
is geometry nobody tuned the navigation stack for. With ``GenOptions.world_differs`` it
also draws the world the simulator builds apart from the map the stack is given
(``folder/world``, :mod:`sim.building_gen.world`), which the missions name as their
``world_site``; the people standing in it that no map shows are in the missions'
``sim.pedestrians`` (those on the floors each mission uses).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np
import yaml

from sim.building_gen.draw import MARGIN, extent, write_site
from sim.building_gen.layout import FloorBuilder
from sim.building_gen.lobby import make_lobby
from sim.building_gen.missions import MissionPlanner, MissionSpec, write_missions
from sim.building_gen.options import MISSION_KINDS, GenOptions
from sim.building_gen.plan import BuildingPlan
from sim.building_gen.topology import Topology
from sim.building_gen.world import WORLD_FOLDER, WorldDiff, draw_world

__all__ = [
    "MISSION_KINDS",
    "GenOptions",
    "GeneratedBuilding",
    "MissionSpec",
    "WorldDiff",
    "generate_building",
]

FLOOR_HEIGHT_M = 4.0


@dataclass
class GeneratedBuilding:
    """What :func:`generate_building` wrote: the site, its scenarios, and what is in it."""

    seed: int
    site_path: Path  # the site folder (holds site.yaml and the floor maps)
    scenarios: list[Path]
    missions: list[MissionSpec]
    geometry: dict
    plan: BuildingPlan = field(repr=False)
    topology: Topology = field(repr=False)
    world: WorldDiff | None = None  # what the world differs in (GenOptions.world_differs)

    @property
    def world_path(self) -> Path | None:
        """The world's site folder, None where the world is the map."""
        return self.site_path / WORLD_FOLDER if self.world is not None else None

    def summary(self) -> str:
        """One line: seed, floors, counts and the missions' kinds (and what the world adds)."""
        g = self.geometry
        kinds = ",".join(m.kind + ("!" if m.expect == "failure" else "") for m in self.missions)
        world = f"; {self.world.summary()}" if self.world is not None else ""
        return (
            f"seed {self.seed}: {g['floors']} floor(s), {len(g['door_widths_m'])} doors, "
            f"{len(g['room_sizes_m2'])} rooms, {len(g['hall_sizes_m2'])} halls, "
            f"{g['doors_in_series']} series, {len(g['lift_headings_deg'])} lifts, "
            f"{g['places']} places; missions {kinds}{world}"
        )


def generate_building(
    seed: int, folder: Path, options: GenOptions | None = None
) -> GeneratedBuilding:
    """Draw the building of ``seed`` into ``folder`` (site + ``missions/*.yaml``)."""
    opts = options or GenOptions()
    opts.check()
    folder = Path(folder)
    rng = np.random.default_rng(seed)
    count = int(rng.integers(opts.floors[0], opts.floors[1] + 1))
    names = [str(i + 1) for i in range(count)]
    lobby = make_lobby(rng, names) if count > 1 else None
    floors = [
        FloorBuilder(name, FLOOR_HEIGHT_M * i, rng, opts, lobby).build()
        for i, name in enumerate(names)
    ]
    plan = BuildingPlan(f"gen{seed}", floors, lobby.lifts if lobby else [])
    plan.transform(int(rng.integers(4)), 0.0, 0.0)
    x0, y0, _, _ = plan.bounds()
    plan.transform(0, round(MARGIN - x0, 6), round(MARGIN - y0, 6))
    write_site(plan, folder)
    world = _write_world(plan, seed, folder) if opts.world_differs else None
    topology = Topology(plan)
    missions = MissionPlanner(plan, topology, rng).plan_missions(opts, seed)
    if world is not None:
        _meet_the_people(missions, plan, world)
    world_site = f"../{WORLD_FOLDER}" if world is not None else None
    scenarios = write_missions(missions, folder / "missions", world_site=world_site)
    geometry = measure(plan)
    summary = {"seed": seed, "options": _recorded(opts), "geometry": geometry}
    if world is not None:
        geometry["world"] = world.sizes()
        summary["world"] = world.record()
    summary["missions"] = [
        {"name": m.name, "kind": m.kind, "expect": m.expect, "file": p.name}
        for m, p in zip(missions, scenarios, strict=True)
    ]
    (folder / "generated.yaml").write_text(yaml.safe_dump(summary, sort_keys=False, width=100))
    return GeneratedBuilding(seed, folder, scenarios, missions, geometry, plan, topology, world)


def _write_world(plan: BuildingPlan, seed: int, folder: Path) -> WorldDiff:
    """Draw the world apart from ``plan`` into ``folder/world`` on the map's grid."""
    world, diff = draw_world(plan, seed)
    write_site(world, folder / WORLD_FOLDER, extent(plan))
    return diff


def _meet_the_people(missions: list[MissionSpec], plan: BuildingPlan, world: WorldDiff) -> None:
    """Give each mission the world's people on the floors it uses: its start's and its
    goal's (a lift ride goes straight from one to the other; people stand off the shafts)."""
    floor_of = {p.name: p.floor for f in plan.floors for p in f.places}
    for m in missions:
        m.pedestrians = world.pedestrians({m.start["floor"], floor_of[m.goal_place]})


def _recorded(opts: GenOptions) -> dict:
    """The options as generated.yaml records them: ``world_differs`` only when on, so a
    building drawn without it is recorded byte for byte as before the option existed."""
    options = asdict(opts)
    if not opts.world_differs:
        del options["world_differs"]
    return options


def measure(plan: BuildingPlan) -> dict:
    """Sizes for the campaign's histograms: doors, corridors (width; the spine's and the
    branches' length), rooms, halls, lifts."""

    def area(r: tuple[float, float, float, float]) -> float:
        return round((r[2] - r[0]) * (r[3] - r[1]), 2)

    spaces = [s for f in plan.floors for s in f.spaces]
    halls = [s.carve for s in spaces if s.kind == "hall" and s.carve]
    return {
        "floors": len(plan.floors),
        "door_widths_m": [round(d.width, 3) for f in plan.floors for d in f.doors],
        "corridor_widths_m": [w for f in plan.floors for w in f.corridor_widths],
        "corridor_lengths_m": [
            round(max(s.carve[2] - s.carve[0], s.carve[3] - s.carve[1]), 2)
            for s in spaces
            if s.kind in ("spine", "branch") and s.carve
        ],
        "room_sizes_m2": [area(s.carve) for s in spaces if s.kind in ("room", "inner") and s.carve],
        "doors_in_series": sum(len(f.series) for f in plan.floors),
        "series_gaps_m": [gap for f in plan.floors for _, _, gap in f.series],
        "hall_sizes_m2": [area(h) for h in halls],
        "hall_sides_m": [[round(h[2] - h[0], 2), round(h[3] - h[1], 2)] for h in halls],
        "lift_headings_deg": [round(math.degrees(x.theta)) % 360 for x in plan.lifts],
        "places": sum(len(f.places) for f in plan.floors),
        "furniture": sum(len(f.furniture) for f in plan.floors),
        "columns": sum(len(f.columns) for f in plan.floors),
    }
