"""The world a generated building's stack meets, drawn apart from the map it is given.

With ``GenOptions.world_differs`` the generator draws, beside the site the stack gets, a
second site (``world/``) from a copy of the same plan with seeded differences the map
does not show: some doors displaced along their wall by up to 0.20 m (opening, leaf and
door entry move), furniture the map lacks and some of the map's furniture gone, one
partition between two rooms shifted by up to 0.20 m, and a few people standing where
furniture may go (not drawn into the world's maps: the simulator makes them bodies, as
the missions' ``sim.pedestrians``). A change is kept only if the floor still keeps the
generator's promises around it: every nearby door's turning discs, straight approaches,
leaf, sweep, pocket and jambs (:func:`~sim.building_gen.doors.door_rules`), every nearby
place's clearance, and the passage around furniture. So the areas and doors joining
them, and each mission's expected outcome, are the map's. The world's draws come from
their own random stream (the people drawn last, so the rest of the world is as drawn
before there were people): the map and the missions are those drawn without the option.
"""

from __future__ import annotations

import copy
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field, replace

import numpy as np

from sim.building_gen.doors import STRAIGHT, Found, door_pocket, door_rules, door_wall, keep_door
from sim.building_gen.furnish import PASSAGE, PLACE_CLEARANCE, fits, flush, furnish
from sim.building_gen.geometry import (
    EPS,
    HALF,
    WALL,
    Rect,
    disc_points,
    on_boundary,
    overlaps,
    point_rect_dist,
    rect,
    rect_gap,
    rect_points,
    snap,
)
from sim.building_gen.lobby import keep_lift
from sim.building_gen.plan import BuildingPlan, DoorSpec, FloorPlan, LiftSpec, PlaceSpec, Space
from sim.building_gen.state import FloorState

WORLD_FOLDER = "world"  # the world's site, inside the building's folder
WORLD_STREAM = 1  # the world draws from numpy.random.default_rng([seed, WORLD_STREAM])
SHIFTS_M = (0.05, 0.10, 0.15, 0.20)  # door and wall displacements, on the map grid
DOOR_SHARE = 0.3  # share of doors the world tries to move
ADDED_PER_FLOOR = (1, 3)  # pieces of furniture the map lacks, per floor
REMOVED_SHARE = 0.3  # chance a furnished floor loses one of its mapped pieces
NEAR_M = 6.0  # a change can reach the rules of doors and places this close to it
JAMB_M = 0.1  # solid wall beside a door's opening (the generator leaves >= 0.1 m)
FACE_M = 0.05  # the floor this far off a wall's face beside a jamb shows whether it runs on
MIN_PARTITION_M = 1.0  # the shortest partition worth moving
MIN_SIDE_M = 2.5  # a partition move never makes a space narrower than this
PARTITIONED = ("room", "inner", "ante", "hall")
FURNISHED = ("room", "inner", "hall")
PEOPLE_PER_FLOOR = (0, 3)  # standing people the map does not show, per floor
PERSON_RADIUS_M = 0.25  # a person: a disc (the simulator's pedestrian cylinder)
PERSON_NEAR_DOOR_M = 3.0  # a person stands within this (per axis) of a door of its space
PERSON_TRIES = 40  # spots tried per person before its floor does without it


