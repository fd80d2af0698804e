"""What goes inside the spaces: named places, hall columns and furniture near doors.

Places get a free disc of 0.9 m (the promise is 0.8 m) so the chair can stand there at
any heading. Columns and furniture keep out of every keep-out zone (turning discs,
straight approaches, places, leaf sweeps) and leave either nothing (flush against a
wall) or at least 0.9 m of passage to every wall and other obstacle, so they never cut
a room in two.
"""

from __future__ import annotations

import math

from sim.building_gen.geometry import (
    RES,
    Rect,
    disc_points,
    overlaps,
    pick,
    rect,
    rect_gap,
    rect_points,
    snap,
)
from sim.building_gen.plan import PlaceSpec, Space
from sim.building_gen.state import FloorState

PLACE_CLEARANCE = 0.9
PASSAGE = 0.9  # free passage around furniture and columns


def place_at(st: FloorState, name: str, area: str, kind: str, x: float, y: float) -> bool:
    """Name the pose at ``(x, y)`` (random heading) if it has its clearance; else False."""
    if not st.free.free(disc_points(x, y, PLACE_CLEARANCE)):
        return False
    theta = round(float(st.rng.uniform(-math.pi, math.pi)), 4)
    st.plan.places.append(PlaceSpec(name, st.plan.name, x, y, theta, area, kind))
    st.keep_disc("zone", name, x, y, PLACE_CLEARANCE)
    return True


def place_in(
    st: FloorState,
    name: str,
    space: Space,
    kind: str,
    tries: int = 60,
    apart: float = 0.0,
) -> bool:
    """A place at a random free spot of ``space``, ``apart`` metres from the floor's others."""
    assert space.carve is not None
    x0, y0, x1, y1 = space.carve
    m = PLACE_CLEARANCE
    if x1 - x0 < 2 * m or y1 - y0 < 2 * m:
        return False
    for _ in range(tries):
        x = pick(st.rng, snap(x0 + m + RES / 2), x1 - m, RES)
        y = pick(st.rng, snap(y0 + m + RES / 2), y1 - m, RES)
        if apart and any(math.hypot(p.x - x, p.y - y) < apart for p in st.plan.places):
            continue
        if place_at(st, name, space.area, kind, x, y):
            return True
    return False


def add_columns(st: FloorState, hall: Space) -> None:
    """Square columns (0.3-0.6 m) on a 4-8 m grid, wherever they block nothing."""
    assert hall.carve is not None
    rng = st.rng
    spacing = pick(rng, 4.0, 8.0, 0.5)
    size = pick(rng, 0.3, 0.6, 0.1)
    x0, y0, x1, y1 = hall.carve
    margin = PASSAGE + 0.1 + size / 2
    gx = snap(x0 + margin + pick(rng, 0.0, spacing, RES))
    while gx <= x1 - margin:
        gy = snap(y0 + margin + pick(rng, 0.0, spacing, RES))
        while gy <= y1 - margin:
            col = rect(gx - size / 2, gy - size / 2, gx + size / 2, gy + size / 2)
            if not st.blocked(col, ("zone", "sweep")):
                st.plan.columns.append(col)
                st.free.obstacles.append(col)
            gy = snap(gy + spacing)
        gx = snap(gx + spacing)


def furnish(st: FloorState, space: Space, anchors: list[tuple[float, float]], count: int) -> None:
    """Up to ``count`` tables and cabinets (0.4-1.2 m) near the ``anchors`` (door middles)."""
    assert space.carve is not None
    rng = st.rng
    inner = space.carve
    for _ in range(count):
        for _ in range(25):
            ax, ay = anchors[int(rng.integers(len(anchors)))]
            sx, sy = pick(rng, 0.4, 1.2, 0.1), pick(rng, 0.4, 1.2, 0.1)
            cx = snap(ax + rng.uniform(-3.0, 3.0))
            cy = snap(ay + rng.uniform(-3.0, 3.0))
            box = flush(rect(cx - sx / 2, cy - sy / 2, cx + sx / 2, cy + sy / 2), inner)
            if box is not None and fits(st, box, inner):
                st.plan.furniture.append(box)
                st.free.obstacles.append(box)
                break


def flush(box: Rect, inner: Rect) -> Rect | None:
    """``box`` pushed against a wall it nearly touches; None if it sticks out of ``inner``."""
    x0, y0, x1, y1 = box
    dx = dy = 0.0
    if 0 < x0 - inner[0] < PASSAGE / 2:
        dx = inner[0] - x0
    elif 0 < inner[2] - x1 < PASSAGE / 2:
        dx = inner[2] - x1
    if 0 < y0 - inner[1] < PASSAGE / 2:
        dy = inner[1] - y0
    elif 0 < inner[3] - y1 < PASSAGE / 2:
        dy = inner[3] - y1
    box = rect(x0 + dx, y0 + dy, x1 + dx, y1 + dy)
    inside = box[0] >= inner[0] - 1e-9 and box[2] <= inner[2] + 1e-9
    inside = inside and box[1] >= inner[1] - 1e-9 and box[3] <= inner[3] + 1e-9
    return box if inside else None


def fits(st: FloorState, box: Rect, inner: Rect) -> bool:
    """Flush or >= PASSAGE from each wall, PASSAGE from other obstacles, clear of keep-outs.

    The other obstacles are every one the floor's free space holds: columns, furniture and
    the open leaves of hinged doors, since a table 0.7 m from a leaf's tip cuts a room in two
    as surely as one 0.7 m from another table.
    """
    gaps = (box[0] - inner[0], box[1] - inner[1], inner[2] - box[2], inner[3] - box[3])
    if any(1e-9 < g < PASSAGE - 1e-9 for g in gaps):
        return False
    for other in st.free.obstacles:
        if overlaps(box, other) or rect_gap(box, other) < PASSAGE - 1e-9:
            return False
    return not st.blocked(box, ("zone", "sweep")) and st.free.free(rect_points(box))
