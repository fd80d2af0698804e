"""The lift lobby: 2-4 lift cars around a lobby that sits at the same place on every floor.

Lifts must stand at the same x, y on every floor they serve while each floor has its
own layout, so the lobby and its shafts are drawn once per building and stamped onto
every floor, north of the floor's main corridor (whose north wall is the line y = 0 of
the plan; the lobby opens onto it over its whole width). Cars stand west, north or east
of the lobby and face into it; every car door gets a 1.5 m turning disc and a free
straight 2.0 m in front of it inside the lobby.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sim.building_gen.doors import DISC_R
from sim.building_gen.geometry import (
    HALF,
    FreeSpace,
    Rect,
    disc_points,
    grow,
    overlaps,
    pick,
    rect,
    rect_points,
)
from sim.building_gen.plan import LiftSpec, Space
from sim.building_gen.state import FloorState

LANDING_STRAIGHT = 2.0
HEADINGS = {"W": 0.0, "E": round(np.pi, 6), "N": round(-np.pi / 2, 6)}


@dataclass
class Lobby:
    """The lobby footprint ``(0, 0)-(width_c, depth_c)`` on centre lines and its lifts."""

    width_c: float
    depth_c: float
    lifts: list[LiftSpec]

    def carve(self) -> Rect:
        return (HALF, HALF, self.width_c - HALF, self.depth_c - HALF)

    def opening(self) -> Rect:
        """The lobby's south wall, removed: it is open to the corridor below."""
        return (HALF, -HALF, self.width_c - HALF, HALF)

    def register(self, st: FloorState) -> None:
        """Stamp the lobby, the shafts and (where the lift stops here) the cars onto a floor."""
        floor = st.plan.name
        area = st.plan.corridor_area
        st.add_space(
            Space(
                "lobby", floor, "lobby", area, (0.0, 0.0, self.width_c, self.depth_c), self.carve()
            )
        )
        st.carve(self.opening())
        for lift in self.lifts:
            serves = floor in lift.floors
            shaft = Space(
                f"shaft_{lift.id}",
                floor,
                "shaft",
                f"shaft:{lift.id}",
                grow(lift.interior(), HALF),
                lift.interior() if serves else None,
            )
            st.add_space(shaft)
            if serves:
                st.carve(_door_gap(lift))
            keep_lift(st, lift, serves)


def keep_lift(st: FloorState, lift: LiftSpec, serves: bool) -> None:
    """Keep the shaft wall solid where the car's leaf runs and, on a floor the lift
    serves, its landing's turning disc and straight approach clear of later steps."""
    st.pockets.extend(_pockets(lift))
    if serves:
        (x, y), strip = _landing(lift)
        st.keep_disc("zone", lift.id, x, y, DISC_R)
        st.keep_rect("zone", lift.id, strip)


def _door_gap(lift: LiftSpec) -> Rect:
    (x1, y1), (x2, y2) = lift.door_segment()
    if abs(y1 - y2) < 1e-9:
        return rect(x1, y1 - HALF, x2, y1 + HALF)
    return rect(x1 - HALF, y1, x1 + HALF, y2)


def _landing(lift: LiftSpec) -> tuple[tuple[float, float], Rect]:
    """The landing's turning-disc centre and the straight 2.0 m strip in front of the door."""
    (x1, y1), (x2, y2) = lift.door_segment()
    ux, uy = lift.axis()
    cx, cy = (x1 + x2) / 2, (y1 + y2) / 2
    disc = (cx + ux * (HALF + DISC_R), cy + uy * (HALF + DISC_R))
    far = HALF + LANDING_STRAIGHT
    strip = rect(x1 + ux * HALF, y1 + uy * HALF, x2 + ux * far, y2 + uy * far)
    return disc, strip


def _pockets(lift: LiftSpec) -> list[Rect]:
    """Wall stretches either side of the car door a sliding car leaf may run into."""
    (x1, y1), (x2, y2) = lift.door_segment()
    w, t = lift.door_width, 0.03
    if abs(y1 - y2) < 1e-9:
        lo, hi = min(x1, x2), max(x1, x2)
        return [rect(lo - w, y1 - t, lo - 0.01, y1 + t), rect(hi + 0.01, y1 - t, hi + w, y1 + t)]
    lo, hi = min(y1, y2), max(y1, y2)
    return [rect(x1 - t, lo - w, x1 + t, lo - 0.01), rect(x1 - t, hi + 0.01, x1 + t, hi + w)]


