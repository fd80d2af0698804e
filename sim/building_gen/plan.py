"""The abstract building plan: spaces, doors, lifts, places and obstacles per floor.

A plan is what the generator decided, before any pixel is drawn: the drawing
(:mod:`sim.building_gen.draw`), the topology graph (:mod:`sim.building_gen.topology`)
and the missions (:mod:`sim.building_gen.missions`) are all read off it. Spaces are
rectangles on wall centre lines (walls 0.2 m thick); ``carve`` is the free part.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from sim.building_gen.geometry import HALF, Rect, rect

Point = tuple[float, float]

# Kinds of spaces. Corridor pieces share one area per floor (they are open to each other).
CORRIDOR_KINDS = ("spine", "branch", "bay", "alcove", "lobby")


@dataclass
class Space:
    """A rectangle of the plan: its footprint on wall centre lines and the area it is part of."""

    id: str
    floor: str
    kind: str  # spine | branch | bay | alcove | lobby | room | inner | ante | hall | shaft
    area: str  # the topology node: all corridor pieces of a floor share one
    rect: Rect
    carve: Rect | None = None


@dataclass
class DoorSpec:
    """A door between areas ``area_a`` and ``area_b``; hinged leaves swing into ``area_b``."""

    id: str
    floor: str
    p1: Point
    p2: Point
    type: str  # manual | automatic | powered
    motion: str  # hinged | sliding
    swing: str  # left | right (hinged), "" for sliding doors
    controller: bool
    area_a: str
    area_b: str
    leaf: Rect | None = None  # the open hinged leaf (a 0.05 m slab), None for sliding

    @property
    def width(self) -> float:
        return math.hypot(self.p2[0] - self.p1[0], self.p2[1] - self.p1[1])

    @property
    def centre(self) -> Point:
        return ((self.p1[0] + self.p2[0]) / 2, (self.p1[1] + self.p2[1]) / 2)


@dataclass
class LiftSpec:
    """A lift car (free inside ``width`` x ``depth``), heading ``theta`` out through its door."""

    id: str
    x: float
    y: float
    theta: float
    width: float
    depth: float
    door_width: float
    floors: list[str]

    def axis(self) -> tuple[int, int]:
        return round(math.cos(self.theta)), round(math.sin(self.theta))

    def door_segment(self) -> tuple[Point, Point]:
        """The car door on the centre line of the shaft wall it faces (as sim.buildings.Shaft)."""
        ux, uy = self.axis()
        reach = self.depth / 2 + HALF
        cx, cy = self.x + ux * reach, self.y + uy * reach
        h = self.door_width / 2
        return (
            (round(cx - uy * h, 6), round(cy - ux * h, 6)),
            (round(cx + uy * h, 6), round(cy + ux * h, 6)),
        )

    def interior(self) -> Rect:
        ux, _ = self.axis()
        hx = (self.depth if ux else self.width) / 2
        hy = (self.width if ux else self.depth) / 2
        return rect(self.x - hx, self.y - hy, self.x + hx, self.y + hy)

    def landing(self, standoff: float = 1.5) -> Point:
        """The point ``standoff`` metres outside the car door (where the chair waits)."""
        (x1, y1), (x2, y2) = self.door_segment()
        ux, uy = self.axis()
        return ((x1 + x2) / 2 + ux * standoff, (y1 + y2) / 2 + uy * standoff)


@dataclass
class PlaceSpec:
    """A named pose with >= 0.9 m clearance, in area ``area``."""

    name: str
    floor: str
    x: float
    y: float
    theta: float
    area: str
    kind: str  # room | inner | hall | corridor


@dataclass
class FloorPlan:
    """One floor: its spaces, every carved rectangle, doors, obstacles and places."""

    name: str
    elevation: float
    spaces: list[Space] = field(default_factory=list)
    carves: list[Rect] = field(default_factory=list)
    doors: list[DoorSpec] = field(default_factory=list)
    columns: list[Rect] = field(default_factory=list)
    furniture: list[Rect] = field(default_factory=list)
    places: list[PlaceSpec] = field(default_factory=list)
    corridor_widths: list[float] = field(default_factory=list)
    series: list[tuple[str, str, float]] = field(default_factory=list)  # outer, inner, gap
    openings: list[Rect] = field(default_factory=list)  # doorless corridor-hall passages

    @property
    def corridor_area(self) -> str:
        return f"{self.name}:corridor"


@dataclass
class BuildingPlan:
    """The whole site: floors bottom-up and the lifts joining them."""

    name: str
    floors: list[FloorPlan]
    lifts: list[LiftSpec]

    def floor(self, name: str) -> FloorPlan:
        return next(f for f in self.floors if f.name == name)

    def place(self, name: str) -> PlaceSpec:
        return next(p for f in self.floors for p in f.places if p.name == name)

    def door(self, door_id: str) -> DoorSpec:
        return next(d for f in self.floors for d in f.doors if d.id == door_id)

    def bounds(self) -> Rect:
        """The box holding every space of every floor."""
        rects = [s.rect for f in self.floors for s in f.spaces]
        return (
            min(r[0] for r in rects),
            min(r[1] for r in rects),
            max(r[2] for r in rects),
            max(r[3] for r in rects),
        )

    def transform(self, quarter_turns: int, dx: float, dy: float) -> None:
        """Turn the whole plan by ``quarter_turns`` x 90 deg about the origin, then shift it."""
        k = quarter_turns % 4

        def pt(p: Point) -> Point:
            x, y = p
            for _ in range(k):
                x, y = -y, x
            return (round(x + dx, 6), round(y + dy, 6))

        def rc(r: Rect) -> Rect:
            (ax, ay), (bx, by) = pt((r[0], r[1])), pt((r[2], r[3]))
            return rect(ax, ay, bx, by)

        def th(theta: float) -> float:
            t = theta + k * math.pi / 2
            return round(math.atan2(math.sin(t), math.cos(t)), 6)

        for f in self.floors:
            for s in f.spaces:
                s.rect = rc(s.rect)
                s.carve = rc(s.carve) if s.carve else None
            f.carves = [rc(r) for r in f.carves]
            f.columns = [rc(r) for r in f.columns]
            f.furniture = [rc(r) for r in f.furniture]
            f.openings = [rc(r) for r in f.openings]
            for d in f.doors:
                d.p1, d.p2 = pt(d.p1), pt(d.p2)
                d.leaf = rc(d.leaf) if d.leaf else None
            for p in f.places:
                p.x, p.y = pt((p.x, p.y))
                p.theta = th(p.theta)
        for lift in self.lifts:
            lift.x, lift.y = pt((lift.x, lift.y))
            lift.theta = th(lift.theta)
