"""A floor while it is being planned: the plan so far plus what later steps must respect.

Steps add spaces, carves, doors and obstacles through :class:`FloorState`; a step that
fails part-way rolls back to a :meth:`FloorState.mark` (every list only grows, so a
rollback is a truncation). Keep-out zones record what must stay clear: turning discs,
straight approaches and places (``zone``: no leaf, column or furniture inside) and the
quarter circles door leaves sweep (``sweep``: no furniture, no other leaf's sweep).
Pockets are the wall stretches sliding leaves run into; nothing may be carved there.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from sim.building_gen.geometry import FreeSpace, Rect, overlaps, point_rect_dist
from sim.building_gen.plan import CORRIDOR_KINDS, FloorPlan, Space


@dataclass
class Keepout:
    """A disc (``radius`` > 0 around ``x, y``) or a rectangle that later steps must keep clear."""

    role: str  # zone | sweep
    owner: str
    rect: Rect | None = None
    x: float = 0.0
    y: float = 0.0
    radius: float = 0.0

    def hits(self, r: Rect) -> bool:
        if self.rect is not None:
            return overlaps(self.rect, r)
        return point_rect_dist(self.x, self.y, r) < self.radius - 1e-6


@dataclass
class FloorState:
    """The floor plan being built and the constraints gathered so far."""

    plan: FloorPlan
    rng: np.random.Generator
    free: FreeSpace = field(default_factory=FreeSpace)
    keepouts: list[Keepout] = field(default_factory=list)
    pockets: list[Rect] = field(default_factory=list)
    counters: dict[str, int] = field(default_factory=dict)

    # ---- ids ---------------------------------------------------------------------------

    def next_id(self, kind: str) -> int:
        self.counters[kind] = self.counters.get(kind, 0) + 1
        return self.counters[kind]

    # ---- transactions ------------------------------------------------------------------

    def _lists(self) -> tuple[list, ...]:
        """Everything a transaction may append to, in a fixed order."""
        p = self.plan
        return (
            p.spaces,
            p.carves,
            p.doors,
            p.columns,
            p.furniture,
            p.places,
            p.series,
            p.openings,
            self.free.carves,
            self.free.obstacles,
            self.keepouts,
            self.pockets,
        )

    def mark(self) -> tuple:
        return tuple(len(x) for x in self._lists()), dict(self.counters)

    def rollback(self, mark: tuple) -> None:
        sizes, counters = mark
        for lst, n in zip(self._lists(), sizes, strict=True):
            del lst[n:]
        self.counters = counters

    # ---- spaces and carving ------------------------------------------------------------

    def fits(self, r: Rect, kind: str) -> bool:
        """Whether a space of ``kind`` on footprint ``r`` overlaps no other space.

        Corridor pieces may overlap each other: they are one open area.
        """
        for s in self.plan.spaces:
            if overlaps(r, s.rect) and not (kind in CORRIDOR_KINDS and s.kind in CORRIDOR_KINDS):
                return False
        return True

    def carve(self, r: Rect) -> bool:
        """Free ``r`` unless it cuts a sliding leaf's pocket; False (nothing done) if it would."""
        if any(overlaps(r, p) for p in self.pockets):
            return False
        self.plan.carves.append(r)
        self.free.carves.append(r)
        return True

    def add_space(self, space: Space) -> bool:
        """Add ``space`` and carve its free part; False (nothing done) if it does not fit."""
        if not self.fits(space.rect, space.kind):
            return False
        if space.carve is not None and any(overlaps(space.carve, p) for p in self.pockets):
            return False
        self.plan.spaces.append(space)
        if space.carve is not None:
            self.carve(space.carve)
        return True

    # ---- keep-outs ---------------------------------------------------------------------

    def keep_disc(self, role: str, owner: str, x: float, y: float, radius: float) -> None:
        self.keepouts.append(Keepout(role, owner, None, x, y, radius))

    def keep_rect(self, role: str, owner: str, r: Rect) -> None:
        self.keepouts.append(Keepout(role, owner, r))

    def blocked(self, r: Rect, roles: tuple[str, ...], owner: str = "") -> bool:
        """Whether ``r`` cuts a keep-out of one of ``roles`` not owned by ``owner``."""
        return any(k.role in roles and k.owner != owner and k.hits(r) for k in self.keepouts)
