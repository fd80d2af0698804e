"""The world a generated building's simulator builds apart from its map (issue 15, item 2).

With ``GenOptions.world_differs`` the world (``world/``) differs from the map exactly as
generated.yaml records it (doors moved along their wall by at most 0.20 m, furniture added
and removed, one partition moved, people standing), keeps every promise the map keeps
(checked on the written files as tests/sim/test_building_gen.py checks maps, the people
drawn in), and the missions name it as their ``world_site`` and give the simulator the
people on their floors. Without the option a building is drawn byte for byte as before.
"""

from __future__ import annotations

import copy
import hashlib
import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from shared.site import Site, load_site
from sim.building_gen import GeneratedBuilding, GenOptions, generate_building
from sim.building_gen.furnish import PLACE_CLEARANCE, fits
from sim.building_gen.geometry import point_rect_dist, rect
from sim.building_gen.world import PEOPLE_PER_FLOOR, PERSON_RADIUS_M, WorldFloor, draw_world
from sim.simulation import Simulation
from tests.sim.test_building_gen import (
    _files,
    check_gaps,
    check_lifts,
    check_outcomes,
    check_places,
    check_turning_discs,
)
from wheelnav.mission.scenario import load_scenario

WORLD_SEEDS = range(10)
MAX_SHIFT_M = 0.20
# every file of building 7 as drawn before the option existed (commit 73da6bf); a change
# that redraws buildings on purpose updates it
# generated.yaml's geometry gained corridor_lengths_m (every other file, and every other
# key, byte for byte as under the digest before it, d6af5346...); furniture keeps its
# passage from open leaves too (b8801.m04), which moves building 7's tables (211a6d09...)
SEED7_DIGEST = "59b86aa58e88b0977c368af76a29a5322abdf8260a85c51de10c580b6f03a130"

World = tuple[GeneratedBuilding, Site, Site, dict]


@pytest.fixture(scope="module")
def worlds(tmp_path_factory) -> list[World]:
    """Buildings drawn with their world: (building, map site, world site, generated.yaml)."""
    root = tmp_path_factory.mktemp("worlds")
    out = []
    for seed in WORLD_SEEDS:
        b = generate_building(seed, root / f"b{seed}", GenOptions(world_differs=True))
        record = yaml.safe_load((b.site_path / "generated.yaml").read_text())
        out.append((b, load_site(b.site_path), load_site(b.world_path), record))
    return out


# ---- helpers -------------------------------------------------------------------------


def _digest(files: dict[str, bytes]) -> str:
    h = hashlib.sha256()
    for name, data in sorted(files.items()):
        h.update(name.encode() + b"\0" + data)
    return h.hexdigest()


def _cells(r: list[float], res: float) -> tuple[slice, slice]:
    """The grid cells a rectangle on the grid covers (as sim.sitegen.draw fills them)."""
    return slice(round(r[1] / res), round(r[3] / res)), slice(round(r[0] / res), round(r[2] / res))


def _gap(door: dict) -> list[float]:
    """A door's opening through the 0.2 m wall, from its segment."""
    (x1, y1), (x2, y2) = door["p1"], door["p2"]
    if abs(y1 - y2) < 1e-9:
        return [min(x1, x2), y1 - 0.1, max(x1, x2), y1 + 0.1]
    return [x1 - 0.1, min(y1, y2), x1 + 0.1, max(y1, y2)]


def _site_yaml(folder: Path) -> dict:
    return yaml.safe_load((folder / "site.yaml").read_text())


def _people_drawn_in(site: Site, people: list[dict]) -> Site:
    """A copy of ``site`` with every cell a person's disc touches made wall (as if they
    were furniture)."""
    site = copy.deepcopy(site)
    for p in people:
        grid = site.floor(p["floor"]).map
        res, r = grid.resolution, p["radius_m"]
        rows, cols = np.mgrid[0 : grid.shape[0], 0 : grid.shape[1]]
        dx = np.maximum(0.0, np.maximum(cols * res - p["x"], p["x"] - (cols + 1) * res))
        dy = np.maximum(0.0, np.maximum(rows * res - p["y"], p["y"] - (rows + 1) * res))
        grid.cells[np.hypot(dx, dy) < r - 1e-9] = 100
    return site


