"""Doors: where a door may go in a wall and whether it leaves the chair room to use it.

A door is accepted only if, on both sides, a disc of 0.8 m radius (the 1.5 m turning
circle plus a margin) touches the wall face next to the opening and lies in free space,
and a straight approach of 1.2 m runs from the opening along its normal. A hinged leaf
turns about ``p1`` into side B of its wall (the room) and, open, must stay out of every
other door's discs and approaches and of places; a sliding leaf runs past ``p2`` into a
pocket of solid wall that nothing may ever carve.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from sim.building_gen.geometry import (
    HALF,
    RES,
    Rect,
    disc_points,
    overlaps,
    pick,
    rect,
    rect_points,
)
from sim.building_gen.plan import DoorSpec, Point
from sim.building_gen.state import FloorState

DISC_R = 0.8  # the promised turning disc has a 0.75 m radius; 5 cm of margin
STRAIGHT = 1.2  # free straight approach on both sides of a door
LEAF = 0.05  # leaf thickness
WIDTHS = (0.8, 1.2)  # free door width range

# a door's needs: turning-disc centres, open leaf, its sweep, sliding pocket
Found = tuple[list[Point], Rect | None, Rect | None, Rect | None]


def vestibule_depth_m(outer: DoorSpec, vestibule_m: float) -> float:
    """The least free depth of the room between two doors in series whose first door is
    ``outer`` (its leaf, if hinged, swings into that room): ``vestibule_m`` (1.22 m in
    accessible buildings, ADA 2010 section 404.2.6) plus the width of that leaf. In a
    shallower one a chair 1.1 m long barely turns beside the open leaf: campaign
    b2010.m00 (seed 2010 before this rule), 1.6 m behind an 0.85 m leaf, leaves a
    five-move manoeuvre keeping 5.4 cm from the leaf and the walls (a search on a 1.25 cm
    grid) and none on the 5 cm grid the controller plans on; the chair reaches each pose
    within 3 cm. ``vestibule_m`` 0: no rule."""
    if vestibule_m <= 0:
        return 0.0
    return vestibule_m + (outer.width if outer.motion == "hinged" else 0.0)


@dataclass(frozen=True)
class Wall:
    """An axis-aligned wall centre line; ``t`` runs along it, ``n`` > 0 is side B."""

    horizontal: bool  # the line is y = line (t is x) or x = line (t is y)
    line: float
    b_sign: int  # side B lies towards +1 or -1 of the line's coordinate

    def xy(self, t: float, n: float) -> Point:
        v = round(self.line + self.b_sign * n, 6)
        return (round(t, 6), v) if self.horizontal else (v, round(t, 6))

    def rect(self, t0: float, t1: float, n0: float, n1: float) -> Rect:
        (ax, ay), (bx, by) = self.xy(t0, n0), self.xy(t1, n1)
        return rect(ax, ay, bx, by)


def draw_type(rng: np.random.Generator) -> tuple[str, str, bool]:
    """A random (type, motion, controller): manual doors mostly hinged without a controller."""
    u = rng.random()
    if u < 0.55:
        return "manual", "hinged" if rng.random() < 0.85 else "sliding", bool(rng.random() < 0.15)
    if u < 0.8:
        return "automatic", "sliding", True
    return "powered", "hinged" if rng.random() < 0.5 else "sliding", True


def place_door(
    st: FloorState,
    wall: Wall,
    lo: float,
    hi: float,
    area_a: str,
    area_b: str,
    *,
    before: Callable[[float, float], bool] | None = None,
    tries: int = 12,
    corner_bias: float = 0.3,
) -> DoorSpec | None:
    """Put a door somewhere in ``[lo, hi]`` along ``wall``, between A (n < 0) and B (n > 0).

    ``before(t_lo, t_hi)`` may carve what the door needs first (an alcove) and return
    False to refuse the spot. Returns the committed door, or None (nothing changed).
    """
    rng = st.rng
    if hi - lo < WIDTHS[0] - 1e-9:
        return None
    for _ in range(tries):
        width = pick(rng, WIDTHS[0], min(WIDTHS[1], hi - lo), RES)
        if rng.random() < corner_bias:
            t_lo = lo if rng.random() < 0.5 else round(hi - width, 6)
        else:
            t_lo = pick(rng, lo, hi - width, RES)
        door_type, motion, controller = draw_type(rng)
        mark = st.mark()
        if before is not None and not before(t_lo, t_lo + width):
            st.rollback(mark)
            continue
        door = _commit_first(st, wall, t_lo, width, door_type, motion, controller, area_a, area_b)
        if door is not None:
            return door
        st.rollback(mark)
    return None


def _commit_first(
    st: FloorState,
    wall: Wall,
    t_lo: float,
    width: float,
    door_type: str,
    motion: str,
    controller: bool,
    area_a: str,
    area_b: str,
) -> DoorSpec | None:
    """Try both orientations of the door at ``t_lo``; commit and return the first that works."""
    t_hi = round(t_lo + width, 6)
    gap = wall.rect(t_lo, t_hi, -HALF, HALF)
    if any(overlaps(gap, p) for p in st.pockets):
        return None
    flip = st.rng.random() < 0.5
    for low_first in (not flip, flip):
        p1t, p2t = (t_lo, t_hi) if low_first else (t_hi, t_lo)
        door_id = f"d{st.plan.name}_{st.counters.get('door', 0) + 1:03d}"
        found = door_rules(st, wall, p1t, p2t, motion, door_id)
        if found is None:
            continue
        _, leaf, _, pocket = found
        st.next_id("door")
        st.carve(gap)
        p1, p2 = wall.xy(p1t, 0.0), wall.xy(p2t, 0.0)
        door = DoorSpec(
            door_id,
            st.plan.name,
            p1,
            p2,
            door_type,
            motion,
            _swing(wall, p1, p2) if motion == "hinged" else "",
            controller,
            area_a,
            area_b,
            leaf,
        )
        st.plan.doors.append(door)
        keep_door(st, wall, t_lo, t_hi, door_id, found)
        if leaf is not None:
            st.free.obstacles.append(leaf)
        if pocket is not None:
            st.pockets.append(pocket)
        return door
    return None


def door_rules(
    st: FloorState, wall: Wall, p1t: float, p2t: float, motion: str, door_id: str
) -> Found | None:
    """What a door from ``p1t`` to ``p2t`` along ``wall`` needs, if the floor as it stands
    gives it: turning discs on both sides, and the open leaf and the quarter it sweeps
    (hinged) or the pocket its leaf runs into (sliding); None where it is denied."""
    if motion == "hinged":
        return _hinged(st, wall, p1t, p2t, door_id)
    return _sliding(st, wall, p1t, p2t, door_id)


def keep_door(
    st: FloorState, wall: Wall, t_lo: float, t_hi: float, door_id: str, found: Found
) -> None:
    """Keep what a door needs clear from later steps: its discs and straight approaches
    (no leaf, column or furniture) and its leaf's sweep (no furniture, no other sweep)."""
    discs, leaf, sweep, _ = found
    for x, y in discs:
        st.keep_disc("zone", door_id, x, y, DISC_R)
    for side in (-1, 1):
        st.keep_rect("zone", door_id, _strip(wall, t_lo, t_hi, side))
    if leaf is not None:
        st.keep_rect("sweep", door_id, sweep)


