"""Draw the bundled multi-floor sites (rooms, doors, elevator shafts) into site folders.

Each floor starts solid and rooms, doorways and shafts are carved out of it, so the only
free space is what a building plan declares and every doorway is exactly the gap between
its door's two end points. Rebuild one with ``python -m sim.buildings two_floors
sites/two_floors``. Coordinates are given on wall centre lines; walls are 0.2 m thick.
"""

from __future__ import annotations

import argparse
import math
from dataclasses import dataclass, field
from pathlib import Path

import yaml

from sim.sitegen import Rect, draw, write_map
from sim.sitegen import two_rooms as sitegen_two_rooms

RES = 0.05
WALL = 0.2
HALF = WALL / 2


@dataclass
class Plan:
    """One floor being drawn: the free rectangles carved out and the doors and places on it."""

    name: str
    elevation: float
    carved: list[Rect] = field(default_factory=list)
    doors: list[dict] = field(default_factory=list)
    places: dict[str, dict] = field(default_factory=dict)

    def room(self, x0: float, y0: float, x1: float, y1: float) -> None:
        """A room whose walls are centred on x0, x1, y0, y1 (its interior becomes free)."""
        self.carved.append((x0 + HALF, y0 + HALF, x1 - HALF, y1 - HALF))

    def carve(self, rect: Rect) -> None:
        """Free an arbitrary rectangle (an alcove, a shaft interior)."""
        self.carved.append(rect)

    def door(self, id: str, p1: tuple[float, float], p2: tuple[float, float], kind: str) -> None:
        """A doorway through the wall whose centre line holds the axis-aligned ``p1``-``p2``."""
        self.carved.append(_gap(p1, p2))
        self.doors.append({"id": id, "floor": self.name, "p1": _r(p1), "p2": _r(p2), "type": kind})

    def place(self, name: str, x: float, y: float, theta: float = 0.0) -> None:
        self.places[name] = {"floor": self.name, "x": x, "y": y, "theta": round(theta, 6)}


@dataclass
class Shaft:
    """An elevator car (free interior) with one door in the wall its heading points through."""

    id: str
    x: float
    y: float
    theta: float
    width: float
    depth: float
    door_width: float

    def door_segment(self) -> tuple[tuple[float, float], tuple[float, float]]:
        """The car door on the centre line of the shaft wall the car faces."""
        ux, uy = round(math.cos(self.theta)), round(math.sin(self.theta))
        reach = self.depth / 2 + HALF
        cx, cy = self.x + ux * reach, self.y + uy * reach
        h = self.door_width / 2
        return (cx - uy * h, cy - ux * h), (cx + uy * h, cy + ux * h)

    def interior(self) -> Rect:
        along_x = round(math.cos(self.theta)) != 0
        hx = (self.depth if along_x else self.width) / 2
        hy = (self.width if along_x else self.depth) / 2
        return (self.x - hx, self.y - hy, self.x + hx, self.y + hy)

    def cut(self, plan: Plan) -> None:
        """Carve the car and its door gap into ``plan``."""
        plan.carve(self.interior())
        plan.carve(_gap(*self.door_segment()))

    def entry(self, floors: list[Plan]) -> dict:
        """The site.yaml ``elevators:`` entry serving ``floors``."""
        p1, p2 = self.door_segment()
        return {
            "id": self.id,
            "floors": [f.name for f in floors],
            "car": {
                "x": self.x,
                "y": self.y,
                "theta": round(self.theta, 6),
                "width": self.width,
                "depth": self.depth,
            },
            "doors": {f.name: {"p1": _r(p1), "p2": _r(p2)} for f in floors},
        }


def _r(p: tuple[float, float]) -> list[float]:
    return [round(p[0], 3), round(p[1], 3)]


def _gap(p1: tuple[float, float], p2: tuple[float, float]) -> Rect:
    """The rectangle through a wall's thickness between two points on its centre line."""
    (x1, y1), (x2, y2) = p1, p2
    if abs(y1 - y2) < 1e-9:
        return (min(x1, x2), y1 - HALF, max(x1, x2), y1 + HALF)
    if abs(x1 - x2) < 1e-9:
        return (x1 - HALF, min(y1, y2), x1 + HALF, max(y1, y2))
    raise ValueError(f"door {p1}-{p2} is not axis-aligned")


