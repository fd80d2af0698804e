"""What a mission holds in the building, as leases: renewed while held, released at its end.

The building lets a lift session or a powered door's open request go when its holder has
been silent for its lease (``building.lift_session_lease_s``,
``building.door_session_lease_s``), so a navigator that dies, or a mission that ends
between "call the car" and "release", cannot leave a lift busy or a door open for ever.
While a mission holds a lift (or a door it asked open), :class:`Leases` asks again, for
the floor it last asked, every ``navigator.lease_renew_s``; when the mission ends
(succeeded, failed, cancelled, replaced by a new goal) it ends every session still held.

It stands between the mission tree and the fleet: the tree's behaviours call
``request_lift``, ``release_lift``, ``request_door`` and ``close_door_when_clear`` on it as
on the fleet, and every other call passes through. A door handed to
``close_door_when_clear`` is still asked open every ``renew_s`` until the fleet finds its
leaf can no longer reach the chair (:meth:`doors_clear_to_close`), whatever the mission
does meanwhile, ended or not: left to the building's lease, a door closed into a chair held
within its reach (campaign b4001.m02). The lease stays the backstop for a navigator that
dies. Pure: the fleet's clock, no I/O of its own.
"""

from __future__ import annotations

from typing import Any

from shared.messages import DoorMode


class Leases:
    """A fleet that remembers which lifts and doors the mission holds."""

    def __init__(self, fleet: Any, renew_s: float) -> None:
        self._fleet = fleet
        self.renew_s = renew_s
        self.lifts: dict[str, str] = {}  # lift id -> the floor last asked for
        self.doors: set[str] = set()  # powered doors asked open, not yet handed back
        self.closing: set[str] = set()  # passed: held open until the leaf cannot reach
        self._asked_at: dict[tuple[str, str], float] = {}  # (kind, id) -> when

    def __getattr__(self, name: str) -> Any:
        return getattr(self._fleet, name)

    def request_lift(self, lift_id: str, floor: str) -> None:
        self._fleet.request_lift(lift_id, floor)
        self.lifts[lift_id] = floor
        self._asked_at["lift", lift_id] = self._fleet.now()

    def release_lift(self, lift_id: str) -> None:
        self._fleet.release_lift(lift_id)
        self.lifts.pop(lift_id, None)
        self._asked_at.pop(("lift", lift_id), None)

    def request_door(self, door_id: str, mode: int) -> None:
        self._fleet.request_door(door_id, mode)
        if mode == DoorMode.OPEN:
            self.doors.add(door_id)
            self._asked_at["door", door_id] = self._fleet.now()
        else:
            self._forget_door(door_id)

    def close_door_when_clear(self, door_id: str, *args: Any) -> None:
        self._fleet.close_door_when_clear(door_id, *args)
        self.doors.discard(door_id)
        self.closing.add(door_id)
        self._asked_at.setdefault(("door", door_id), self._fleet.now())

    def doors_clear_to_close(self) -> list[Any]:
        """The fleet's close requests for the doors whose leaves can no longer reach the
        chair (to send); those are no longer held open."""
        due = self._fleet.doors_clear_to_close()
        for req in due:
            self.closing.discard(req.door_name)
            self._asked_at.pop(("door", req.door_name), None)
        return due

    def _forget_door(self, door_id: str) -> None:
        self.doors.discard(door_id)
        self._asked_at.pop(("door", door_id), None)

    def renew(self, now: float) -> None:
        """Ask again for every lift and door held and not asked for in ``renew_s``."""
        for lift_id, floor in list(self.lifts.items()):
            if now - self._asked_at.get(("lift", lift_id), now) >= self.renew_s:
                self.request_lift(lift_id, floor)
        for door_id in sorted(self.doors):
            if now - self._asked_at.get(("door", door_id), now) >= self.renew_s:
                self.request_door(door_id, DoorMode.OPEN)
        for door_id in sorted(self.closing):
            if now - self._asked_at.get(("door", door_id), now) >= self.renew_s:
                self._fleet.hold_door_open(door_id)
                self._asked_at["door", door_id] = now

    def release(self, checkpoint_id: str) -> bool:
        """End the session of a lift or the open request of a door the mission gives up
        on (it plans around it); False if it holds neither by that id."""
        if checkpoint_id in self.lifts:
            self.release_lift(checkpoint_id)
            return True
        if checkpoint_id in self.doors:
            self.request_door(checkpoint_id, DoorMode.CLOSED)
            return True
        return False

    def release_all(self) -> list[str]:
        """End every lift session and door request still held (the mission ended); the
        ids released."""
        released = list(self.lifts) + sorted(self.doors)
        for lift_id in list(self.lifts):
            self.release_lift(lift_id)
        for door_id in sorted(self.doors):
            self.request_door(door_id, DoorMode.CLOSED)
        return released