@dataclass
class WorldDiff:
    """What the world has that the map has not (rectangles as ``[x0, y0, x1, y1]``).

    ``doors``: ``{id, floor, offset_m}``, the door's ``p1`` and ``p2`` (and its leaf and
    opening) moved ``offset_m`` along ``p1 -> p2``; ``furniture_added`` and
    ``furniture_removed``: ``{floor, rect}``; ``walls``: ``{floor, spaces, shift_m,
    length_m, freed, walled}``, the partition between ``spaces`` (the first grows)
    moved ``shift_m`` into the second: ``freed`` was wall and is free, ``walled`` was
    free and is wall; ``people``: ``{floor, x, y, radius_m}``, a person standing there
    (in no map: the missions give them to the simulator, :meth:`pedestrians`).
    """

    doors: list[dict] = field(default_factory=list)
    furniture_added: list[dict] = field(default_factory=list)
    furniture_removed: list[dict] = field(default_factory=list)
    walls: list[dict] = field(default_factory=list)
    people: list[dict] = field(default_factory=list)

    def record(self) -> dict:
        """The ``world`` entry of generated.yaml: where the world is and what differs."""
        return {
            "site": WORLD_FOLDER,
            "doors_moved": self.doors,
            "furniture_added": self.furniture_added,
            "furniture_removed": self.furniture_removed,
            "walls_moved": self.walls,
            "people": self.people,
        }

    def sizes(self) -> dict:
        """Sizes for the campaign's histogram: door offsets, furniture areas, wall shifts,
        people's radii (one per person)."""

        def area(r: list[float]) -> float:
            return round((r[2] - r[0]) * (r[3] - r[1]), 3)

        return {
            "doors_moved_m": [abs(d["offset_m"]) for d in self.doors],
            "furniture_added_m2": [area(f["rect"]) for f in self.furniture_added],
            "furniture_removed_m2": [area(f["rect"]) for f in self.furniture_removed],
            "walls_moved_m": [w["shift_m"] for w in self.walls],
            "walls_moved_length_m": [w["length_m"] for w in self.walls],
            "people_radius_m": [p["radius_m"] for p in self.people],
        }

    def summary(self) -> str:
        """A few words: how many doors moved, pieces added and removed, walls moved,
        people standing."""
        people = f"{len(self.people)} {'person' if len(self.people) == 1 else 'people'}"
        return (
            f"world differs: {len(self.doors)} doors moved, "
            f"{len(self.furniture_added)}+/{len(self.furniture_removed)}- furniture, "
            f"{len(self.walls)} wall moved, {people} standing"
        )

    def pedestrians(self, floors: Iterable[str]) -> list[dict]:
        """The people on ``floors`` as the simulator's ``sim.pedestrians`` entries: one
        waypoint each, where the person stands."""
        wanted = set(floors)
        return [
            {"waypoints": [[p["x"], p["y"]]], "radius": p["radius_m"], "floor": p["floor"]}
            for p in self.people
            if p["floor"] in wanted
        ]


@dataclass(frozen=True)
class Partition:
    """The wall between ``grow`` and ``shrink``, two spaces side by side along ``axis``
    (0: the wall runs along y) with ``shrink`` towards ``sign`` of ``grow``, no longer
    than ``shrink``'s side, so moving it into ``shrink`` keeps both free parts rectangles
    (``grow`` gains a strip)."""

    grow: Space
    shrink: Space
    axis: int
    sign: int

    @property
    def length_m(self) -> float:
        c, j = self.shrink.carve, 1 - self.axis
        return round(c[j + 2] - c[j], 6)

    def _span(self, a0: float, a1: float) -> Rect:
        """The rectangle from ``a0`` to ``a1`` along ``axis`` over the wall's length."""
        c, j = self.shrink.carve, 1 - self.axis
        lo, hi = (a0, c[j]), (a1, c[j + 2])
        if self.axis == 1:
            lo, hi = (c[j], a0), (c[j + 2], a1)
        return rect(*lo, *hi)

    def wall(self) -> Rect:
        """The partition as the map has it."""
        g, s, k = self.grow.carve, self.shrink.carve, self.axis
        return self._span(g[k + 2], s[k]) if self.sign > 0 else self._span(s[k + 2], g[k])

    def moved(self, shift: float) -> tuple[Rect, Rect, Rect]:
        """``shrink``'s free part, the strip ``grow`` gains and the strip that turns to wall
        when the wall moves ``shift`` into ``shrink``."""
        g, s, k = self.grow.carve, self.shrink.carve, self.axis
        lo, hi = list(s[:2]), list(s[2:])
        if self.sign > 0:
            lo[k] = round(s[k] + shift, 6)
            freed, walled = self._span(g[k + 2], g[k + 2] + shift), self._span(s[k], lo[k])
        else:
            hi[k] = round(s[k + 2] - shift, 6)
            freed, walled = self._span(g[k] - shift, g[k]), self._span(hi[k], s[k + 2])
        return rect(*lo, *hi), freed, walled