def make_lobby(rng: np.random.Generator, floors: list[str]) -> Lobby:
    """Draw a lobby with 2-4 lifts (the first two serve every floor)."""
    for _ in range(200):
        lobby = _draw(rng, floors)
        if lobby is not None:
            return lobby
    raise RuntimeError("no lift lobby fits")  # pragma: no cover - 200 draws always find one


def _draw(rng: np.random.Generator, floors: list[str]) -> Lobby | None:
    n = int(rng.choice([2, 2, 2, 3, 3, 4]))
    sides = [str(s) for s in rng.permutation(["W", "N", "N", "E"])[:n]]
    cars = [
        (side, pick(rng, 1.6, 2.0, 0.1), pick(rng, 2.0, 2.6, 0.1), pick(rng, 0.9, 1.2, 0.1))
        for side in sides
    ]
    north = [c for c in cars if c[0] == "N"]
    widths = sum(cw + 2 * HALF for _, cw, _, _ in north)
    free_w = max(3.4, widths + 0.6 * len(north) + pick(rng, 0.0, 1.6, 0.1))
    side_cars = [cw for s, cw, _, _ in cars if s != "N"]
    free_d = max(3.4, max(side_cars, default=0.0) + 1.0) + pick(rng, 0.0, 1.6, 0.1)
    width_c, depth_c = round(free_w + 2 * HALF, 6), round(free_d + 2 * HALF, 6)
    slack = width_c - widths
    cuts = sorted(pick(rng, 0.0, slack, 0.05) for _ in north)
    gaps = [b - a for a, b in zip([0.0, *cuts], [*cuts, slack], strict=False)][: len(north)]
    lifts: list[LiftSpec] = []
    x = 0.0
    for i, (side, cw, dp, dw) in enumerate(cars):
        lift_id = f"lift_{chr(ord('a') + i)}"
        served = list(floors) if i < 2 or len(floors) < 3 else _subset(rng, floors)
        if side == "N":
            x += gaps.pop(0)
            cx = round(x + HALF + cw / 2, 6)
            x = round(x + cw + 2 * HALF, 6)
            cy = round(depth_c + HALF + dp / 2, 6)
        else:
            cy = pick(rng, max(0.9, cw / 2 + 2 * HALF), free_d + HALF - 0.9, 0.05)
            cx = round(-HALF - dp / 2 if side == "W" else width_c + HALF + dp / 2, 6)
        lifts.append(LiftSpec(lift_id, cx, cy, HEADINGS[side], cw, dp, dw, served))
    lobby = Lobby(width_c, depth_c, lifts)
    return lobby if _valid(lobby) else None


def _subset(rng: np.random.Generator, floors: list[str]) -> list[str]:
    """All floors, or (sometimes) a run of at least two of them."""
    if rng.random() < 0.6:
        return list(floors)
    start = int(rng.integers(len(floors) - 1))
    stop = int(rng.integers(start + 2, len(floors) + 1))
    return list(floors[start:stop])


def _valid(lobby: Lobby) -> bool:
    """Shafts apart, every landing disc and strip inside the lobby, pockets solid."""
    shafts = [grow(lift.interior(), HALF) for lift in lobby.lifts]
    for i, a in enumerate(shafts):
        if a[1] < -1e-9 or any(overlaps(a, b) for b in shafts[i + 1 :]):
            return False
    inside = FreeSpace()
    inside.carves.append(lobby.carve())
    everything = FreeSpace()
    everything.carves += [lobby.carve(), lobby.opening(), (-100.0, -50.0, 100.0, -HALF)]
    everything.carves += [lift.interior() for lift in lobby.lifts]
    everything.carves += [_door_gap(lift) for lift in lobby.lifts]
    for lift in lobby.lifts:
        (x, y), strip = _landing(lift)
        if not inside.free(disc_points(x, y, DISC_R)) or not inside.free(rect_points(strip)):
            return False
        if any(everything.any_carved(rect_points(p)) for p in _pockets(lift)):
            return False
    return True