def _pedestrians(data: dict) -> list[dict]:
    """A mission file's ``config.sim.pedestrians`` (none: [])."""
    return ((data.get("config") or {}).get("sim") or {}).get("pedestrians", [])


def _without_people(data: dict) -> dict:
    """A mission file's content without its ``config.sim.pedestrians`` (and what empties)."""
    data = copy.deepcopy(data)
    config = data.get("config") or {}
    config.get("sim", {}).pop("pedestrians", None)
    if config.get("sim") == {}:
        del config["sim"]
    if config == {}:
        data.pop("config", None)
    return data


def _without_world(data: dict) -> dict:
    """generated.yaml as the option off would write it."""
    data = {k: v for k, v in data.items() if k != "world"}
    data["options"] = {k: v for k, v in data["options"].items() if k != "world_differs"}
    data["geometry"] = {k: v for k, v in data["geometry"].items() if k != "world"}
    return data


def _check_doors_moved(label: str, map_raw: dict, world_raw: dict, moved: dict) -> None:
    """Same doors; the recorded ones moved along p1 -> p2 by their offset (<= 0.20 m, on
    the 5 cm grid), every other key and every other door as the map has it."""
    assert [d["id"] for d in map_raw["doors"]] == [d["id"] for d in world_raw["doors"]], label
    for old, new in zip(map_raw["doors"], world_raw["doors"], strict=True):
        offset = moved.get(old["id"], 0.0)
        assert abs(offset) <= MAX_SHIFT_M + 1e-9, (label, old["id"], offset)
        assert abs(offset / 0.05 - round(offset / 0.05)) < 1e-6, (label, old["id"], offset)
        u = np.subtract(old["p2"], old["p1"]) / math.dist(old["p1"], old["p2"])
        for key in ("p1", "p2"):
            assert np.allclose(np.add(old[key], u * offset), new[key], atol=1e-6), (label, key)
        rest = {k: v for k, v in old.items() if k not in ("p1", "p2")}
        assert rest == {k: v for k, v in new.items() if k not in ("p1", "p2")}, label


def _mask(shape: tuple[int, int], rects: list[list[float]], res: float) -> np.ndarray:
    out = np.zeros(shape, dtype=bool)
    for r in rects:
        out[_cells(r, res)] = True
    return out


def _on(changes: list[dict], floor: str, field: str) -> list:
    """``field`` of the recorded changes on ``floor``."""
    return [c[field] for c in changes if c["floor"] == floor]


def _check_rasters(label: str, world: dict, plan: Site, real: Site, raw: tuple[dict, dict]) -> None:
    """Every cell that differs between a map and its world lies in a recorded change, and
    every recorded change shows: furniture, the moved wall's strips, the doors' openings."""
    gaps = [{d["id"]: _gap(d) for d in site["doors"]} for site in raw]
    for floor in plan.floors:
        occ_map, occ_world = plan.floor(floor).map.occupied(), real.floor(floor).map.occupied()
        shape, res = occ_map.shape, plan.floor(floor).map.resolution
        added = _mask(shape, _on(world["furniture_added"], floor, "rect"), res)
        removed = _mask(shape, _on(world["furniture_removed"], floor, "rect"), res)
        freed = _mask(shape, _on(world["walls_moved"], floor, "freed"), res)
        walled = _mask(shape, _on(world["walls_moved"], floor, "walled"), res)
        moved = _on(world["doors_moved"], floor, "id")
        old_gaps = _mask(shape, [gaps[0][d] for d in moved], res)
        new_gaps = _mask(shape, [gaps[1][d] for d in moved], res)
        assert occ_world[added].all() and not (occ_map & added & ~removed).any(), label
        assert occ_map[removed].all() and not (occ_world & removed & ~added).any(), label
        assert occ_map[freed].all() and not occ_world[freed].any(), label
        assert occ_world[walled].all() and not occ_map[walled].any(), label
        assert not occ_map[old_gaps].any() and not occ_world[new_gaps].any(), label
        explained = added | removed | freed | walled | old_gaps | new_gaps
        differs = occ_map != occ_world
        assert not (differs & ~explained).any(), f"{label}: floor {floor} differs unrecorded"