class WorldFloor:
    """One floor of the world while it is altered, with the rules its plan was drawn by."""

    def __init__(self, plan: FloorPlan, lifts: list[LiftSpec], rng: np.random.Generator) -> None:
        self.plan, self.rng = plan, rng
        fixed = FloorState(plan, rng)
        for lift in lifts:
            keep_lift(fixed, lift, plan.name in lift.floors)
        for opening in plan.openings:
            for zone in _opening_zones(opening):
                fixed.keep_rect("zone", "opening", zone)
        for p in plan.places:
            fixed.keep_disc("zone", p.name, p.x, p.y, PLACE_CLEARANCE)
        self.fixed_zones, self.fixed_pockets = fixed.keepouts, fixed.pockets
        self.found: dict[str, Found] = {}
        self.strict: dict[str, bool] = {}
        self.faces: dict[str, list[bool]] = {}  # per door, as the map has them: _jamb_faces
        self.people: list[Rect] = []  # the bounding squares of the people standing
        self._rules_of_the_map()

    # ---- the floor as the generator saw it ----------------------------------------------

    def state(self, without: str = "", zones: bool = True) -> FloorState:
        """The floor as a :class:`FloorState` (free space, obstacles, pockets and, with
        ``zones``, keep-outs), leaving out what door ``without`` brings itself."""
        st = FloorState(self.plan, self.rng)
        doors = [d for d in self.plan.doors if d.id != without]
        st.free.carves = list(self.plan.carves)
        leaves = [d.leaf for d in doors if d.leaf is not None]
        st.free.obstacles = self.plan.columns + self.plan.furniture + self.people + leaves
        pockets = [door_pocket(*door_wall(d)) for d in doors if d.motion == "sliding"]
        st.pockets = self.fixed_pockets + pockets
        if zones:
            st.keepouts = list(self.fixed_zones)
            for d in (d for d in doors if d.id in self.found):
                wall, p1t, p2t = door_wall(d)
                keep_door(st, wall, min(p1t, p2t), max(p1t, p2t), d.id, self.found[d.id])
        return st

    def door_holds(self, door: DoorSpec, zones: bool = True) -> Found | None:
        """What ``door`` needs, if the floor gives it (its jambs solid, its opening off
        every pocket, :func:`door_rules`; ``zones``: also off the others' keep-outs)."""
        wall, p1t, p2t = door_wall(door)
        t_lo, t_hi = min(p1t, p2t), max(p1t, p2t)
        st = self.state(door.id, zones)
        gap = wall.rect(t_lo, t_hi, -HALF, HALF)
        if any(overlaps(gap, p) for p in st.pockets):
            return None
        for a, b in ((t_lo - JAMB_M, t_lo), (t_hi, t_hi + JAMB_M)):
            jamb = wall.rect(a + 0.01, b - 0.01, 0.01 - HALF, HALF - 0.01)
            if st.free.any_carved(rect_points(jamb)):
                return None
        return door_rules(st, wall, p1t, p2t, door.motion, door.id)

    def _jamb_faces(self, door: DoorSpec) -> list[bool]:
        """Per jamb and per face of its wall: whether the floor just off the face beside the
        jamb is free (the wall runs on there, it is not a corner's side wall)."""
        wall, p1t, p2t = door_wall(door)
        t_lo, t_hi = min(p1t, p2t), max(p1t, p2t)
        free = self.state(door.id, zones=False).free
        out = []
        for a, b in ((t_lo - JAMB_M, t_lo), (t_hi, t_hi + JAMB_M)):
            for n0, n1 in ((HALF + 0.01, HALF + FACE_M), (-HALF - FACE_M, -HALF - 0.01)):
                strip = rect_points(wall.rect(a + 0.01, b - 0.01, n0, n1), step=0.02)
                out.append(free.all_carved(strip))
        return out

    def _keeps_its_jambs(self, door: DoorSpec) -> bool:
        """True if every face beside a jamb of ``door`` that the map has free still is: a
        door moved along its wall must not end flush with a corner (world-differs
        b7104w.m00: an 0.80 m door 7.5 cm from the side wall of the room before it), which
        the generator never draws."""
        kept = self.faces.get(door.id)
        return kept is None or all(
            now or not before for before, now in zip(kept, self._jamb_faces(door), strict=True)
        )

    def _rules_of_the_map(self) -> None:
        """Which rules each door keeps on the map, so the world keeps them: all of them
        (``strict``), or (where the map itself has a leaf a hair inside a place's 0.9 m,
        the generator having checked that place on sample points) those on free space
        alone; a door keeping not even these is left out (and never moved)."""
        doors = self.plan.doors
        for d in doors:
            found = self.door_holds(d, zones=False)
            if found is not None:
                self.found[d.id] = found
        for d in (d for d in doors if d.id in self.found):
            self.strict[d.id] = self.door_holds(d) is not None
            self.faces[d.id] = self._jamb_faces(d)

    def _refresh(self, doors: list[DoorSpec]) -> bool:
        """Find the discs of ``doors`` on the floor as it is now, then check each door
        whole (as far as the map keeps its rules) against everybody's keep-outs; False as
        soon as one is denied."""
        doors = [d for d in doors if d.id in self.strict]
        for d in doors:
            found = self.door_holds(d, zones=False)
            if found is None or not self._keeps_its_jambs(d):
                return False
            self.found[d.id] = found
        return all(self.door_holds(d, self.strict[d.id]) is not None for d in doors)

    def _places_clear(self, places: list[PlaceSpec]) -> bool:
        """Whether each place still has its clearance from walls, furniture and open
        leaves, checked as the generator checked it (a moved leaf is also held off every
        place's disc exactly, by its door's rules)."""
        free = self.state(zones=False).free
        return all(free.free(disc_points(p.x, p.y, PLACE_CLEARANCE)) for p in places)

    def holds_near(self, region: Rect) -> bool:
        """Whether every door and place within ``NEAR_M`` of ``region`` keeps its promise."""
        doors = [d for d in self.plan.doors if point_rect_dist(*d.centre, region) < NEAR_M]
        places = [p for p in self.plan.places if point_rect_dist(p.x, p.y, region) < NEAR_M]
        return self._refresh(doors) and self._places_clear(places)

    def _try(self, change: Callable[[], Rect]) -> bool:
        """Make ``change`` (it returns the region it touched) and keep it if the rules
        still hold near that region; else undo it and return False."""
        carves, doors, found = list(self.plan.carves), list(self.plan.doors), dict(self.found)
        spaces, people = [(s, s.carve) for s in self.plan.spaces], list(self.people)
        if self.holds_near(change()):
            return True
        self.plan.carves[:], self.plan.doors[:], self.found = carves, doors, found
        self.people[:] = people
        for s, carve in spaces:
            s.carve = carve
        return False

    # ---- the differences --------------------------------------------------------------

    def remove_furniture(self) -> list[dict]:
        """Maybe take one mapped piece out of the world (that never takes a promise away)."""
        pieces = self.plan.furniture
        if not pieces or self.rng.random() >= REMOVED_SHARE:
            return []
        piece = pieces.pop(int(self.rng.integers(len(pieces))))
        return [{"floor": self.plan.name, "rect": list(piece)}]

    def move_doors(self) -> list[dict]:
        """Move about ``DOOR_SHARE`` of the doors along their wall, each by up to 0.20 m
        where it keeps its promises (and its neighbours theirs) there."""
        moved = []
        for i in range(len(self.plan.doors)):
            if self.rng.random() >= DOOR_SHARE or not self.strict.get(self.plan.doors[i].id):
                continue
            offset = float(self.rng.choice(SHIFTS_M)) * float(self.rng.choice([-1.0, 1.0]))
            for o in (offset, -offset):
                if self.move_door(i, o):
                    door = self.plan.doors[i]
                    moved.append({"id": door.id, "floor": self.plan.name, "offset_m": o})
                    break
        return moved

    def move_door(self, index: int, offset: float) -> bool:
        """Move door ``index`` ``offset`` metres along ``p1 -> p2``; False (undone) if the
        rules do not hold there."""
        door = self.plan.doors[index]
        moved = shifted(door, offset)
        old, new = door_gap(door), door_gap(moved)
        at = _index(self.plan.carves, old)
        if at is None:
            return False

        def change() -> Rect:
            self.plan.doors[index] = moved
            self.plan.carves[at] = new
            return _hull(old, new)

        return self._try(change)

    def partitions(self) -> list[Partition]:
        """Every partition a move may take: between two spaces side by side, doorless,
        at least ``MIN_PARTITION_M`` long, no column or furniture within the passage."""
        spaces = [s for s in self.plan.spaces if s.kind in PARTITIONED and s.carve]
        out = []
        for g in spaces:
            for s in spaces:
                for axis in (0, 1):
                    for sign in (1, -1):
                        part = _partition(g, s, axis, sign)
                        if part is not None and self._movable(part):
                            out.append(part)
        return out

    def _movable(self, part: Partition) -> bool:
        wall = part.wall()
        if part.length_m < MIN_PARTITION_M - EPS or any(
            overlaps(wall, c) for c in self.plan.carves
        ):
            return False
        _, _, walled = part.moved(max(SHIFTS_M))
        band = _hull(wall, walled)
        obstacles = self.plan.columns + self.plan.furniture
        return all(rect_gap(o, band) >= PASSAGE - EPS for o in obstacles)

    def move_wall(self, part: Partition, shift: float) -> dict | None:
        """Move ``part`` ``shift`` metres into its ``shrink`` space; its record, or None
        (undone) where the rules do not hold or the space would get too narrow."""
        s = part.shrink.carve
        side = s[part.axis + 2] - s[part.axis]
        if side - shift < MIN_SIDE_M - EPS:
            return None
        carve, freed, walled = part.moved(shift)
        at = _index(self.plan.carves, s)
        if at is None or any(
            overlaps(walled, c) for i, c in enumerate(self.plan.carves) if i != at
        ):
            return None

        def change() -> Rect:
            self.plan.carves[at] = carve
            self.plan.carves.append(freed)
            part.shrink.carve = carve
            return _hull(freed, walled)

        if not self._try(change):
            return None
        return {
            "floor": self.plan.name,
            "spaces": [part.grow.id, part.shrink.id],
            "shift_m": shift,
            "length_m": part.length_m,
            "freed": list(freed),
            "walled": list(walled),
        }

    def add_furniture(self, count: int) -> list[dict]:
        """Up to ``count`` pieces the map lacks, by the generator's own furnishing rules
        (near doors, off every keep-out, flush or a passage away from anything)."""
        st = self.state()
        spaces = [s for s in self.plan.spaces if s.kind in FURNISHED and s.carve]
        before = len(self.plan.furniture)
        for i in self.rng.permutation(len(spaces)):
            if len(self.plan.furniture) - before >= count:
                break
            space = spaces[int(i)]
            anchors = [d.centre for d in self.plan.doors if on_boundary(d.centre, space.rect)]
            x0, y0, x1, y1 = space.carve
            furnish(st, space, anchors or [((x0 + x1) / 2, (y0 + y1) / 2)], 1)
        return [{"floor": self.plan.name, "rect": list(r)} for r in self.plan.furniture[before:]]

    def add_people(self, count: int) -> list[dict]:
        """Up to ``count`` people standing where furniture may go: near a door of a
        furnished space, each one's bounding square fitted as a piece of furniture is
        (flush against a wall or a passage away from walls, furniture and the other
        people, off every keep-out) and every door and place near it keeping its promise."""
        spaces = [s for s in self.plan.spaces if s.kind in FURNISHED and s.carve]
        out, r = [], PERSON_RADIUS_M
        for _ in range(count if spaces else 0):
            for _ in range(PERSON_TRIES):
                space = spaces[int(self.rng.integers(len(spaces)))]
                x0, y0, x1, y1 = space.carve
                doors = [d.centre for d in self.plan.doors if on_boundary(d.centre, space.rect)]
                anchors = doors or [((x0 + x1) / 2, (y0 + y1) / 2)]
                ax, ay = anchors[int(self.rng.integers(len(anchors)))]
                x = snap(ax + self.rng.uniform(-PERSON_NEAR_DOOR_M, PERSON_NEAR_DOOR_M))
                y = snap(ay + self.rng.uniform(-PERSON_NEAR_DOOR_M, PERSON_NEAR_DOOR_M))
                box = flush(rect(x - r, y - r, x + r, y + r), space.carve)
                if box is not None and self._stands(box, space.carve):
                    x, y = round((box[0] + box[2]) / 2, 6), round((box[1] + box[3]) / 2, 6)
                    out.append({"floor": self.plan.name, "x": x, "y": y, "radius_m": r})
                    break
        return out

    def _stands(self, box: Rect, inner: Rect) -> bool:
        """Whether a person fits in ``box`` of the space ``inner`` as furniture would,
        the people so far counting as furniture; if so the person stays (an obstacle)."""
        if any(rect_gap(box, p) < PASSAGE - EPS for p in self.people):
            return False
        if not fits(self.state(), box, inner):
            return False

        def change() -> Rect:
            self.people.append(box)
            return box

        return self._try(change)


