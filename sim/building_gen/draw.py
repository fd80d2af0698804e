"""Draw a building plan: one map_server map per floor and the site.yaml describing it.

Each floor starts solid; the plan's carved rectangles are cut out and its columns and
furniture drawn back in, on the 0.05 m grid, with the origin at (0, 0) for every floor
(so lift cars line up). Doors carry the site keys ``motion``, ``swing`` (hinged doors)
and ``controller``.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import yaml

from sim.building_gen.geometry import RES
from sim.building_gen.plan import BuildingPlan, FloorPlan
from sim.sitegen import draw, write_map

MARGIN = 1.0  # solid border around the building (metres)


def extent(plan: BuildingPlan) -> tuple[float, float]:
    """Map size: the plan's bounds plus the margin, on the grid."""
    _, _, x1, y1 = plan.bounds()
    return (
        round(math.ceil((x1 + MARGIN) / RES - 1e-9) * RES, 6),
        round(math.ceil((y1 + MARGIN) / RES - 1e-9) * RES, 6),
    )


def occupancy(floor: FloorPlan, size: tuple[float, float]) -> np.ndarray:
    """The floor's bool grid (True = occupied), row 0 at the bottom."""
    occ = draw(size, [(0.0, 0.0, *size)], floor.carves, RES)
    return occ | draw(size, floor.columns + floor.furniture, (), RES)


def _pt(p: tuple[float, float]) -> list[float]:
    return [round(p[0], 3), round(p[1], 3)]


def site_dict(plan: BuildingPlan) -> dict:
    """The site.yaml content of ``plan`` (maps named ``floor<name>.yaml``)."""
    doors = []
    for floor in plan.floors:
        for d in floor.doors:
            entry = {
                "id": d.id,
                "floor": d.floor,
                "p1": _pt(d.p1),
                "p2": _pt(d.p2),
                "type": d.type,
                "motion": d.motion,
            }
            if d.motion == "hinged":
                entry["swing"] = d.swing
            entry["controller"] = d.controller
            doors.append(entry)
    places = {
        p.name: {"floor": p.floor, "x": round(p.x, 3), "y": round(p.y, 3), "theta": p.theta}
        for f in plan.floors
        for p in f.places
    }
    lifts = []
    for lift in plan.lifts:
        p1, p2 = lift.door_segment()
        lifts.append(
            {
                "id": lift.id,
                "floors": list(lift.floors),
                "car": {
                    "x": round(lift.x, 3),
                    "y": round(lift.y, 3),
                    "theta": round(lift.theta, 6),
                    "width": lift.width,
                    "depth": lift.depth,
                },
                "doors": {f: {"p1": _pt(p1), "p2": _pt(p2)} for f in lift.floors},
            }
        )
    site = {
        "name": plan.name,
        "floors": [
            {"name": f.name, "elevation": f.elevation, "map": f"floor{f.name}.yaml"}
            for f in plan.floors
        ],
        "doors": doors,
        "places": places,
    }
    if lifts:
        site["elevators"] = lifts
    return site


def write_site(plan: BuildingPlan, folder: Path, size: tuple[float, float] | None = None) -> Path:
    """Write every floor's map and ``site.yaml`` into ``folder``; returns the site.yaml path.
    ``size``: the maps' extent (default the plan's), so a world drawn from an altered copy
    of a plan lies on the same grid as the map of the plan."""
    folder.mkdir(parents=True, exist_ok=True)
    size = size or extent(plan)
    for floor in plan.floors:
        write_map(occupancy(floor, size), folder, f"floor{floor.name}", RES, (0.0, 0.0, 0.0))
    path = folder / "site.yaml"
    path.write_text(
        yaml.safe_dump(site_dict(plan), sort_keys=False, default_flow_style=None, width=100)
    )
    return path