def write_site(
    folder: Path,
    name: str,
    plans: list[Plan],
    shafts: list[Shaft],
    extent: Rect,
) -> None:
    """Write one map per floor (solid ``extent`` with the plan carved out) and site.yaml."""
    x0, y0, x1, y1 = extent
    origin = (x0, y0, 0.0)
    floors = []
    for plan in plans:
        for shaft in shafts:
            shaft.cut(plan)
        local = [(a - x0, b - y0, c - x0, d - y0) for a, b, c, d in plan.carved]
        size = (x1 - x0, y1 - y0)
        occ = draw(size, [(0.0, 0.0, *size)], local, RES)
        stem = f"floor{plan.name}"
        write_map(occ, folder, stem, RES, origin)
        floors.append({"name": plan.name, "elevation": plan.elevation, "map": f"{stem}.yaml"})
    site = {
        "name": name,
        "floors": floors,
        "doors": [d for plan in plans for d in plan.doors],
        "places": {k: v for plan in plans for k, v in plan.places.items()},
        "elevators": [shaft.entry(plans) for shaft in shafts],
    }
    (folder / "site.yaml").write_text(
        yaml.safe_dump(site, sort_keys=False, default_flow_style=None, width=100)
    )


# --------------------------------------------------------------------------------------
# seed_floor: the seed's floor 4 (and a floor 5 to ride to)
# --------------------------------------------------------------------------------------


def _seed_core(plan: Plan) -> None:
    """Elevator room north of the hallway, its 1.5 m door and the landing alcove to the lift."""
    plan.room(28.0, 6.9, 39.0, 13.8)
    plan.door(f"d{plan.name}_elevator_room", (30.35, 6.9), (31.85, 6.9), "manual")
    plan.carve((27.1, 8.4, 28.1, 10.6))  # landing recess through the room's west wall


def seed_floor(folder: Path) -> None:
    """The seed's floor 4 (hallway, elevator room, offices) and floor 5, joined by lift_1."""
    four = Plan("4", 12.0)
    four.room(-6.5, -1.0, 84.2, 6.9)
    _seed_core(four)
    four.room(10.0, 6.9, 18.0, 13.8)
    four.door("d4_office_401", (13.55, 6.9), (14.45, 6.9), "manual")
    four.room(45.0, 6.9, 53.0, 13.8)
    four.door("d4_office_402", (48.5, 6.9), (49.5, 6.9), "automatic")
    four.room(2.0, -7.0, 10.0, -1.0)
    four.door("d4_office_403", (5.4, -1.0), (6.6, -1.0), "powered")
    four.place("hallway_west", -4.0, 3.0, 0.0)
    four.place("hallway_east", 80.0, 3.0, math.pi)
    four.place("elevator_room", 30.0, 12.0, math.pi)
    four.place("office_401", 14.0, 10.5, -math.pi / 2)
    four.place("office_402", 49.0, 10.5, -math.pi / 2)
    four.place("office_403", 6.0, -4.0, math.pi / 2)

    five = Plan("5", 16.0)
    five.room(-6.5, -1.0, 60.0, 6.9)
    _seed_core(five)
    five.room(10.0, 6.9, 18.0, 13.8)
    five.door("d5_office_501", (13.55, 6.9), (14.45, 6.9), "manual")
    five.place("hallway_5", 5.0, 3.0, 0.0)
    five.place("elevator_room_5", 30.0, 12.0, math.pi)
    five.place("office_501", 14.0, 10.5, -math.pi / 2)

    lift = Shaft("lift_1", 25.9, 9.5, 0.0, 1.6, 2.0, 1.2)  # car door centred at (27, 9.5)
    write_site(folder, "seed_floor", [four, five], [lift], (-7.0, -7.5, 85.0, 14.5))


# --------------------------------------------------------------------------------------
# two_floors: two storeys, a corridor each, two lifts facing each other across it
# --------------------------------------------------------------------------------------