def draw_world(plan: BuildingPlan, seed: int) -> tuple[BuildingPlan, WorldDiff]:
    """A copy of ``plan`` altered as the world differs from it, and what differs."""
    rng = np.random.default_rng([seed, WORLD_STREAM])
    world = copy.deepcopy(plan)
    floors = [WorldFloor(f, world.lifts, rng) for f in world.floors]
    diff = WorldDiff()
    for wf in floors:
        diff.furniture_removed += wf.remove_furniture()
    diff.walls += move_one_wall(floors, rng)
    for wf in floors:
        diff.doors += wf.move_doors()
    for wf in floors:
        diff.furniture_added += wf.add_furniture(int(rng.integers(*ADDED_PER_FLOOR, endpoint=True)))
    for wf in floors:  # last: the draws before are those of a world without people
        diff.people += wf.add_people(int(rng.integers(*PEOPLE_PER_FLOOR, endpoint=True)))
    return world, diff


def move_one_wall(floors: list[WorldFloor], rng: np.random.Generator) -> list[dict]:
    """Move one partition of the building (tried in random order) by up to 0.20 m; the
    record of the one moved (none if no partition can move)."""
    parts = [(wf, p) for wf in floors for p in wf.partitions()]
    for i in rng.permutation(len(parts)):
        wf, part = parts[int(i)]
        for shift in rng.permutation(SHIFTS_M):
            record = wf.move_wall(part, float(shift))
            if record is not None:
                return [record]
    return []


