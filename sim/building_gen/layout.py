"""One floor's layout: a corridor spine, maybe a branch and a hall, rooms and suites.

The plan is laid out in its own frame (the spine runs along x, its north wall on y = 0,
the lift lobby north of it) and turned as a whole afterwards. Spaces are rectangles on
wall centre lines that never overlap (corridor pieces excepted: they form one open
area), so walls are at least 0.2 m thick. Rooms line every corridor wall; each gets its
door onto the corridor, some a second one or a door to their neighbour (so a stuck door
can be bypassed), and some are suites reached through an ante-room. A corridor too
narrow for a 1.5 m turning disc in front of a door is widened there by an alcove (the
rooms along it stand back from the corridor wall to make room for it) and at its ends by
a bay.
Between two doors in series there is 1.22 m plus the width of a leaf swinging into that
room (the accessible-building rule for vestibules, :func:`vestibule_depth_m`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from sim.building_gen.doors import DISC_R, Wall, place_door, vestibule_depth_m
from sim.building_gen.furnish import add_columns, furnish, place_at, place_in
from sim.building_gen.geometry import HALF, RES, Rect, on_boundary, pick, rect
from sim.building_gen.lobby import Lobby
from sim.building_gen.options import GenOptions
from sim.building_gen.plan import DoorSpec, FloorPlan, Point, Space
from sim.building_gen.state import FloorState

NARROW = 1.8  # corridors narrower than this get bays at their ends (places need 0.9 m)
BAY = 2.2  # a bay's footprint on centre lines (2.0 m free)
DEEP = 99.0  # the depth of a corridor seen from its end wall


@dataclass(frozen=True)
class Frontage:
    """A corridor wall rooms can line: ``t`` runs along it, ``v`` > 0 away from the corridor."""

    name: str
    horizontal: bool  # the wall is y = line (t is x) or x = line (t is y)
    line: float
    sign: int  # the room side lies towards +1 or -1
    lo: float  # the corridor's free span along the wall, where doors can open
    hi: float
    depth: float  # the corridor's free depth in front of the wall
    area: str

    def xy(self, t: float, v: float) -> Point:
        c = round(self.line + self.sign * v, 6)
        return (round(t, 6), c) if self.horizontal else (c, round(t, 6))

    def rect(self, t0: float, t1: float, v0: float, v1: float) -> Rect:
        (ax, ay), (bx, by) = self.xy(t0, v0), self.xy(t1, v1)
        return rect(ax, ay, bx, by)

    def wall(self, v: float) -> Wall:
        return Wall(self.horizontal, round(self.line + self.sign * v, 6), self.sign)

    def cross(self, v: float) -> float:
        return round(self.line + self.sign * v, 6)


def pullback(depth: float) -> float:
    """How far rooms stand back so an alcove makes the turning disc fit a narrow corridor."""
    need = 2 * DISC_R + 0.05 - depth
    return 0.0 if need <= 1e-9 else round(math.ceil(need / RES - 1e-9) * RES, 6)


@dataclass
class _Row:
    """A room placed along a frontage, for doors between neighbours."""

    t0: float
    t1: float
    depth: float
    space: Space


class FloorBuilder:
    """Lays out one floor with the building's shared ``lobby`` (None: no lifts)."""

    def __init__(
        self,
        name: str,
        elevation: float,
        rng: np.random.Generator,
        opts: GenOptions,
        lobby: Lobby | None,
    ) -> None:
        self.st = FloorState(FloorPlan(name, elevation), rng)
        self.rng = rng
        self.opts = opts
        self.lobby = lobby
        self.name = name
        self.area = self.st.plan.corridor_area
        self.frontages: list[Frontage] = []
        self.ends: list[Frontage] = []
        self.alternatives = 0  # second doors and doors between neighbours
        self.spine_width = self.x0 = self.x1 = self.south = 0.0  # set by _spine

    # ---- the whole floor -------------------------------------------------------------

    def build(self) -> FloorPlan:
        """Lay out the floor and return its plan."""
        rng, o = self.rng, self.opts
        self._spine()
        if self.lobby is not None:
            self.lobby.register(self.st)
        branch = None
        if o.branches and rng.random() < 0.6:
            style = str(rng.choice(["T", "T", "L"]))
            branch = (style, str(rng.choice(["north", "south"])), str(rng.choice(["east", "west"])))
        ends = [e for e in self.ends if not (branch and branch[0] == "L" and e.name == branch[2])]
        self.ends = [self._bay(e) if self.spine_width < NARROW else e for e in ends]
        hall_at = None
        if o.halls and rng.random() < o.hall_probability:
            hall_at = str(rng.choice([e.name for e in self.ends] + ["south", "south"]))
        for e in self.ends:
            self._end_place(e)
        if hall_at is not None:
            self._hall(hall_at)
        if branch is not None:
            self._branch(*branch)
        order = self.frontages + [e for e in self.ends if e.name != hall_at]
        for i in rng.permutation(len(order)):
            self._fill(order[int(i)])
        self._furnish()
        return self.st.plan

    # ---- corridors ---------------------------------------------------------------------

    def _spine(self) -> None:
        rng, o = self.rng, self.opts
        width = pick(rng, *o.corridor_width_m, 0.1)
        length = pick(rng, *o.spine_length_m, 0.1)
        if self.lobby is not None:  # >= 5.5 m of corridor west of the lobby, 2.5 m east
            length = max(length, round(self.lobby.width_c + 8.0, 6))
            x0 = -pick(rng, 5.5, length - self.lobby.width_c - 2.3, 0.1)
        else:
            x0 = 0.0
        x1 = round(x0 + length + 2 * HALF, 6)
        south = round(-(width + 2 * HALF), 6)
        self.spine_width = width
        self.x0, self.x1, self.south = x0, x1, south
        spine = Space(
            "spine",
            self.name,
            "spine",
            self.area,
            (x0, south, x1, 0.0),
            (x0 + HALF, south + HALF, x1 - HALF, -HALF),
        )
        self.st.add_space(spine)
        self.st.plan.corridor_widths.append(width)
        lo, hi = round(x0 + HALF, 6), round(x1 - HALF, 6)
        self.frontages += [
            Frontage("north", True, 0.0, 1, lo, hi, width, self.area),
            Frontage("south", True, south, -1, lo, hi, width, self.area),
        ]
        ylo, yhi = round(south + HALF, 6), -HALF
        self.ends = [
            Frontage("west", False, x0, -1, ylo, yhi, DEEP, self.area),
            Frontage("east", False, x1, 1, ylo, yhi, DEEP, self.area),
        ]

    def _bay(self, end: Frontage) -> Frontage:
        """Widen a narrow corridor's last 2 m to 2 m; returns the end with its wider span."""
        mid = round((end.lo + end.hi) / 2, 6)
        half = BAY / 2
        bay = Space(
            f"bay_{end.name}",
            self.name,
            "bay",
            self.area,
            end.rect(mid - half, mid + half, -BAY, 0.0),
            end.rect(mid - half + HALF, mid + half - HALF, HALF - BAY, -HALF),
        )
        if not self.st.add_space(bay):
            return end
        return replace(end, lo=round(mid - half + HALF, 6), hi=round(mid + half - HALF, 6))

    def _end_place(self, end: Frontage) -> None:
        mid = round((end.lo + end.hi) / 2, 6)
        x, y = end.xy(mid, -(HALF + 1.0))
        n = self.st.next_id("corridor_place")
        place_at(self.st, f"f{self.name}_corridor{n}", self.area, "corridor", x, y)

    def _branch(self, style: str, side: str, end: str) -> None:
        """A corridor off the spine: from its middle (T) or flush with one end (L)."""
        rng, st = self.rng, self.st
        width = pick(rng, *self.opts.corridor_width_m, 0.1)
        length = pick(rng, 6.0, 20.0, 0.1)
        wc = round(width + 2 * HALF, 6)
        if style == "L":
            xs = [self.x1 - wc if end == "east" else self.x0]
        else:
            xs = [pick(rng, self.x0 + 2.0, self.x1 - wc - 2.0, 0.1) for _ in range(6)]
        base = 0.0 if side == "north" else self.south
        sign = 1 if side == "north" else -1
        along = Frontage("stem", False, 0.0, 1, 0.0, 0.0, 0.0, self.area)
        for bx in xs:
            bx = round(bx, 6)
            far = round(base + sign * (length + 2 * HALF), 6)
            space = Space(
                "branch",
                self.name,
                "branch",
                self.area,
                rect(bx, base, bx + wc, far),
                rect(bx + HALF, base + sign * HALF, bx + wc - HALF, far - sign * HALF),
            )
            mark = st.mark()
            opening = rect(bx + HALF, base - HALF, bx + wc - HALF, base + HALF)
            if not (st.add_space(space) and st.carve(opening)):
                st.rollback(mark)
                continue
            st.plan.corridor_widths.append(width)
            lo, hi = sorted((round(base + sign * HALF, 6), round(far - sign * HALF, 6)))
            self.frontages += [
                replace(along, name="branch_w", line=bx, sign=-1, lo=lo, hi=hi, depth=width),
                replace(along, name="branch_e", line=round(bx + wc, 6), lo=lo, hi=hi, depth=width),
            ]
            tip = Frontage(
                "branch_end",
                True,
                far,
                sign,
                round(bx + HALF, 6),
                round(bx + wc - HALF, 6),
                DEEP,
                self.area,
            )
            tip = self._bay(tip) if width < NARROW else tip
            self._end_place(tip)
            self.ends.append(tip)
            return

    # ---- rooms -------------------------------------------------------------------------

    def _front_door(
        self, f: Frontage, r: float, lo: float, hi: float, area: str
    ) -> DoorSpec | None:
        """A door from the corridor into ``area`` in the wall ``r`` behind the frontage."""
        st = self.st

        def alcove(t_lo: float, t_hi: float) -> bool:
            if r <= 0:
                return True
            c = (t_lo + t_hi) / 2
            a0 = round(math.floor((c - DISC_R - 0.05) / RES + 1e-9) * RES, 6)
            a1 = round(math.ceil((c + DISC_R + 0.05) / RES - 1e-9) * RES, 6)
            if a0 < f.lo - 1e-9 or a1 > f.hi + 1e-9:
                return False
            n = st.next_id("alcove")
            space = Space(
                f"alcove{n}",
                self.name,
                "alcove",
                f.area,
                f.rect(a0 - HALF, a1 + HALF, 0.0, r),
                f.rect(a0, a1, -HALF, r - HALF),
            )
            return st.add_space(space)

        return place_door(st, f.wall(r), lo, hi, f.area, area, before=alcove)

    def _room(self, f: Frontage, t0: float, wc: float, dc: float, r: float) -> Space | None:
        """A room ``wc`` x ``dc`` (centre lines) at ``t0`` with its corridor door(s) and place."""
        st = self.st
        n = st.counters.get("room", 0) + 1
        space = Space(
            f"room{n:02d}",
            self.name,
            "room",
            f"{self.name}:room{n:02d}",
            f.rect(t0, t0 + wc, r, r + dc),
            f.rect(t0 + HALF, t0 + wc - HALF, r + HALF, r + dc - HALF),
        )
        if not st.fits(space.rect, "room"):
            return None
        mark = st.mark()
        st.next_id("room")
        st.add_space(space)
        lo, hi = (
            round(max(t0 + 2 * HALF, f.lo + HALF), 6),
            round(min(t0 + wc - 2 * HALF, f.hi - HALF), 6),
        )
        door = self._front_door(f, r, lo, hi, space.area)
        if door is None:
            st.rollback(mark)
            return None
        if hi - lo >= 4.0 and self.rng.random() < 0.35:
            a, b = sorted((door.p1[0 if f.horizontal else 1], door.p2[0 if f.horizontal else 1]))
            left, right = (lo, round(a - 1.0, 6)), (round(b + 1.0, 6), hi)
            span = left if left[1] - left[0] > right[1] - right[0] else right
            if self._front_door(f, r, *span, space.area) is not None:
                self.alternatives += 1
        if not place_in(st, f"f{self.name}_room{n:02d}", space, "room"):
            st.rollback(mark)
            return None
        return space

    def _suite(self, f: Frontage, t0: float, r: float, end: float) -> float | None:
        """An ante-room on the corridor and a room behind it: two doors in series."""
        rng, st = self.rng, self.st
        awc = pick(rng, 1.9, min(3.7, end - t0), 0.1)  # ante free width 1.7-3.5 m
        adc = pick(rng, 1.8, 3.2, 0.1)  # free depth 1.6-3.0 m: the doors' gap
        lo_room = self.opts.room_size_m[0] + 2 * HALF
        iwc = pick(rng, max(lo_room, awc), min(7.2, end - t0 + 3.0), 0.1)
        idc = pick(rng, lo_room, max(lo_room, min(6.2, self.opts.room_size_m[1] + 2 * HALF)), 0.1)
        shift = pick(rng, 0.0, iwc - awc, 0.1) if rng.random() < 0.5 else 0.0
        i0 = round(t0 - shift, 6)
        n = st.counters.get("suite", 0) + 1
        ante = Space(
            f"ante{n:02d}",
            self.name,
            "ante",
            f"{self.name}:ante{n:02d}",
            f.rect(t0, t0 + awc, r, r + adc),
            f.rect(t0 + HALF, t0 + awc - HALF, r + HALF, r + adc - HALF),
        )
        inner = Space(
            f"suite{n:02d}",
            self.name,
            "inner",
            f"{self.name}:suite{n:02d}",
            f.rect(i0, i0 + iwc, r + adc, r + adc + idc),
            f.rect(i0 + HALF, i0 + iwc - HALF, r + adc + HALF, r + adc + idc - HALF),
        )
        if not (st.fits(ante.rect, "ante") and st.fits(inner.rect, "inner")):
            return None
        mark = st.mark()
        st.next_id("suite")
        st.add_space(ante)
        st.add_space(inner)
        lo, hi = (
            round(max(t0 + 2 * HALF, f.lo + HALF), 6),
            round(min(t0 + awc - 2 * HALF, f.hi - HALF), 6),
        )
        outer = self._front_door(f, r, lo, hi, ante.area)
        if outer is not None and adc - 2 * HALF < vestibule_depth_m(outer, self.opts.vestibule_m):
            st.rollback(mark)
            return None
        lo, hi = round(max(t0, i0) + 2 * HALF, 6), round(min(t0 + awc, i0 + iwc) - 2 * HALF, 6)
        second = place_door(st, f.wall(r + adc), lo, hi, ante.area, inner.area) if outer else None
        if second is None or not place_in(st, f"f{self.name}_suite{n:02d}", inner, "inner"):
            st.rollback(mark)
            return None
        st.plan.series.append((outer.id, second.id, round(adc - 2 * HALF, 6)))
        return round(max(t0 + awc, i0 + iwc), 6)

    def _fill(self, f: Frontage) -> None:
        """Line a frontage with rooms and suites (and a few gaps) from end to end."""
        rng, o = self.rng, self.opts
        r = pullback(f.depth)
        lo_room, hi_room = (round(s + 2 * HALF, 6) for s in o.room_size_m)
        single = f.depth >= DEEP  # an end wall: one room, overhanging the corridor's span
        if single:
            if rng.random() < 0.5:
                return
            wc = pick(rng, max(lo_room, f.hi - f.lo + 2 * HALF), max(lo_room, hi_room), 0.1)
            t0 = round(f.lo - HALF - pick(rng, 0.0, wc - (f.hi - f.lo) - 2 * HALF, 0.1), 6)
            self._room(f, t0, wc, pick(rng, lo_room, hi_room, 0.1), r)
            return
        t, end = round(f.lo - HALF, 6), round(f.hi + HALF, 6)
        rows: list[_Row] = []
        while end - t >= lo_room - 1e-9:
            u = rng.random()
            if u < 0.1:
                t = round(t + pick(rng, 0.5, 3.0, 0.1), 6)
                continue
            if o.suites and u < 0.1 + o.suite_probability:
                stop = self._suite(f, t, r, end)
                if stop is not None:
                    t = stop
                    continue
            wc = pick(rng, lo_room, min(hi_room, end - t), 0.1)
            if end - t - wc < lo_room and end - t <= hi_room and rng.random() < 0.7:
                wc = round(end - t, 6)
            space = None
            for dc in sorted(
                {pick(rng, lo_room, hi_room, 0.1), lo_room + 1.0, lo_room}, reverse=True
            ):
                space = self._room(f, t, wc, dc, r)
                if space is not None:
                    rows.append(_Row(t, round(t + wc, 6), dc, space))
                    break
            t = round(t + wc, 6) if space is not None else round(t + 0.5, 6)
        self._neighbours(f, r, rows)

    def _neighbours(self, f: Frontage, r: float, rows: list[_Row]) -> None:
        """Doors between rooms side by side (always one per floor if none exists yet)."""
        pairs = [(a, b) for a, b in zip(rows, rows[1:], strict=False) if abs(a.t1 - b.t0) < 1e-6]
        for a, b in pairs:
            if self.rng.random() < 0.35 or self.alternatives == 0:
                lo, hi = sorted(
                    (f.cross(r + 2 * HALF), f.cross(r + min(a.depth, b.depth) - 2 * HALF))
                )
                wall = Wall(not f.horizontal, a.t1, 1)
                if place_door(self.st, wall, lo, hi, a.space.area, b.space.area) is not None:
                    self.alternatives += 1

    # ---- halls -------------------------------------------------------------------------

    def _hall(self, where: str) -> None:
        """A hall (up to 30 m a side, maybe with columns) off an end or the south wall."""
        rng, st = self.rng, self.st
        hw = round(pick(rng, *self.opts.hall_size_m, 0.1) + 2 * HALF, 6)
        hd = round(pick(rng, *self.opts.hall_size_m, 0.1) + 2 * HALF, 6)
        f = next(e for e in self.ends + self.frontages if e.name == where)
        r = pullback(f.depth)
        span = f.hi - f.lo
        if f.depth >= DEEP:
            t0 = round(f.lo - HALF - pick(rng, 1.2, hw - span - 1.4, 0.1), 6)
        else:
            t0 = round(pick(rng, f.lo - hw + 4.0, f.hi - 4.0, 0.1), 6)
        join = "opening" if rng.random() < 0.3 else "door"
        n = st.next_id("hall")
        area = f.area if join == "opening" else f"{self.name}:hall{n}"
        hall = Space(
            f"hall{n}",
            self.name,
            "hall",
            area,
            f.rect(t0, t0 + hw, r, r + hd),
            f.rect(t0 + HALF, t0 + hw - HALF, r + HALF, r + hd - HALF),
        )
        mark = st.mark()
        if not st.add_space(hall):
            st.rollback(mark)
            return
        lo, hi = (
            round(max(t0 + 2 * HALF, f.lo + HALF), 6),
            round(min(t0 + hw - 2 * HALF, f.hi - HALF), 6),
        )
        if join == "door":
            ok = self._front_door(f, r, lo, hi, area) is not None
        else:
            ok = hi - lo >= 2.0 and self._opening(f, r, lo, hi)
        if not ok:
            st.rollback(mark)
            return
        if self.opts.columns and rng.random() < 0.6:
            add_columns(st, hall)
        placed = 0
        for k in range(int(rng.integers(2, 5))):
            placed += place_in(st, f"f{self.name}_hall{n}_{k + 1}", hall, "hall", apart=3.0)
        if placed < 2:
            st.rollback(mark)

    def _opening(self, f: Frontage, r: float, lo: float, hi: float) -> bool:
        """A 2-4 m wide opening between the corridor and a hall (no door)."""
        width = pick(self.rng, 2.0, min(4.0, hi - lo), 0.1)
        o0 = pick(self.rng, lo, hi - width, RES)
        opening = f.rect(o0, o0 + width, -HALF, r + HALF)
        if not self.st.carve(opening):
            return False
        self.st.plan.openings.append(opening)
        self.st.keep_rect("zone", "opening", f.rect(o0, o0 + width, -HALF - 1.2, -HALF))
        self.st.keep_rect("zone", "opening", f.rect(o0, o0 + width, r + HALF, r + HALF + 1.2))
        return True

    # ---- furniture ---------------------------------------------------------------------

    def _furnish(self) -> None:
        if not self.opts.furniture:
            return
        st = self.st
        for space in list(st.plan.spaces):
            if space.kind not in ("room", "inner", "hall") or space.carve is None:
                continue
            anchors = [d.centre for d in st.plan.doors if on_boundary(d.centre, space.rect)]
            if not anchors:
                x0, y0, x1, y1 = space.carve
                anchors = [((x0 + x1) / 2, (y0 + y1) / 2)]
            count = (
                int(self.rng.integers(2, 7))
                if space.kind == "hall"
                else int(self.rng.integers(0, 3))
            )
            furnish(st, space, anchors, count)
