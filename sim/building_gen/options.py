"""What a generated building may contain: the knobs of :func:`generate_building`."""

from __future__ import annotations

from dataclasses import dataclass

MISSION_KINDS = (
    "same_floor",
    "cross_floor",
    "door_stuck_alt",
    "door_stuck_no_way",
    "lift_out_of_service",
    "lift_busy",
    "lift_all_out_of_service",
)


@dataclass
class GenOptions:
    """Ranges and switches of the generator; every range is ``(low, high)`` inclusive.

    The defaults draw the buildings a campaign should see: 1-3 floors, corridors 1.2-3.0 m
    wide, halls up to 30 m a side, suites with doors in series and 2-4 lifts when there is
    more than one floor. ``mission_kinds`` (kind -> count) replaces the default mix of
    ``missions`` missions. ``world_differs`` also draws the world the simulator builds
    apart from the map the stack is given (:mod:`sim.building_gen.world`: doors moved,
    furniture added and removed, a partition moved, people standing); off, nothing is
    drawn as before.
    """

    floors: tuple[int, int] = (1, 3)
    missions: int = 8
    mission_kinds: dict[str, int] | None = None
    halls: bool = True
    suites: bool = True
    lifts: bool = True
    branches: bool = True
    furniture: bool = True
    columns: bool = True
    spine_length_m: tuple[float, float] = (10.0, 45.0)
    corridor_width_m: tuple[float, float] = (1.2, 3.0)
    room_size_m: tuple[float, float] = (2.5, 8.0)
    hall_size_m: tuple[float, float] = (8.0, 30.0)
    hall_probability: float = 0.5
    suite_probability: float = 0.25
    # the least free depth between two doors in series, plus a hinged leaf swinging into
    # it (ADA 404.2.6); 0 draws them as before that rule (campaign b2010.m00's 1.6 m)
    vestibule_m: float = 1.22
    world_differs: bool = False

    def check(self) -> None:
        """Raise ValueError for options the generator cannot honour."""
        lo, hi = self.floors
        if not 1 <= lo <= hi <= 3:
            raise ValueError(f"floors: need 1 <= low <= high <= 3, got {self.floors}")
        if hi > 1 and not self.lifts:
            raise ValueError("floors: more than one floor needs lifts (lifts=True)")
        if self.missions < 0:
            raise ValueError(f"missions: must be >= 0, got {self.missions}")
        if self.vestibule_m < 0:
            raise ValueError(f"vestibule_m: must be >= 0, got {self.vestibule_m}")
        for kind in self.mission_kinds or {}:
            if kind not in MISSION_KINDS:
                raise ValueError(f"mission_kinds: unknown kind {kind!r} ({MISSION_KINDS})")
        for name, (a, b), low, high in (
            ("spine_length_m", self.spine_length_m, 10.0, 60.0),
            ("corridor_width_m", self.corridor_width_m, 1.2, 3.0),
            ("room_size_m", self.room_size_m, 2.5, 12.0),
            ("hall_size_m", self.hall_size_m, 6.0, 30.0),
        ):
            if not low <= a <= b <= high:
                raise ValueError(f"{name}: need {low} <= low <= high <= {high}, got {(a, b)}")