# ---- without the option --------------------------------------------------------------


def test_without_the_option_a_building_is_drawn_as_before(tmp_path: Path) -> None:
    files = _files(generate_building(7, tmp_path / "b7").site_path)
    assert _digest(files) == SEED7_DIGEST
    assert not any(name.startswith("world") for name in files)
    assert b"world" not in files["generated.yaml"]


def test_the_option_adds_a_world_and_changes_nothing_else(worlds, tmp_path: Path) -> None:
    b, _, _, record = worlds[0]
    plain = generate_building(b.seed, tmp_path / "plain")
    on, off = _files(b.site_path), _files(plain.site_path)
    assert {k for k in on if not k.startswith("world/")} == set(off)
    assert all(on[k] == off[k] for k in off if not k.startswith(("missions/", "generated")))
    for name in (k for k in off if k.startswith("missions/")):
        data = yaml.safe_load(on[name])
        assert data.pop("world_site") == "../world"
        assert not _pedestrians(yaml.safe_load(off[name])), name
        assert _without_people(data) == yaml.safe_load(off[name]), name
    assert _without_world(record) == yaml.safe_load(off["generated.yaml"])
    assert record["options"]["world_differs"] is True


# ---- the world -----------------------------------------------------------------------


def test_the_world_differs_from_the_map_as_recorded(worlds) -> None:
    walls = removed = people = 0
    for b, site, real, record in worlds:
        label = f"seed {b.seed}"
        world = record["world"]
        assert world["site"] == "world" and b.world_path == b.site_path / "world"
        map_raw, world_raw = _site_yaml(b.site_path), _site_yaml(b.world_path)
        for key in ("name", "floors", "places", "elevators"):
            assert map_raw.get(key) == world_raw.get(key), (label, key)
        moved = {d["id"]: d["offset_m"] for d in world["doors_moved"]}
        assert moved and all(moved.values()), label
        _check_doors_moved(label, map_raw, world_raw, moved)
        _check_rasters(label, world, site, real, (map_raw, world_raw))
        assert world["furniture_added"], label
        for w in world["walls_moved"]:
            assert 0 < w["shift_m"] <= MAX_SHIFT_M + 1e-9 and w["length_m"] >= 1.0, (label, w)
        sizes = record["geometry"]["world"]
        assert sizes["doors_moved_m"] == [abs(v) for v in moved.values()], label
        assert sizes["walls_moved_m"] == [w["shift_m"] for w in world["walls_moved"]], label
        assert len(sizes["furniture_added_m2"]) == len(world["furniture_added"]), label
        assert len(world["walls_moved"]) <= 1, label
        assert sizes["people_radius_m"] == [p["radius_m"] for p in world["people"]], label
        assert len(world["people"]) <= PEOPLE_PER_FLOOR[1] * len(site.floors), label
        walls += len(world["walls_moved"])
        removed += len(world["furniture_removed"])
        people += len(world["people"])
    assert walls >= len(worlds) - 1 and removed > 0 and people >= len(worlds)


def test_the_world_keeps_the_promises_of_the_map(worlds) -> None:
    """Turning discs and straight approaches at every door, solid jambs and pockets, clear
    places and landings, and every mission's expected outcome, on the world's files with
    its people drawn in as if they were furniture."""
    for b, _, world, record in worlds:
        label = f"seed {b.seed} (world)"
        world = _people_drawn_in(world, record["world"]["people"])
        check_turning_discs(label, b.world_path, world)
        check_gaps(label, b.world_path, world)
        check_places(label, b.world_path, world)
        check_lifts(label, world)
        check_outcomes(label, b.scenarios, world)


