"""Where a door is, as the scans show it, against where the map puts it.

A map drawn 10 cm off (or a pose estimate off by as much) lines stop-turn-go up on a
doorway that is not there: at an 0.80 m door with a leaf open, 10 cm is more than the gap
a side, and the pass stops at the jamb (issue 14's door bench: 0 of 10 at 0.80 m hinged
with the map 10 cm off). :class:`DoorFix` carries the shift along the wall that the
doorways seen in the scans show; the door steps after it (the second alignment, the
pass) aim at the mapped poses moved by it. Pure: no I/O.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from statistics import median

ALIGNED_RAD = 0.3  # a sighting's wall runs within this of the mapped door's wall


@dataclass
class DoorFix:
    """The shift (map frame, metres) from the mapped door to the door the scans show; zero
    until a :class:`~behaviours.door.LocateDoor` sets it."""

    shift: tuple[float, float] = (0.0, 0.0)

    def at(self, x: float, y: float) -> tuple[float, float]:
        """The point (x, y) of the mapped door's frame, moved onto the door seen."""
        return x + self.shift[0], y + self.shift[1]

    def reset(self) -> None:
        self.shift = (0.0, 0.0)


@dataclass
class DoorSightings:
    """Sightings of one mapped door (centre, heading through it, width) gathered scan by
    scan: the offset along its wall of every doorway seen within ``reach_m`` of it, whose
    wall runs the same way and which is at least ``min_width_m`` wide."""

    centre: tuple[float, float]
    heading: float
    reach_m: float
    min_width_m: float = 0.0
    offsets: list[float] = field(default_factory=list)

    @property
    def along(self) -> tuple[float, float]:
        """The mapped door's wall direction (unit), to the left of the heading through it."""
        return -math.sin(self.heading), math.cos(self.heading)

    def add(self, seen: list[tuple[float, float, float, float]]) -> bool:
        """Add one scan's doorways (map frame: centre x, y, wall direction angle, width);
        True if one of them is this door."""
        ux, uy = self.along
        nx, ny = math.cos(self.heading), math.sin(self.heading)
        best: float | None = None
        for cx, cy, direction, width in seen:
            dx, dy = cx - self.centre[0], cy - self.centre[1]
            lateral, depth = dx * ux + dy * uy, dx * nx + dy * ny
            parallel = abs(math.sin(direction - math.atan2(uy, ux))) <= math.sin(ALIGNED_RAD)
            if (
                abs(lateral) <= self.reach_m
                and abs(depth) <= self.reach_m
                and parallel
                and width >= self.min_width_m
                and (best is None or abs(lateral) < abs(best))
            ):
                best = lateral
        if best is None:
            return False
        self.offsets.append(best)
        return True

    def shift(self, needed: int) -> tuple[float, float] | None:
        """The median offset as a map-frame shift along the wall, once ``needed`` sightings
        agree; None before."""
        if len(self.offsets) < needed:
            return None
        m = median(self.offsets)
        ux, uy = self.along
        return m * ux, m * uy