# (room, its rectangle on wall centre lines, its door span along the corridor wall, door type)
_SOUTH_WALL, _NORTH_WALL = 8.0, 10.5
_TWO_FLOORS: dict[str, list[tuple[str, Rect, tuple[float, float], str]]] = {
    "1": [
        ("room_1a", (0.0, 0.0, 10.0, 8.0), (4.55, 5.45), "manual"),
        ("lab_1", (10.0, 0.0, 22.0, 8.0), (15.3, 16.7), "powered"),
        ("office_1c", (26.0, 0.0, 40.0, 8.0), (32.5, 33.5), "manual"),
        ("lobby_1", (0.0, 10.5, 16.0, 20.0), (7.25, 8.75), "automatic"),
        ("office_1d", (16.0, 10.5, 22.0, 20.0), (18.6, 19.4), "manual"),
        ("office_1e", (26.0, 10.5, 40.0, 20.0), (32.4, 33.6), "powered"),
    ],
    "2": [
        ("office_2a", (0.0, 0.0, 10.0, 8.0), (4.5, 5.5), "manual"),
        ("room_2b", (10.0, 0.0, 22.0, 8.0), (15.45, 16.55), "automatic"),
        ("lab_2", (26.0, 0.0, 40.0, 8.0), (32.35, 33.65), "powered"),
        ("lobby_2", (0.0, 10.5, 16.0, 20.0), (7.25, 8.75), "automatic"),
        ("office_2d", (16.0, 10.5, 22.0, 20.0), (18.55, 19.45), "manual"),
        ("office_2e", (26.0, 10.5, 40.0, 20.0), (32.6, 33.4), "manual"),
    ],
}


def two_floors(folder: Path) -> None:
    """Floors 1 and 2: a 2.3 m corridor, three rooms each side, lifts lift_a and lift_b."""
    plans = []
    for name, elevation in (("1", 0.0), ("2", 4.0)):
        plan = Plan(name, elevation)
        plan.room(0.0, _SOUTH_WALL, 40.0, _NORTH_WALL)
        for room, rect, (xa, xb), kind in _TWO_FLOORS[name]:
            plan.room(*rect)
            south = rect[3] == _SOUTH_WALL
            y = _SOUTH_WALL if south else _NORTH_WALL
            plan.door(f"d{name}_{room}", (xa, y), (xb, y), kind)
            facing = math.pi / 2 if south else -math.pi / 2  # facing the door
            plan.place(room, (rect[0] + rect[2]) / 2, 4.0 if south else 15.0, facing)
        mid = (_SOUTH_WALL + _NORTH_WALL) / 2
        plan.place(f"corridor_{name}_west", 2.0, mid, 0.0)
        plan.place(f"corridor_{name}_east", 38.0, mid, math.pi)
        plans.append(plan)
    shafts = [
        Shaft("lift_a", 24.0, 6.9, math.pi / 2, 1.6, 2.0, 1.2),  # door in the south wall
        Shaft("lift_b", 24.0, 11.6, -math.pi / 2, 1.6, 2.0, 1.2),  # door in the north wall
    ]
    write_site(folder, "two_floors", plans, shafts, (-1.0, -1.0, 41.0, 21.0))


# --------------------------------------------------------------------------------------
# two_ways: two rooms joined by a door and, the long way round, by a corridor north of both
# --------------------------------------------------------------------------------------


def two_ways(folder: Path) -> None:
    """Rooms room_a and room_b share door_ab; each also opens into a 2.5 m corridor north."""
    plan = Plan("1", 0.0)
    plan.room(0.0, 0.0, 8.0, 6.0)  # room_a
    plan.room(8.0, 0.0, 16.0, 6.0)  # room_b
    plan.room(0.0, 6.0, 16.0, 8.5)  # the corridor
    plan.door("door_ab", (8.0, 2.5), (8.0, 3.5), "manual")
    plan.door("door_a_hall", (3.5, 6.0), (4.5, 6.0), "manual")
    plan.door("door_b_hall", (11.5, 6.0), (12.5, 6.0), "manual")
    plan.place("room_a", 2.0, 3.0, 0.0)
    plan.place("room_b", 14.0, 3.0, math.pi)
    plan.place("hall", 8.0, 7.25, 0.0)
    write_site(folder, "two_ways", [plan], [], (-1.0, -1.0, 17.0, 9.5))


SITES = {
    "two_rooms": sitegen_two_rooms,
    "seed_floor": seed_floor,
    "two_floors": two_floors,
    "two_ways": two_ways,
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("site", choices=sorted(SITES))
    parser.add_argument("folder", type=Path)
    args = parser.parse_args()
    SITES[args.site](args.folder)
    print(f"wrote {args.site} to {args.folder}")


if __name__ == "__main__":
    main()