def _jamb_faces_free(site: Site, door) -> list[bool]:
    """Per jamb (the 0.1 m of wall beyond each end of the opening) and per side of the
    wall: whether the floor just off the wall's face beside it is free on the raster."""
    grid = site.floor(door.floor).map
    occ = grid.occupied(True)
    p1 = np.array(door.p1, dtype=float)
    u = (np.array(door.p2) - p1) / door.width_m
    n = np.array([-u[1], u[0]])
    out = []
    for a, b in ((-0.1, 0.0), (door.width_m, door.width_m + 0.1)):
        for side in (1.0, -1.0):
            points = [p1 + u * t + n * side * 0.125 for t in np.linspace(a + 0.02, b - 0.02, 4)]
            cells = [
                (
                    int((y - grid.origin[1]) / grid.resolution),
                    int((x - grid.origin[0]) / grid.resolution),
                )
                for x, y in points
            ]
            out.append(not any(occ[r, c] for r, c in cells))
    return out


def test_a_door_keeps_wall_beside_its_jambs_in_the_world(worlds) -> None:
    """World-differs campaign b7104w.m00: an 0.80 m door moved 0.10 m along its wall ended
    flush with the side wall of the room before it, its jamb now that wall's end: a door
    the generator never draws (it leaves 0.1 m of the same wall beside an opening, free
    floor before it), whose approach runs 7.5 cm off a wall. Where the map has free floor
    beside a door's jamb, so has the world."""
    for b, plan, world, _ in worlds:
        for old, new in zip(plan.doors, world.doors, strict=True):
            before, after = _jamb_faces_free(plan, old), _jamb_faces_free(world, new)
            lost = [i for i, (x, y) in enumerate(zip(before, after, strict=True)) if x and not y]
            assert not lost, f"seed {b.seed}: {new.id} has a jamb in a corner ({lost})"


def test_missions_load_with_their_world(worlds) -> None:
    """The scenario loader gives the stack the map and the simulator the world."""
    for b, site, _, _ in worlds[:3]:
        for path in b.scenarios:
            data = yaml.safe_load(path.read_text())
            assert data["world_site"] == "../world"
            scenario = load_scenario(path)
            assert scenario.kind == data["kind"] and scenario.expect == data["expect"]
            assert Path(scenario.config.site) == b.site_path.resolve()
            assert Path(scenario.config.sim.world_site) == b.world_path.resolve()
            world = load_site(scenario.config.sim.world_site)
            assert [d.id for d in world.doors] == [d.id for d in site.doors]
            assert scenario.place in world.places


# ---- the people ----------------------------------------------------------------------


def test_people_stand_off_every_door_rule_and_place_clearance(worlds) -> None:
    """Each person's disc (and its bounding square) lies in a furnished space's free part,
    off every keep-out the world's doors, openings, lifts and places hold (the generator's
    own turning discs, straight approaches, leaves and sweeps), and a place's clearance
    plus its radius from every place; the world drawn again draws the same people."""
    for b, _, _, record in worlds:
        label = f"seed {b.seed}"
        people = record["world"]["people"]
        plan, diff = draw_world(b.plan, b.seed)
        assert diff.people == people, label
        for floor in plan.floors:
            here = [p for p in people if p["floor"] == floor.name]
            wf = WorldFloor(floor, plan.lifts, np.random.default_rng(0))
            st = wf.state()
            rooms = [s.carve for s in floor.spaces if s.kind in ("room", "inner", "hall")]
            for p in here:
                r = p["radius_m"]
                assert r == PERSON_RADIUS_M, label
                box = rect(p["x"] - r, p["y"] - r, p["x"] + r, p["y"] + r)
                assert any(
                    c and c[0] <= box[0] and c[1] <= box[1] and box[2] <= c[2] and box[3] <= c[3]
                    for c in rooms
                ), (label, p)
                assert not st.blocked(box, ("zone", "sweep")), (label, p)
                assert any(fits(st, box, c) for c in rooms if c), (label, p)
                for place in floor.places:
                    gap = math.hypot(place.x - p["x"], place.y - p["y"])
                    assert gap >= PLACE_CLEARANCE + r - 1e-6, (label, p, place.name)
                    assert point_rect_dist(place.x, place.y, box) >= PLACE_CLEARANCE - 1e-6