def door_wall(door: DoorSpec) -> tuple[Wall, float, float]:
    """The wall ``door`` stands in (side B the side its hinged leaf swings into) and where
    ``p1`` and ``p2`` lie along it."""
    (x1, y1), (x2, y2) = door.p1, door.p2
    horizontal = abs(y1 - y2) < 1e-9
    line, p1t, p2t = (y1, x1, x2) if horizontal else (x1, y1, y2)
    wall = Wall(horizontal, line, 1)
    if door.motion == "hinged" and _swing(wall, door.p1, door.p2) != door.swing:
        wall = Wall(horizontal, line, -1)
    return wall, p1t, p2t


def _strip(wall: Wall, t_lo: float, t_hi: float, side: int) -> Rect:
    return wall.rect(t_lo, t_hi, side * HALF, side * (HALF + STRAIGHT))


def _swing(wall: Wall, p1: Point, p2: Point) -> str:
    """'left' if side B is on the left of p1 -> p2."""
    dx, dy = p2[0] - p1[0], p2[1] - p1[1]
    bx, by = (0.0, wall.b_sign) if wall.horizontal else (wall.b_sign, 0.0)
    return "left" if -dy * bx + dx * by > 0 else "right"


def _approaches_free(st: FloorState, wall: Wall, t_lo: float, t_hi: float) -> bool:
    return all(st.free.free(rect_points(_strip(wall, t_lo, t_hi, s))) for s in (-1, 1))


