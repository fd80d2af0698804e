"""Elevators in site.yaml and the bundled multi-floor sites: geometry, doors, connectivity."""

from __future__ import annotations

import math
from functools import cache
from pathlib import Path

import numpy as np
import pytest
import yaml
from PIL import Image
from scipy import ndimage

from shared.site import Elevator, GridMap, Site, SiteError, load_site
from tests.conftest import ROOT

INFLATION_M = 0.375  # chair half width 0.325 + margin
SITES = ("seed_floor", "two_floors", "two_ways")


@cache
def site(name: str) -> Site:
    return load_site(ROOT / "sites" / name)


@cache
def components(name: str, floor: str) -> np.ndarray:
    """Labels of the free space a 0.375 m inflated chair can reach on ``floor``."""
    grid = site(name).floor(floor).map
    clear = ndimage.distance_transform_edt(~grid.occupied(), sampling=grid.resolution)
    labels, _ = ndimage.label(clear > INFLATION_M, structure=np.ones((3, 3)))
    return labels


def is_free(grid: GridMap, x: float, y: float) -> bool:
    r, c = grid.to_cell(x, y)
    return grid.contains(r, c) and not grid.occupied()[r, c]


def assert_gap(grid: GridMap, p1: tuple[float, float], p2: tuple[float, float], what: str) -> None:
    """Cells along p1-p2 are free; the cells half a cell beyond either end are occupied."""
    (x1, y1), (x2, y2) = p1, p2
    length = math.hypot(x2 - x1, y2 - y1)
    ux, uy = (x2 - x1) / length, (y2 - y1) / length
    half = grid.resolution / 2
    for s in np.arange(half, length - half / 2, half):
        assert is_free(grid, x1 + ux * s, y1 + uy * s), f"{what}: blocked at {s:.3f} m"
    assert not is_free(grid, x1 - ux * half, y1 - uy * half), f"{what}: open beyond p1"
    assert not is_free(grid, x2 + ux * half, y2 + uy * half), f"{what}: open beyond p2"


def label_at(name: str, floor: str, x: float, y: float) -> int:
    grid = site(name).floor(floor).map
    r, c = grid.to_cell(x, y)
    return int(components(name, floor)[r, c])


@pytest.mark.parametrize("name", SITES)
def test_declared_doors_are_gaps(name: str) -> None:
    s = site(name)
    for door in s.doors:
        assert_gap(s.floor(door.floor).map, door.p1, door.p2, door.id)
        width = math.dist(door.p1, door.p2)
        assert 0.8 - 1e-9 <= width <= 1.5 + 1e-9, door.id
    for lift in s.elevators:
        for floor in lift.floors:
            assert_gap(s.floor(floor).map, *lift.door(floor), f"{lift.id}@{floor}")


def test_two_floors_inventory() -> None:
    s = site("two_floors")
    assert [(f.name, f.elevation) for f in s.floors.values()] == [("1", 0.0), ("2", 4.0)]
    assert len(s.doors) >= 8
    assert {d.type for d in s.doors} == {"manual", "automatic", "powered"}
    assert {e.id for e in s.elevators} == {"lift_a", "lift_b"}
    for lift in s.elevators:
        assert lift.floors == ["1", "2"]
        assert set(lift.doors) == {"1", "2"}
    assert s.place("room_1a").floor == "1"
    assert s.place("room_2b").floor == "2"


def test_seed_floor_matches_the_seed() -> None:
    s = site("seed_floor")
    lift = s.elevator("lift_1")
    assert lift.floors == ["4", "5"]
    assert lift.door_centre("4") == pytest.approx((27.0, 9.5))
    door = next(d for d in s.doors if d.id == "d4_elevator_room")
    assert door.type == "manual"
    assert math.dist(door.p1, door.p2) == pytest.approx(1.5)
    assert np.mean([door.p1, door.p2], axis=0) == pytest.approx((31.1, 6.9))
    grid = s.floor("4").map
    for x, y in ((31.2, 6.0), (31.2, 8.0), (-6.3, -0.8), (84.0, 6.7), (38.8, 13.6)):
        assert is_free(grid, x, y), (x, y)  # the seed's approach points and room corners
    assert label_at("seed_floor", "4", 31.2, 6.0) == label_at("seed_floor", "4", 31.2, 8.0)
    assert {"hallway_west", "hallway_east", "elevator_room"} <= set(s.places)


@pytest.mark.parametrize("name", SITES)
def test_places_and_lifts_connect_on_every_floor(name: str) -> None:
    s = site(name)
    for floor in s.floors:
        grid = s.floor(floor).map
        points = {p.name: (p.x, p.y) for p in s.places.values() if p.floor == floor}
        for lift in s.elevators:
            if lift.serves(floor):
                x, y, theta = lift.entry_pose(floor, 1.0)
                cx, cy = lift.door_centre(floor)
                assert math.cos(theta) * (cx - x) + math.sin(theta) * (cy - y) > 0.99
                assert is_free(grid, x, y)
                points[f"{lift.id} entry"] = (x, y)
                points[f"{lift.id} car"] = lift.inside_pose()[:2]
        labels = {k: label_at(name, floor, x, y) for k, (x, y) in points.items()}
        assert all(labels.values()), f"floor {floor}: not clear of walls: {labels}"
        assert len(set(labels.values())) == 1, f"floor {floor}: split: {labels}"