def test_people_are_drawn_the_same_for_the_same_seed(worlds, tmp_path: Path) -> None:
    b, _, _, record = worlds[1]
    again = generate_building(b.seed, tmp_path / "again", GenOptions(world_differs=True))
    assert _files(again.site_path) == _files(b.site_path)
    assert again.world.people == record["world"]["people"]
    other = generate_building(b.seed + 100, tmp_path / "other", GenOptions(world_differs=True))
    assert other.world.people != again.world.people


def test_each_mission_gives_the_simulator_the_people_on_its_floors(worlds) -> None:
    """A mission's ``sim.pedestrians`` are the world's people on its start's and its goal's
    floors, each standing (one waypoint); the scenario loader passes them on."""
    given = 0
    for b, site, _, record in worlds:
        people = record["world"]["people"]
        for path in b.scenarios:
            data = yaml.safe_load(path.read_text())
            floors = {data["start"]["floor"], site.places[data["goal"]["place"]].floor}
            want = [p for p in people if p["floor"] in floors]
            got = _pedestrians(data)
            assert [(p["floor"], p["waypoints"], p["radius"]) for p in got] == [
                (p["floor"], [[p["x"], p["y"]]], p["radius_m"]) for p in want
            ], (b.seed, path.name)
            given += len(got)
        scenario = load_scenario(b.scenarios[0])
        assert [len(p.waypoints) for p in scenario.config.sim.pedestrians] == [1] * len(
            _pedestrians(yaml.safe_load(b.scenarios[0].read_text()))
        )
    assert given > 0


def test_a_person_is_a_body_the_lidar_sees_and_the_map_does_not_show(worlds) -> None:
    """The simulator of a world mission stands each person where generated.yaml says; a
    chair put down facing one sees it at its distance less its radius, where the world's
    own map (and the stack's) is free."""
    b, site, world, _ = worlds[0]
    path, person = next(
        (path, p)
        for path in b.scenarios
        for p in _pedestrians(yaml.safe_load(path.read_text()))
        if p["floor"] == yaml.safe_load(path.read_text())["start"]["floor"]
    )
    cfg = load_scenario(path).config
    sim = Simulation(cfg, world)
    placed = [(round(q.position[0], 6), round(q.position[1], 6)) for q in sim.pedestrians]
    assert placed == [tuple(p.waypoints[0]) for p in cfg.sim.pedestrians]
    (px, py), floor = person["waypoints"][0], person["floor"]
    for m in (site.floor(floor).map, world.floor(floor).map):
        assert not m.occupied()[m.to_cell(px, py)], "a person is in no map"
    x, y, theta, d = _facing(sim, world, floor, px, py)
    pts = sim.lidar.scan(x, y, theta, sim.z)
    pts = pts[np.abs(pts[:, 2]) < 0.3]
    ahead = pts[np.abs(np.arctan2(pts[:, 1], pts[:, 0])) < 0.02]
    assert np.linalg.norm(ahead[:, :2], axis=1).min() == pytest.approx(
        d - person["radius"], abs=0.05
    )


def _facing(sim: Simulation, world: Site, floor: str, px: float, py: float) -> tuple:
    """Put the chair down facing the person at (px, py) from 1-2 m away, with nothing of
    the world's map between them: its pose and distance."""
    grid = world.floor(floor).map
    occ = grid.occupied()
    for d in (1.5, 1.2, 2.0, 1.0):
        for k in range(16):
            a = 2 * math.pi * k / 16
            x, y = px + d * math.cos(a), py + d * math.sin(a)
            line = [(x + (px - x) * t, y + (py - y) * t) for t in np.linspace(0.0, 1.0, 60)]
            cells = [grid.to_cell(*q) for q in line]
            if all(grid.contains(*c) and not occ[c] for c in cells) and sim.kidnap(
                x, y, a + math.pi
            ):
                return x, y, a + math.pi, d
    raise AssertionError(f"no free pose facing the person at ({px}, {py})")
