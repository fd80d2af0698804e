"""A floor's rooms and the doors between them, from the room graph of the segmentation.

Rooms and door names come from :func:`services.planner.room_graph.room_graph` (declared
doors and lifts keep their ids, other doorways are ``doorway_<n>``). Its graph holds one
edge per pair of rooms, so a second doorway between the same two rooms is listed here
from the segmentation's doorways. Each door's normal points from its first room into its
second (rooms in increasing id order).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from services.planner.room_graph import room_graph
from services.planner.room_segmentation import RoomMap
from services.planner.routes import corridor_rooms
from shared.site import GridMap, Site

Point = tuple[float, float]
MATCH_M = 0.3  # a doorway this near a listed door's centre is that door


@dataclass
class Room:
    """A segmented room: its label in the segmentation, what it is, where and how big."""

    id: int
    kind: str  # room, corridor or lift
    centroid: Point
    inside: Point  # the point farthest from obstacles, always in the room
    area_m2: float
    lift: str = ""


@dataclass
class DoorInfo:
    """A door between two rooms: its opening (p1 to p2), width and unit normal."""

    id: str
    kind: str  # door or elevator
    type: str  # the declared door's type, "" for a detected doorway
    center: Point
    width_m: float
    normal: Point
    p1: Point
    p2: Point
    rooms: tuple[int, int]


@dataclass
class FloorRooms:
    """The rooms and doors of one floor, with the segmentation (for pictures)."""

    floor: str
    rooms: list[Room]
    doors: list[DoorInfo]
    room_map: RoomMap
    grid: GridMap


def floor_rooms(site: Site, floor: str) -> FloorRooms:
    """Rooms and doors of ``floor`` ("" = the first); SiteError for an unknown floor."""
    floor = site.floor(floor).name
    grid = site.floor(floor).map
    graph, rm = room_graph(site, floor)
    corridors = corridor_rooms(rm)
    rooms = [
        Room(
            int(room),
            "lift" if data.get("lift") else ("corridor" if room in corridors else "room"),
            _point(data["centroid"]),
            _point(data["inside"]),
            float(data["area_m2"]),
            data.get("lift", ""),
        )
        for room, data in sorted(graph.nodes(data=True))
    ]
    doors = [_edge_door(site, floor, rm, a, b, data) for a, b, data in graph.edges(data=True)]
    for i, dw in enumerate(rm.doorways):
        if all(math.dist(dw.centre, d.center) > MATCH_M for d in doors):
            a, b = sorted((dw.room_a, dw.room_b))
            doors.append(
                DoorInfo(
                    f"doorway_{i}",
                    "door",
                    "",
                    _point(dw.centre),
                    float(dw.width),
                    _point(dw.normal),
                    _point(dw.p1),
                    _point(dw.p2),
                    (a, b),
                )
            )
    doors.sort(key=lambda d: (d.rooms, d.id))
    return FloorRooms(floor, rooms, doors, rm, grid)


def _edge_door(site: Site, floor: str, rm: RoomMap, a: int, b: int, data: dict) -> DoorInfo:
    """The door of a room-graph edge, its segment from the site (declared door or lift car
    door) or from the segmentation (a detected doorway)."""
    name = data["door"]
    a, b = sorted((int(a), int(b)))
    declared = {d.id: (d.p1, d.p2) for d in site.doors if d.floor == floor}
    declared |= {e.id: e.door(floor) for e in site.elevators if e.serves(floor)}
    if name in declared:
        p1, p2 = (np.asarray(p, float) for p in declared[name])
        centre = (p1 + p2) / 2
        along = p2 - p1
        normal = np.array([-along[1], along[0]]) / max(float(np.linalg.norm(along)), 1e-9)
        normal = normal * _side(rm, centre, normal, a, b)
    else:
        dw = rm.doorways[int(name.removeprefix("doorway_"))]
        p1, p2 = np.asarray(dw.p1), np.asarray(dw.p2)
        centre, normal = np.asarray(dw.centre), np.asarray(dw.normal)
        if (dw.room_a, dw.room_b) != (a, b):
            normal = -normal
    return DoorInfo(
        name,
        data["kind"],
        data["type"],
        _point(centre),
        float(data["width"]),
        _point(normal),
        _point(p1),
        _point(p2),
        (a, b),
    )


def _side(rm: RoomMap, centre: np.ndarray, normal: np.ndarray, a: int, b: int) -> int:
    """+1 if ``normal`` points from room ``a`` into room ``b`` at ``centre``, else -1."""
    for d in (0.3, 0.5, 0.8, 1.2):
        ahead = rm.room_at(*(centre + d * normal))
        behind = rm.room_at(*(centre - d * normal))
        if ahead == b or behind == a:
            return 1
        if ahead == a or behind == b:
            return -1
    ca = np.asarray(rm.graph.nodes[a]["centroid"], float)
    cb = np.asarray(rm.graph.nodes[b]["centroid"], float)
    return 1 if float(np.dot(cb - ca, normal)) >= 0 else -1


def _point(p) -> Point:
    return float(p[0]), float(p[1])
