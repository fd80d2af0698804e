"""Door state machines of the building emulator: how far each door is open, and why.

Pure and deterministic: no clock reads, no threads, no transport. Every method takes
``now``, the simulation time in seconds, and the door first advances itself to ``now``
(a ``now`` earlier than the last one counts as the last one). Events that fall between two
calls (a scheduled open, the end of an automatic door's hold time) take effect at their own
instant, so results do not depend on how often ``update`` is called.

Three kinds of door (``shared.site.DOOR_TYPES``):

* ``manual``: a person opens and closes it, at the times of the scenario's schedule.
  Requests are recorded but change nothing (nobody on the other side listens).
* ``automatic``: opens while something moves in its sensor zone, closes ``hold_open_s``
  after the last motion. Requests are recorded but change nothing.
* ``powered``: Open-RMF supervisor semantics. A ``DoorRequest`` OPEN adds its
  ``requester_id`` to the door's sessions, CLOSED removes it, and so does its lease running
  out (``session_lease_s`` after its last OPEN); the door is open while any session remains
  and closes when none does.

Every kind stops closing when the doorway is obstructed and opens again (a motor's safety
edge, or the person closing a manual door waiting for the doorway to clear).

Reported mode, as a door controller derives it from its two limit switches:
``CLOSED`` when the leaf is home, ``OPEN`` only when it is fully open, ``MOVING`` anywhere
in between. Mechanical faults are silent, as they are in real buildings: a door stuck
closed reports ``CLOSED`` and a door jammed half open reports ``MOVING`` (never ``OPEN``:
half an opening is not passable for a wheelchair). Only a dead controller (the ``offline``
fault) reports ``OFFLINE``. So a client that waits for ``OPEN`` without a timeout waits
forever, which is the failure the navigator's door timeout must handle.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Iterable
from dataclasses import dataclass

from shared.messages import DoorMode, DoorRequest, DoorState
from shared.site import DOOR_TYPES, Door

EPS = 1e-9
REQUEST_LOG_LEN = 256


class DoorMotion:
    """How the leaf moves: swings on hinges or slides along the wall."""

    HINGED = "hinged"
    SLIDING = "sliding"
    ALL = (HINGED, SLIDING)


class DoorFault:
    """Faults a scenario can inject into one door (``None`` means a healthy door)."""

    STUCK_CLOSED = "stuck_closed"
    STUCK_HALF_OPEN = "stuck_half_open"
    OFFLINE = "offline"
    ALL = (STUCK_CLOSED, STUCK_HALF_OPEN, OFFLINE)


@dataclass
class DoorTiming:
    """Speeds and delays of doors (defaults: Open-RMF's simulated doors).

    Attributes:
        hinged_speed_rad_s: swing speed of a hinged leaf.
        open_angle_rad: swing of a fully open hinged leaf (90 degrees: ~3.1 s to open).
        sliding_speed_m_s: speed of a sliding leaf.
        sliding_travel_m: how far a sliding leaf travels; ``None`` means the door's width.
        hold_open_s: an automatic door closes this long after the last motion it saw.
        half_open_fraction: where a ``stuck_half_open`` door jams (fraction of full opening).
    """

    hinged_speed_rad_s: float = 0.5
    open_angle_rad: float = math.pi / 2
    sliding_speed_m_s: float = 0.2
    sliding_travel_m: float | None = None
    hold_open_s: float = 5.0
    half_open_fraction: float = 0.5


class DoorSim:
    """One door of the building: its opening fraction, commands, sessions and faults.

    States (reported mode): CLOSED (opening 0), MOVING (0 < opening < 1), OPEN (opening 1),
    OFFLINE (``offline`` fault, frozen where it was).

    Transitions: the door moves towards fully open while it is *wanted open* and towards
    closed otherwise, at the speed of its motion type (CLOSED -> MOVING -> OPEN and back).
    Wanted open means: manual, the last schedule entry passed was "open"; automatic, something
    moves in the zone or the last motion was less than ``hold_open_s`` ago; powered, at least
    one requester holds a session. For every kind an obstruction keeps a door that is not
    fully closed wanted open (a closing door re-opens). ``stuck_closed`` caps the opening at 0,
    ``stuck_half_open`` at ``half_open_fraction``; ``offline`` stops all motion.
    """

    def __init__(
        self,
        door: Door,
        motion: str = DoorMotion.HINGED,
        timing: DoorTiming | None = None,
        fault: str | None = None,
        schedule: Iterable[tuple[float, str]] = (),
        start_open: bool = False,
        session_lease_s: float | None = None,
    ) -> None:
        """Build a door, closed (or fully open with ``start_open``) until it is told otherwise.

        Args:
            door: the site's door (its ``type`` picks the behaviour, ``p1``-``p2`` its width).
            motion: ``"hinged"`` or ``"sliding"``.
            timing: speeds and hold time; defaults to :class:`DoorTiming`.
            fault: ``None`` or one of :class:`DoorFault`.
            schedule: manual doors only: ``[(time_s, "open" | "close"), ...]`` from the scenario.
            start_open: start fully open (capped by a fault) instead of closed.
            session_lease_s: powered doors only: a requester's session ends this long
                after its last OPEN, as if it had sent CLOSED (None: held until CLOSED).

        Raises:
            ValueError: unknown door type, motion, fault or schedule action; zero-width door.
        """
        if door.type not in DOOR_TYPES:
            raise ValueError(f"door {door.id}: type must be one of {DOOR_TYPES}, got {door.type!r}")
        if motion not in DoorMotion.ALL:
            raise ValueError(f"door {door.id}: motion must be one of {DoorMotion.ALL}")
        if fault is not None and fault not in DoorFault.ALL:
            raise ValueError(f"door {door.id}: fault must be one of {DoorFault.ALL}, got {fault!r}")
        entries = sorted(((float(t), str(a)) for t, a in schedule), key=lambda e: e[0])
        for _, action in entries:
            if action not in ("open", "close"):
                raise ValueError(f"door {door.id}: schedule action must be open/close: {action!r}")
        self.door = door
        self.motion = motion
        self.timing = timing or DoorTiming()
        self.fault = fault
        self.width_m = math.dist(door.p1, door.p2)
        if self.width_m <= 0.0:
            raise ValueError(f"door {door.id}: p1 and p2 coincide")
        self.requests: deque[tuple[float, DoorRequest]] = deque(maxlen=REQUEST_LOG_LEN)
        self._schedule = entries
        self._next_entry = 0
        self._limit = {
            DoorFault.STUCK_CLOSED: 0.0,
            DoorFault.STUCK_HALF_OPEN: self.timing.half_open_fraction,
        }.get(fault, 1.0)
        self._opening = min(1.0, self._limit) if start_open else 0.0
        self._t: float | None = None
        self._manual_open = start_open
        self._moving = False
        self._hold_until: float | None = None
        self._obstructed = False
        self._sessions: dict[str, float] = {}  # requester -> when it last asked OPEN
        self._lease = session_lease_s
        self._reported: int | None = None

    # ----------------------------------------------------------------------------------
    # Inputs
    # ----------------------------------------------------------------------------------

    def request(self, now: float, req: DoorRequest) -> None:
        """Take an Open-RMF door request; only powered doors act on it, every door records it.

        OPEN opens a session for ``req.requester_id``, CLOSED ends it; other modes and
        requests naming another door are ignored.
        """
        self.update(now)
        if req.door_name != self.door.id:
            return
        self.requests.append((now, req))
        if self.door.type != "powered":
            return
        if req.requested_mode == DoorMode.OPEN:
            self._sessions[req.requester_id] = self._t
        elif req.requested_mode == DoorMode.CLOSED:
            self._sessions.pop(req.requester_id, None)

    def set_presence(self, now: float, moving: bool) -> None:
        """Tell an automatic door whether something moves in its sensor zone now.

        The hold time runs from the moment motion stops; other door types ignore this.
        """
        self.update(now)
        if self.door.type != "automatic" or moving == self._moving:
            return
        self._moving = moving
        self._hold_until = None if moving else now + self.timing.hold_open_s

    def set_obstructed(self, now: float, obstructed: bool) -> None:
        """Tell the door whether something stands in its doorway (so it must not close).

        When an automatic door's doorway clears, its hold time starts again.
        """
        self.update(now)
        if obstructed == self._obstructed:
            return
        self._obstructed = obstructed
        if (
            not obstructed
            and self.door.type == "automatic"
            and not self._moving
            and self._opening > EPS
        ):
            self._hold_until = now + self.timing.hold_open_s

    # ----------------------------------------------------------------------------------
    # Time
    # ----------------------------------------------------------------------------------

    def update(self, now: float) -> None:
        """Advance the door to ``now``, applying schedule entries and hold ends at their times."""
        if self._t is None:
            self._t = now
        now = max(now, self._t)
        while True:
            due = self._next_event()
            if due is None or due > now:
                break
            self._move(max(due, self._t))
            self._fire()
        self._move(now)

    def _next_event(self) -> float | None:
        """Time of the next change of command that no caller announces."""
        if self.door.type == "manual" and self._next_entry < len(self._schedule):
            return self._schedule[self._next_entry][0]
        if self.door.type == "automatic":
            return self._hold_until
        if self._sessions and self._lease is not None:
            return min(self._sessions.values()) + self._lease
        return None

    def _fire(self) -> None:
        if self.door.type == "manual":
            self._manual_open = self._schedule[self._next_entry][1] == "open"
            self._next_entry += 1
        elif self.door.type == "automatic":
            self._hold_until = None
        else:  # powered: the sessions whose lease ran out end
            self._sessions = {
                k: at for k, at in self._sessions.items() if at + self._lease > self._t
            }

    def _wanted_open(self) -> bool:
        if self._obstructed and self._opening > EPS:
            return True
        if self.door.type == "manual":
            return self._manual_open
        if self.door.type == "automatic":
            return self._moving or self._hold_until is not None
        return bool(self._sessions)

    def _rate(self) -> float:
        """Opening fraction per second."""
        if self.fault == DoorFault.OFFLINE:
            return 0.0
        if self.motion == DoorMotion.HINGED:
            return self.timing.hinged_speed_rad_s / self.timing.open_angle_rad
        travel = self.timing.sliding_travel_m or self.width_m
        return self.timing.sliding_speed_m_s / travel

    def _move(self, t: float) -> None:
        dt = t - self._t
        self._t = t
        if dt <= 0.0:
            return
        target = self._limit if self._wanted_open() else 0.0
        step = self._rate() * dt
        if self._opening < target:
            self._opening = min(target, self._opening + step)
        elif self._opening > target:
            self._opening = max(target, self._opening - step)

    # ----------------------------------------------------------------------------------
    # Outputs
    # ----------------------------------------------------------------------------------

    @property
    def opening(self) -> float:
        """How open the door is: 0 closed .. 1 fully open (as of the last update)."""
        return self._opening

    @property
    def angle_rad(self) -> float:
        """Swing angle of a hinged leaf (0 for a sliding door), for the simulator's body."""
        if self.motion != DoorMotion.HINGED:
            return 0.0
        return self._opening * self.timing.open_angle_rad

    @property
    def slide_m(self) -> float:
        """How far a sliding leaf has moved (0 for a hinged door), for the simulator's body."""
        if self.motion != DoorMotion.SLIDING:
            return 0.0
        return self._opening * (self.timing.sliding_travel_m or self.width_m)

    @property
    def full_open_s(self) -> float:
        """Time a healthy door of this motion takes from closed to fully open."""
        return 1.0 / self._rate() if self._rate() > 0 else math.inf

    @property
    def sessions(self) -> frozenset[str]:
        """Requesters holding a powered door open."""
        return frozenset(self._sessions)

    @property
    def commanded_open(self) -> bool:
        """Whether the door is currently driven towards open (faults aside)."""
        return self._wanted_open()

    def mode(self) -> int:
        """The ``DoorMode`` a controller with two limit switches would report (see module doc)."""
        if self.fault == DoorFault.OFFLINE:
            return DoorMode.OFFLINE
        if self._opening <= EPS:
            return DoorMode.CLOSED
        if self._opening >= 1.0 - EPS:
            return DoorMode.OPEN
        return DoorMode.MOVING

    def state(self, now: float) -> DoorState:
        """Advance to ``now`` and return the door's Open-RMF state message."""
        self.update(now)
        return DoorState(stamp=float(now), door_name=self.door.id, current_mode=self.mode())

    def changed(self) -> bool:
        """Whether the mode differs from the one seen at the previous call (True at first call).

        For publish-on-change: call after ``update`` or ``state``.
        """
        mode = self.mode()
        if mode == self._reported:
            return False
        self._reported = mode
        return True