def test_rooms_are_reached_only_through_their_doors() -> None:
    s = site("two_floors")
    for room, corridor in (("room_1a", "corridor_1_west"), ("room_2b", "corridor_2_east")):
        floor = s.place(room).floor
        grid = s.floor(floor).map
        free = ~grid.occupied()
        for door in s.doors:
            if door.floor == floor:
                for t in np.linspace(0.0, 1.0, 100):
                    x = door.p1[0] + t * (door.p2[0] - door.p1[0])
                    y = door.p1[1] + t * (door.p2[1] - door.p1[1])
                    r, c = grid.to_cell(x, y)
                    free[r - 3 : r + 3, c - 3 : c + 3] = False
        labels, _ = ndimage.label(free)
        a, b = (grid.to_cell(s.place(n).x, s.place(n).y) for n in (room, corridor))
        assert labels[a] and labels[b] and labels[a] != labels[b], room


def test_elevator_poses() -> None:
    lift = Elevator("l", ["1"], 0.0, 0.0, math.pi / 2, 1.6, 2.0, {"1": ((0.6, 1.1), (-0.6, 1.1))})
    assert lift.door_centre("1") == pytest.approx((0.0, 1.1))
    assert lift.entry_pose("1", 1.0) == pytest.approx((0.0, 2.1, -math.pi / 2))
    assert lift.inside_pose() == (0.0, 0.0, math.pi / 2)
    with pytest.raises(SiteError, match="does not serve floor '2'"):
        lift.door_centre("2")
    assert site("two_floors").elevator("lift_b").entry_pose("2", 0.8)[2] == pytest.approx(
        math.pi / 2
    )
    with pytest.raises(SiteError, match="no elevator 'lift_z'"):
        site("two_floors").elevator("lift_z")


GOOD_LIFT = {
    "id": "lift_a",
    "floors": ["1", "2"],
    "car": {"x": 1.0, "y": 1.0, "theta": 0.0, "width": 0.8, "depth": 1.0},
    "doors": {"1": {"p1": [1.6, 0.6], "p2": [1.6, 1.4]}, "2": {"p1": [1.6, 0.6], "p2": [1.6, 1.4]}},
}


def write_site(folder: Path, elevators: list, doors: list | None = None) -> Path:
    Image.fromarray(np.full((20, 20), 254, np.uint8)).save(folder / "m.pgm")
    (folder / "m.yaml").write_text("image: m.pgm\nresolution: 0.1\norigin: [0, 0, 0]\n")
    data = {
        "name": "tiny",
        "floors": [
            {"name": "1", "map": "m.yaml"},
            {"name": "2", "elevation": 4.0, "map": "m.yaml"},
        ],
        "doors": doors or [],
        "elevators": elevators,
    }
    (folder / "site.yaml").write_text(yaml.safe_dump(data))
    return folder


def variant(**changes) -> dict:
    lift = yaml.safe_load(yaml.safe_dump(GOOD_LIFT))
    for key, value in changes.items():
        target, leaf = lift, key.split("__")
        for part in leaf[:-1]:
            target = target[part]
        if value is None:
            del target[leaf[-1]]
        else:
            target[leaf[-1]] = value
    return lift


def test_good_tiny_site(tmp_path: Path) -> None:
    s = load_site(write_site(tmp_path, [GOOD_LIFT]))
    lift = s.elevator("lift_a")
    assert lift.floors == ["1", "2"] and lift.width == 0.8
    assert lift.entry_pose("2", 0.5) == pytest.approx((2.1, 1.0, math.pi))
    assert load_site(ROOT / "sites" / "two_rooms").elevators == []


@pytest.mark.parametrize(
    ("lifts", "message"),
    [
        ([variant(speed=2.0)], r"elevators\[0\]: unknown key 'speed'"),
        ([variant(car__colour="red")], r"elevators\[0\]\.car: unknown key 'colour'"),
        ([variant(doors__1__hinge=1)], r"elevators\[0\]\.doors\.1: unknown key 'hinge'"),
        ([variant(floors=["1", "3"])], r"elevators\[0\]\.floors: no floor '3'"),
        ([variant(floors=["1"])], r"elevators\[0\]\.doors\.2: elevator lift_a does not serve"),
        ([variant(doors__2=None)], r"elevators\[0\]\.doors: no door for served floor '2'"),
        ([variant(car__width=0.0)], r"elevators\[0\]\.car\.width: must be > 0"),
        ([variant(car__depth=-1.0)], r"elevators\[0\]\.car\.depth: must be > 0"),
        ([variant(car__x="left")], r"elevators\[0\]\.car\.x: expected a number"),
        ([variant(car__y=None)], r"elevators\[0\]\.car: missing key 'y'"),
        ([variant(id=None)], r"elevators\[0\]: missing key 'id'"),
        ([variant(floors=[])], r"elevators\[0\]\.floors: expected a non-empty list"),
        ([variant(doors__1__p2=[1.6])], r"elevators\[0\]\.doors\.1\.p2: expected \[x, y\]"),
        ([variant(doors__1__p2=[1.6, 0.6])], r"elevators\[0\]\.doors\.1: p1 and p2 are the same"),
        ([GOOD_LIFT, GOOD_LIFT], r"elevators\[1\]\.id: duplicate elevator id 'lift_a'"),
    ],
)
def test_bad_elevators(tmp_path: Path, lifts: list, message: str) -> None:
    with pytest.raises(SiteError, match=message) as err:
        load_site(write_site(tmp_path, lifts))
    text = str(err.value)
    assert "\n" not in text and str(tmp_path / "site.yaml") in text


def test_duplicate_door_ids(tmp_path: Path) -> None:
    door = {"id": "d1", "floor": "1", "p1": [0.5, 0.5], "p2": [0.5, 1.5]}
    with pytest.raises(SiteError, match=r"doors\[1\]\.id: duplicate door id 'd1'") as err:
        load_site(write_site(tmp_path, [], [door, door]))
    assert "\n" not in str(err.value)
