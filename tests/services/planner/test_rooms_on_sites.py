"""Room segmentation on every bundled floor: every doorway found, no false one."""

from __future__ import annotations

import math

import pytest

from services.planner.room_segmentation import segment_rooms
from shared.site import load_site
from tests.conftest import ROOT

FLOORS = [
    ("two_rooms", "1"),
    ("two_floors", "1"),
    ("two_floors", "2"),
    ("seed_floor", "4"),
    ("seed_floor", "5"),
    ("two_ways", "1"),
]


@pytest.mark.parametrize(("name", "floor"), FLOORS)
def test_every_declared_doorway_found_and_no_false_one(name: str, floor: str) -> None:
    site = load_site(ROOT / "sites" / name)
    grid = site.floor(floor).map
    rooms = segment_rooms(grid.occupied(True), grid.resolution, (grid.origin[0], grid.origin[1]))
    declared = {
        d.id: ((d.p1[0] + d.p2[0]) / 2, (d.p1[1] + d.p2[1]) / 2, math.dist(d.p1, d.p2))
        for d in site.doors
        if d.floor == floor
    }
    declared |= {
        e.id: (*e.door_centre(floor), math.dist(*e.door(floor)))
        for e in site.elevators
        if floor in e.floors
    }
    matched = set()
    for doorway in rooms.doorways:
        near = [
            k
            for k, (x, y, _w) in declared.items()
            if math.hypot(doorway.centre[0] - x, doorway.centre[1] - y) < 0.3
        ]
        assert near, f"false doorway at {doorway.centre} on {name} floor {floor}"
        assert doorway.width == pytest.approx(declared[near[0]][2], abs=0.15)
        matched.add(near[0])
    assert matched == set(declared), f"missed: {set(declared) - matched}"


def test_room_graph_carries_declared_ids_and_lifts() -> None:
    from services.planner.room_graph import room_graph

    site = load_site(ROOT / "sites" / "two_floors")
    graph, rooms = room_graph(site, "1")
    doors = {d["door"] for _a, _b, d in graph.edges(data=True) if d["kind"] == "door"}
    assert doors == {d.id for d in site.doors if d.floor == "1"}
    cars = {data["lift"]: n for n, data in graph.nodes(data=True) if "lift" in data}
    assert sorted(cars) == ["lift_a", "lift_b"]
    corridor = rooms.room_at(20.0, 9.25)
    for lift, car in cars.items():
        assert graph.edges[corridor, car]["kind"] == "elevator"
        assert graph.edges[corridor, car]["door"] == lift
    assert nx_path_through(graph, rooms.room_at(5.0, 4.0), cars["lift_a"])


def nx_path_through(graph, a, b) -> bool:
    import networkx as nx

    return nx.has_path(graph, a, b)