def _disc(st: FloorState, wall: Wall, side: int, candidates: list[float]) -> Point | None:
    """The first free turning-disc centre among lateral ``candidates`` on ``side``."""
    n = side * (HALF + DISC_R)
    for t in candidates:
        x, y = wall.xy(t, n)
        if st.free.free(disc_points(x, y, DISC_R)):
            return (x, y)
    return None


def _centred(t_lo: float, t_hi: float) -> list[float]:
    """Lateral disc positions across the opening, from its middle outwards."""
    mid = (t_lo + t_hi) / 2
    half = (t_hi - t_lo) / 2 + RES
    out = [mid]
    k = 1
    while k * RES <= half + 1e-9:
        out += [mid - k * RES, mid + k * RES]
        k += 1
    return out


def _hinged(st: FloorState, wall: Wall, p1t: float, p2t: float, door_id: str) -> Found | None:
    """Discs, leaf, sweep for a leaf hinged at ``p1t`` swinging into side B; None if blocked."""
    width = abs(p2t - p1t)
    d = 1.0 if p2t > p1t else -1.0
    t_lo, t_hi = min(p1t, p2t), max(p1t, p2t)
    leaf = wall.rect(p1t - LEAF / 2, p1t + LEAF / 2, 0.0, width)
    sweep = wall.rect(p1t, p2t, HALF, width)
    if not st.free.free(rect_points(sweep)) or st.blocked(leaf, ("zone",), door_id):
        return None
    if st.blocked(sweep, ("sweep",), door_id):
        return None
    if not _approaches_free(st, wall, t_lo, t_hi):
        return None
    # Side B holds the open leaf: the disc keeps >= DISC_R + LEAF/2 from the hinge line.
    reach = max(width / 2, DISC_R + LEAF)
    b_lat = [p1t + d * r for r in np.arange(reach, width + RES + 1e-9, RES)]
    disc_b = _disc(st, wall, 1, [round(t, 6) for t in b_lat])
    disc_a = _disc(st, wall, -1, _centred(t_lo, t_hi))
    if disc_a is None or disc_b is None:
        return None
    return [disc_a, disc_b], leaf, sweep, None


def _sliding(st: FloorState, wall: Wall, p1t: float, p2t: float, door_id: str) -> Found | None:
    """Discs and pocket for a leaf sliding past ``p2t``; None if blocked."""
    pocket = door_pocket(wall, p1t, p2t)
    if st.free.any_carved(rect_points(rect(*_shrink_along(pocket)))):
        return None
    t_lo, t_hi = min(p1t, p2t), max(p1t, p2t)
    if not _approaches_free(st, wall, t_lo, t_hi):
        return None
    discs = [_disc(st, wall, s, _centred(t_lo, t_hi)) for s in (-1, 1)]
    if None in discs:
        return None
    return discs, None, None, pocket


def door_pocket(wall: Wall, p1t: float, p2t: float) -> Rect:
    """The wall stretch past ``p2t`` a sliding leaf from ``p1t`` to ``p2t`` runs into."""
    d = 1.0 if p2t > p1t else -1.0
    return wall.rect(p2t, p2t + d * abs(p2t - p1t), -LEAF / 2 - 0.005, LEAF / 2 + 0.005)


def _shrink_along(r: Rect) -> Rect:
    """``r`` minus 1 cm at each end, so the pocket may touch its own door's gap."""
    if r[2] - r[0] > r[3] - r[1]:
        return (r[0] + 0.01, r[1], r[2] - 0.01, r[3])
    return (r[0], r[1] + 0.01, r[2], r[3] - 0.01)
