"""The rooms and doors of a floor of a site: segmented rooms, joined by named doors and lifts.

The site-level view of a floor's rooms, for people and tools (what a command listing a
site's rooms would print) and for tests of the segmentation on the bundled sites. Routing
does not use it: the route planner runs one A* over the whole floor and makes checkpoints
of the declared doors the path crosses (:mod:`services.planner.routes`), so it never
needs to match a detected doorway to a declared door.

Rooms and doorways come from :func:`services.planner.room_segmentation.segment_rooms`. A
detected doorway within ``match_m`` of a declared door takes that door's id, type and
exact segment; a declared door that was not detected still joins the rooms on either side
of it. A lift car is a room of the map: its node gets ``lift=<id>`` and the edge through
its car door is of kind ``elevator`` (an undetected car door still joins the car to the
room in front of it). Edge attribute ``door``: the door or lift id (``doorway_<n>`` for
undeclared ones); ``kind``: door or elevator; ``type``: the declared door's type (""
otherwise); ``width``.
"""

from __future__ import annotations

import math

import networkx as nx

from services.planner.room_segmentation import RoomMap, segment_rooms
from shared.site import Site


def room_graph(site: Site, floor: str, match_m: float = 0.3) -> tuple[nx.Graph, RoomMap]:
    """The floor's room graph and the segmentation behind it."""
    grid = site.floor(floor).map
    rooms = segment_rooms(grid.occupied(True), grid.resolution, (grid.origin[0], grid.origin[1]))
    graph = nx.Graph()
    for room, data in rooms.graph.nodes(data=True):
        graph.add_node(room, **data)
    declared = [d for d in site.doors if d.floor == floor]
    used: set[str] = set()
    lifts = [e for e in site.elevators if floor in e.floors]
    for i, dw in enumerate(rooms.doorways):
        lift = next(
            (
                e
                for e in lifts
                if e.id not in used
                and math.hypot(
                    dw.centre[0] - e.door_centre(floor)[0], dw.centre[1] - e.door_centre(floor)[1]
                )
                < match_m
            ),
            None,
        )
        if lift is not None:
            used.add(lift.id)
            car = rooms.room_at(lift.x, lift.y)
            graph.nodes[car]["lift"] = lift.id
            graph.add_edge(
                dw.room_a,
                dw.room_b,
                door=lift.id,
                kind="elevator",
                type="",
                width=math.dist(*lift.door(floor)),
            )
            continue
        match = next(
            (
                d
                for d in declared
                if d.id not in used
                and math.hypot(
                    dw.centre[0] - (d.p1[0] + d.p2[0]) / 2, dw.centre[1] - (d.p1[1] + d.p2[1]) / 2
                )
                < match_m
            ),
            None,
        )
        if match is not None:
            used.add(match.id)
            graph.add_edge(
                dw.room_a,
                dw.room_b,
                door=match.id,
                kind="door",
                type=match.type,
                width=math.dist(match.p1, match.p2),
            )
        else:
            graph.add_edge(
                dw.room_a, dw.room_b, door=f"doorway_{i}", kind="door", type="", width=dw.width
            )
    for d in declared:
        if d.id in used:
            continue
        cx, cy = (d.p1[0] + d.p2[0]) / 2, (d.p1[1] + d.p2[1]) / 2
        nx_, ny_ = -(d.p2[1] - d.p1[1]), d.p2[0] - d.p1[0]
        norm = math.hypot(nx_, ny_)
        a = rooms.room_at(cx + 0.5 * nx_ / norm, cy + 0.5 * ny_ / norm)
        b = rooms.room_at(cx - 0.5 * nx_ / norm, cy - 0.5 * ny_ / norm)
        if a and b and a != b:
            graph.add_edge(a, b, door=d.id, kind="door", type=d.type, width=math.dist(d.p1, d.p2))
    for lift in lifts:
        if lift.id in used:
            continue
        x, y, _theta = lift.entry_pose(floor, 0.8)
        room, car = rooms.room_at(x, y), rooms.room_at(lift.x, lift.y)
        if room and car and room != car:
            graph.nodes[car]["lift"] = lift.id
            graph.add_edge(
                room,
                car,
                door=lift.id,
                kind="elevator",
                type="",
                width=math.dist(*lift.door(floor)),
            )
    return graph, rooms
