"""The building's topology and route estimates, read off the plan (never off a run).

Two graphs: ``areas`` (networkx MultiGraph) has one node per room, ante-room, hall and
floor corridor, an edge per door (key: door id) and per lift and pair of floors it
serves (key: lift id); ``ways`` refines it for distances, with a node per door and lift
landing, joined within each area by their Manhattan distance. Expected outcomes follow
from connectivity with doors or lifts taken out; route lengths feed the time limits.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import networkx as nx

from sim.building_gen.plan import BuildingPlan, PlaceSpec, Point

RIDE_COST_M = 10.0  # what a lift ride weighs against walking, for the route choice


@dataclass
class Route:
    """An estimated route: metres walked, doors passed and lifts ridden, in order."""

    length_m: float
    doors: list[str]
    lifts: list[str]


def _l1(a: Point, b: Point) -> float:
    return abs(a[0] - b[0]) + abs(a[1] - b[1])


class Topology:
    """Areas, doors and lifts of a plan, with shortest routes between places."""

    def __init__(self, plan: BuildingPlan) -> None:
        self.areas = nx.MultiGraph()
        self.ways = nx.Graph()
        self.portals: dict[str, list[tuple[tuple, Point]]] = {}
        for floor in plan.floors:
            for space in floor.spaces:
                if space.kind != "shaft" and space.area not in self.areas:
                    self.areas.add_node(space.area, floor=floor.name, kind=space.kind)
                    self.portals[space.area] = []
            for d in floor.doors:
                node = ("door", d.id)
                self.ways.add_node(node)
                self.portals[d.area_a].append((node, d.centre))
                self.portals[d.area_b].append((node, d.centre))
                self.areas.add_edge(d.area_a, d.area_b, key=d.id, kind="door")
        for lift in plan.lifts:
            landing = lift.landing()
            for f in lift.floors:
                node = ("lift", lift.id, f)
                self.ways.add_node(node)
                self.portals[plan.floor(f).corridor_area].append((node, landing))
            for fa, fb in itertools.combinations(lift.floors, 2):
                a, b = ("lift", lift.id, fa), ("lift", lift.id, fb)
                self.ways.add_edge(a, b, weight=RIDE_COST_M, lift=lift.id)
                area_a, area_b = plan.floor(fa).corridor_area, plan.floor(fb).corridor_area
                self.areas.add_edge(area_a, area_b, key=lift.id, kind="lift")
        for portals in self.portals.values():
            for (a, pa), (b, pb) in itertools.combinations(portals, 2):
                if a != b:
                    self.ways.add_edge(a, b, weight=_l1(pa, pb))

    def route(
        self,
        start: PlaceSpec,
        goal: PlaceSpec,
        doors: frozenset[str] = frozenset(),
        lifts: frozenset[str] = frozenset(),
    ) -> Route | None:
        """The shortest route with ``doors`` shut and ``lifts`` out of use; None if none."""
        g = self.ways.copy()
        g.remove_nodes_from([("door", d) for d in doors])
        g.remove_edges_from([(a, b) for a, b, lift in g.edges(data="lift") if lift in lifts])
        for name, place in (("start", start), ("goal", goal)):
            g.add_node(name)
            for node, p in self.portals[place.area]:
                if node in g:
                    g.add_edge(name, node, weight=_l1((place.x, place.y), p))
        if start.area == goal.area:
            g.add_edge("start", "goal", weight=_l1((start.x, start.y), (goal.x, goal.y)))
        try:
            path = nx.dijkstra_path(g, "start", "goal", weight="weight")
        except nx.NetworkXNoPath:
            return None
        length, rides = 0.0, []
        for a, b in zip(path, path[1:], strict=False):
            lift = g.edges[a, b].get("lift")
            if lift is None:
                length += g.edges[a, b]["weight"]
            else:
                rides.append(lift)
        door_ids = [n[1] for n in path if isinstance(n, tuple) and n[0] == "door"]
        return Route(round(length, 2), door_ids, rides)

    def single_door(self, area: str) -> str | None:
        """The id of the only door of ``area`` (nothing else leads in), else None."""
        edges = list(self.areas.edges(area, keys=True, data="kind"))
        if len(edges) == 1 and edges[0][3] == "door":
            return str(edges[0][2])
        return None

    def spare_doors(self) -> set[str]:
        """Doors whose loss disconnects nothing (another way round exists)."""
        spare = set()
        for a, b, key, kind in self.areas.edges(keys=True, data="kind"):
            if kind != "door":
                continue
            g = self.areas.copy()
            g.remove_edge(a, b, key=key)
            if nx.has_path(g, a, b):
                spare.add(str(key))
        return spare
