"""The lift sessions a mission holds, as leases: renewed while held, released at its end.

The building lets a session go when its holder has been silent for
``building.lift_session_lease_s`` (services/building/lifts.py), so a navigator that dies,
or a mission that ends between "call the car" and "release", cannot leave a lift busy for
ever. While a mission holds a lift, :class:`LiftLeases` asks again, for the floor it last
asked, every ``navigator.lift_lease_renew_s``; when the mission ends (succeeded, failed,
cancelled, replaced by a new goal) it ends every session still held.

It stands between the mission tree and the fleet: the tree's behaviours call
``request_lift`` and ``release_lift`` on it as on the fleet, and every other call passes
through. Pure: the fleet's clock, no I/O of its own.
"""

from __future__ import annotations

from typing import Any


class LiftLeases:
    """A fleet that remembers which lifts the mission holds, and for which floor."""

    def __init__(self, fleet: Any, renew_s: float) -> None:
        self._fleet = fleet
        self.renew_s = renew_s
        self.held: dict[str, str] = {}  # lift id -> the floor last asked for
        self._asked_at: dict[str, float] = {}

    def __getattr__(self, name: str) -> Any:
        return getattr(self._fleet, name)

    def request_lift(self, lift_id: str, floor: str) -> None:
        self._fleet.request_lift(lift_id, floor)
        self.held[lift_id] = floor
        self._asked_at[lift_id] = self._fleet.now()

    def release_lift(self, lift_id: str) -> None:
        self._fleet.release_lift(lift_id)
        self.held.pop(lift_id, None)
        self._asked_at.pop(lift_id, None)

    def renew(self, now: float) -> None:
        """Ask again for every held lift not asked for in the last ``renew_s``."""
        for lift_id, floor in list(self.held.items()):
            if now - self._asked_at.get(lift_id, now) >= self.renew_s:
                self.request_lift(lift_id, floor)

    def release_all(self) -> list[str]:
        """End every session still held (the mission ended); the lifts released."""
        released = list(self.held)
        for lift_id in released:
            self.release_lift(lift_id)
        return released