def shifted(door: DoorSpec, offset: float) -> DoorSpec:
    """``door`` moved ``offset`` metres along ``p1 -> p2`` (its leaf with it)."""
    ux, uy = (door.p2[0] - door.p1[0]) / door.width, (door.p2[1] - door.p1[1]) / door.width
    dx, dy = round(ux * offset, 6), round(uy * offset, 6)

    def pt(p: tuple[float, float]) -> tuple[float, float]:
        return (round(p[0] + dx, 6), round(p[1] + dy, 6))

    leaf = None
    if door.leaf is not None:
        leaf = rect(*pt(door.leaf[:2]), *pt(door.leaf[2:]))
    return replace(door, p1=pt(door.p1), p2=pt(door.p2), leaf=leaf)


def door_gap(door: DoorSpec) -> Rect:
    """The opening a door stands in: its segment through the wall's thickness."""
    wall, p1t, p2t = door_wall(door)
    return wall.rect(min(p1t, p2t), max(p1t, p2t), -HALF, HALF)


def _partition(g: Space, s: Space, axis: int, sign: int) -> Partition | None:
    """The partition between ``g`` and ``s`` if ``s`` lies ``sign`` of ``g`` along
    ``axis`` across one wall and its side there is within ``g``'s; else None."""
    if g is s:
        return None
    gc, sc, j = g.carve, s.carve, 1 - axis
    touching = sc[axis] - gc[axis + 2] if sign > 0 else gc[axis] - sc[axis + 2]
    if abs(touching - WALL) > EPS:
        return None
    if sc[j] < gc[j] - EPS or sc[j + 2] > gc[j + 2] + EPS:
        return None
    return Partition(g, s, axis, sign)


def _opening_zones(opening: Rect) -> list[Rect]:
    """The straight approaches kept clear on both sides of a doorless opening."""
    x0, y0, x1, y1 = opening
    if x1 - x0 < y1 - y0:  # the wall runs along y
        return [rect(x0 - STRAIGHT, y0, x0, y1), rect(x1, y0, x1 + STRAIGHT, y1)]
    return [rect(x0, y0 - STRAIGHT, x1, y0), rect(x0, y1, x1, y1 + STRAIGHT)]


def _hull(a: Rect, b: Rect) -> Rect:
    return (min(a[0], b[0]), min(a[1], b[1]), max(a[2], b[2]), max(a[3], b[3]))


def _index(rects: list[Rect], r: Rect) -> int | None:
    """Where ``r`` is in ``rects`` (to the µm), None if it is not."""
    for i, c in enumerate(rects):
        if all(abs(a - b) < EPS for a, b in zip(c, r, strict=True)):
            return i
    return None
