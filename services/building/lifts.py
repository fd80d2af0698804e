"""Lift state machine of the building emulator: sessions, car motion and car doors.

Pure and deterministic: no clock reads, no threads, no transport. Every method takes
``now``, the simulation time in seconds, and the lift first advances itself to ``now``
(a ``now`` earlier than the last one counts as the last one). Internal events (doors fully
closed, car arrived, door hold over) take effect at their own instant, so results do not
depend on how often ``update`` is called.

Open-RMF semantics (``rmf_lift_msgs``): one session at a time. An AGV_MODE or HUMAN_MODE
request with a ``session_id`` opens (or keeps) the session and sets the destination floor;
requests from another session while one is held are refused; END_SESSION releases it, and
so does the lease running out (``session_lease_s`` after the holder's last request). The
request's ``door_state`` OPEN asks for the doors to open, and stay open, at the destination.
Doors always close completely before the car moves; the car follows a trapezoidal speed
profile (``car_accel_m_s2`` up to ``car_speed_m_s``, triangular on short trips).
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

from shared.messages import (
    LiftDoor,
    LiftMode,
    LiftMotion,
    LiftRequest,
    LiftRequestType,
    LiftState,
)

EPS = 1e-9
REQUEST_LOG_LEN = 256


class LiftFault:
    """Faults a scenario can inject into one lift (``None`` means a healthy lift)."""

    OUT_OF_SERVICE = "out_of_service"
    DOOR_SLOW = "door_slow"
    ALL = (OUT_OF_SERVICE, DOOR_SLOW)


@dataclass
class LiftTiming:
    """Speeds and delays of a lift (defaults: Open-RMF's simulated lifts).

    Attributes:
        car_speed_m_s: top speed of the car.
        car_accel_m_s2: acceleration and deceleration of the car.
        door_speed_m_s: speed of the car doors.
        door_width_m: travel of the car doors (1.8 m at 0.3 m/s: 6 s to open or close).
        door_hold_s: how long doors stay open when nobody holds them (after arrival without
            a session, or after END_SESSION).
        door_slow_factor: the ``door_slow`` fault divides the door speed by this.
    """

    car_speed_m_s: float = 2.0
    car_accel_m_s2: float = 1.0
    door_speed_m_s: float = 0.3
    door_width_m: float = 1.8
    door_hold_s: float = 5.0
    door_slow_factor: float = 4.0


def trip_duration(distance_m: float, speed_m_s: float, accel_m_s2: float) -> float:
    """Time of a rest-to-rest trip over ``distance_m`` with a trapezoidal speed profile.

    Triangular (never reaching ``speed_m_s``) when the distance is shorter than speed^2/accel.
    """
    d = abs(distance_m)
    if d <= 0.0:
        return 0.0
    v_peak = min(speed_m_s, math.sqrt(accel_m_s2 * d))
    return 2.0 * v_peak / accel_m_s2 + (d - v_peak**2 / accel_m_s2) / v_peak


def trip_profile(
    distance_m: float, speed_m_s: float, accel_m_s2: float, tau: float
) -> tuple[float, float]:
    """Distance covered and speed at ``tau`` seconds into a rest-to-rest trip (both >= 0)."""
    d = abs(distance_m)
    total = trip_duration(d, speed_m_s, accel_m_s2)
    if d <= 0.0 or tau >= total:
        return d, 0.0
    if tau <= 0.0:
        return 0.0, 0.0
    v_peak = min(speed_m_s, math.sqrt(accel_m_s2 * d))
    t_acc = v_peak / accel_m_s2
    if tau < t_acc:
        return 0.5 * accel_m_s2 * tau**2, accel_m_s2 * tau
    if tau <= total - t_acc:
        return 0.5 * accel_m_s2 * t_acc**2 + v_peak * (tau - t_acc), v_peak
    left = total - tau
    return d - 0.5 * accel_m_s2 * left**2, accel_m_s2 * left


@dataclass(frozen=True)
class _Trip:
    """One rest-to-rest run of the car from elevation ``z0`` to ``floor`` at ``z1``."""

    t0: float
    z0: float
    z1: float
    floor: str
    duration: float


class LiftSim:
    """One lift: session, destination, car position and car doors.

    States:
        idle: car at rest at a floor, doors closed, no session (mode HUMAN).
        door opening / open / closing: car at rest; door_state MOVING or OPEN.
        travelling: doors closed, car moving UP or DOWN towards a floor.
        out of service: mode OFFLINE, every session refused, the car never moves.

    Transitions:
        * A session's request for another floor: doors close fully, then the car travels.
        * A new destination during a trip is served after the car stops at the current one.
        * Arrival at the destination: doors open if the session asked for OPEN and then stay
          open while it holds the lift and keeps asking OPEN; with no session they open and
          close ``door_hold_s`` after fully open. A session asking CLOSED keeps them shut.
        * END_SESSION with the doors open: they close ``door_hold_s`` later.
        * Obstruction of a doorway that is not fully closed: the doors re-open and stay open
          until it clears (so the car cannot leave).
    """

    def __init__(
        self,
        name: str,
        floors: dict[str, float],
        start_floor: str,
        timing: LiftTiming | None = None,
        fault: str | None = None,
        session_lease_s: float | None = None,
    ) -> None:
        """Build a lift at rest at ``start_floor`` with its doors closed.

        Args:
            name: the lift's name (``lift_name`` of its messages).
            floors: floor name -> elevation of the car's floor there (m).
            start_floor: where the car starts.
            timing: speeds and hold time; defaults to :class:`LiftTiming`.
            fault: ``None`` or one of :class:`LiftFault`.
            session_lease_s: a session ends this long after its holder's last accepted
                request, as if it had sent END_SESSION (None: held until it ends).

        Raises:
            ValueError: no floors, unknown start floor or fault, non-positive speeds.
        """
        if not floors:
            raise ValueError(f"lift {name}: no floors")
        if start_floor not in floors:
            raise ValueError(f"lift {name}: start floor {start_floor!r} not in {list(floors)}")
        if fault is not None and fault not in LiftFault.ALL:
            raise ValueError(f"lift {name}: fault must be one of {LiftFault.ALL}, got {fault!r}")
        self.timing = timing or LiftTiming()
        t = self.timing
        if min(t.car_speed_m_s, t.car_accel_m_s2, t.door_speed_m_s, t.door_width_m) <= 0.0:
            raise ValueError(f"lift {name}: speeds, acceleration and door width must be > 0")
        self.name = name
        self.floors = {str(k): float(v) for k, v in floors.items()}
        self.fault = fault
        self.available_floors = sorted(self.floors, key=self.floors.__getitem__)
        self.requests: deque[tuple[float, LiftRequest, str | None]] = deque(maxlen=REQUEST_LOG_LEN)
        slow = t.door_slow_factor if fault == LiftFault.DOOR_SLOW else 1.0
        self._door_rate = t.door_speed_m_s / t.door_width_m / slow
        self._t: float | None = None
        self._rest_floor = start_floor
        self._z = self.floors[start_floor]
        self._trip: _Trip | None = None
        self._destination = start_floor
        self._door = 0.0
        self._session = ""
        self._session_at = 0.0  # when the holder last asked
        self._lease = session_lease_s
        self.expired: list[tuple[float, str]] = []  # (when, session) of leases run out
        self._session_mode = LiftMode.HUMAN
        self._wanted_door = LiftDoor.CLOSED
        self._timed_open = False
        self._hold_deadline: float | None = None
        self._obstructed = False
        self._reported: tuple | None = None

    # ----------------------------------------------------------------------------------
    # Inputs
    # ----------------------------------------------------------------------------------

    def request(self, now: float, req: LiftRequest) -> str | None:
        """Apply an Open-RMF lift request; returns why it was refused, or None if accepted.

        Every request is recorded in ``requests`` with its answer.
        """
        self.update(now)
        error = self._apply(req)
        self.requests.append((now, req, error))
        self._control()
        return error

    def _apply(self, req: LiftRequest) -> str | None:
        if req.lift_name != self.name:
            return f"request for lift {req.lift_name!r} sent to lift {self.name!r}"
        if req.request_type == LiftRequestType.END_SESSION:
            if not self._session:
                return None
            if req.session_id != self._session:
                return f"lift {self.name} is held by session {self._session!r}"
            self._end_session()
            return None
        if req.request_type not in (LiftRequestType.AGV_MODE, LiftRequestType.HUMAN_MODE):
            return f"unknown request type {req.request_type}"
        if self.fault == LiftFault.OUT_OF_SERVICE:
            return f"lift {self.name} is out of service"
        if not req.session_id:
            return "empty session_id"
        if self._session and req.session_id != self._session:
            return f"lift {self.name} is busy: held by session {self._session!r}"
        if req.destination_floor not in self.floors:
            return (
                f"lift {self.name} does not serve floor {req.destination_floor!r} "
                f"(floors: {', '.join(self.available_floors)})"
            )
        if req.door_state not in (LiftDoor.OPEN, LiftDoor.CLOSED):
            return f"door_state must be OPEN or CLOSED, got {req.door_state}"
        self._session, self._session_at = req.session_id, self._t
        self._session_mode = (
            LiftMode.AGV if req.request_type == LiftRequestType.AGV_MODE else LiftMode.HUMAN
        )
        self._destination = req.destination_floor
        self._wanted_door = req.door_state
        self._timed_open = False
        self._hold_deadline = None
        return None

    def set_obstructed(self, now: float, obstructed: bool) -> None:
        """Tell the lift whether something stands in its doorway (doors then do not close)."""
        self.update(now)
        self._obstructed = obstructed
        self._control()

    # ----------------------------------------------------------------------------------
    # Time
    # ----------------------------------------------------------------------------------

    def update(self, now: float) -> None:
        """Advance the lift to ``now``, handling doors closed, arrivals and hold ends in order."""
        if self._t is None:
            self._t = now
            self._control()
        now = max(now, self._t)
        while True:
            event = self._next_event()
            if event is None or event[0] > now:
                break
            self._advance(max(event[0], self._t))
            self._fire(event[1])
            self._control()
        self._advance(now)

    def _door_goal(self) -> float:
        """1 if the doors should be opening or open, else 0."""
        if self._obstructed and self._door > EPS:
            return 1.0
        if self._trip is not None:
            return 0.0
        if self._timed_open:
            return 1.0
        at_destination = self._rest_floor == self._destination
        if self._session and at_destination and self._wanted_door == LiftDoor.OPEN:
            return 1.0
        return 0.0

    def _control(self) -> None:
        """Start a trip when the car must move and its doors are fully closed."""
        if (
            self._trip is None
            and self._rest_floor != self._destination
            and self.fault != LiftFault.OUT_OF_SERVICE
            and self._door <= 0.0
            and self._door_goal() == 0.0
        ):
            z1 = self.floors[self._destination]
            t = self.timing
            duration = trip_duration(z1 - self._z, t.car_speed_m_s, t.car_accel_m_s2)
            self._trip = _Trip(self._t, self._z, z1, self._destination, duration)

    def _next_event(self) -> tuple[float, str] | None:
        events = []
        if self._trip is not None:
            events.append((self._trip.t0 + self._trip.duration, "arrive"))
        goal = self._door_goal()
        if self._door != goal:
            events.append((self._t + abs(goal - self._door) / self._door_rate, "door"))
        if self._hold_deadline is not None:
            events.append((self._hold_deadline, "hold"))
        if self._session and self._lease is not None:
            events.append((self._session_at + self._lease, "lease"))
        return min(events) if events else None

    def _fire(self, kind: str) -> None:
        if kind == "door":
            self._door = self._door_goal()
            if self._door == 1.0 and self._timed_open and self._hold_deadline is None:
                self._hold_deadline = self._t + self.timing.door_hold_s
        elif kind == "arrive":
            self._rest_floor = self._trip.floor
            self._z = self._trip.z1
            self._trip = None
            if self._rest_floor == self._destination and not self._session:
                self._start_timed_open()
        elif kind == "lease":
            self.expired.append((self._t, self._session))
            self._end_session()
        else:
            self._timed_open = False
            self._hold_deadline = None

    def _advance(self, t: float) -> None:
        dt = t - self._t
        if dt > 0.0:
            goal = self._door_goal()
            step = self._door_rate * dt
            if self._door < goal:
                self._door = min(goal, self._door + step)
            elif self._door > goal:
                self._door = max(goal, self._door - step)
        self._t = t

    def _end_session(self) -> None:
        """Let the session go (END_SESSION, or its lease ran out): open doors close
        ``door_hold_s`` later, the car stays."""
        doors_opening = self._door_goal() == 1.0 and self._trip is None
        self._session = ""
        self._wanted_door = LiftDoor.CLOSED
        if doors_opening:
            self._start_timed_open()

    def _start_timed_open(self) -> None:
        """Open the doors (if not open yet) and close them ``door_hold_s`` after fully open."""
        self._timed_open = True
        self._hold_deadline = self._t + self.timing.door_hold_s if self._door >= 1.0 else None

    # ----------------------------------------------------------------------------------
    # Outputs
    # ----------------------------------------------------------------------------------

    @property
    def car_elevation(self) -> float:
        """Elevation of the car's floor (m) as of the last update, for the simulator's body."""
        if self._trip is None:
            return self._z
        return self._trip.z0 + self._trip_sign() * self._trip_progress()[0]

    @property
    def car_velocity(self) -> float:
        """Vertical speed of the car (m/s, positive up) as of the last update."""
        if self._trip is None:
            return 0.0
        return self._trip_sign() * self._trip_progress()[1]

    def _trip_sign(self) -> float:
        return 1.0 if self._trip.z1 >= self._trip.z0 else -1.0

    def _trip_progress(self) -> tuple[float, float]:
        trip, t = self._trip, self.timing
        return trip_profile(trip.z1 - trip.z0, t.car_speed_m_s, t.car_accel_m_s2, self._t - trip.t0)

    @property
    def door_opening(self) -> float:
        """How open the car doors are: 0 closed .. 1 fully open."""
        return self._door

    @property
    def session_id(self) -> str:
        """The session holding the lift ("" when free)."""
        return self._session

    def current_floor(self) -> str:
        """The floor the car rests at, or the nearest one by elevation while it travels."""
        if self._trip is None:
            return self._rest_floor
        z = self.car_elevation
        return min(self.available_floors, key=lambda f: abs(self.floors[f] - z))

    def door_state(self) -> int:
        """``LiftDoor`` value: CLOSED, OPEN only when fully open, MOVING in between."""
        if self._door <= EPS:
            return LiftDoor.CLOSED
        if self._door >= 1.0 - EPS:
            return LiftDoor.OPEN
        return LiftDoor.MOVING

    def motion_state(self) -> int:
        """``LiftMotion`` value: UP or DOWN while the car travels, else STOPPED."""
        if self._trip is None or self._trip.z1 == self._trip.z0:
            return LiftMotion.STOPPED
        return LiftMotion.UP if self._trip.z1 > self._trip.z0 else LiftMotion.DOWN

    def mode(self) -> int:
        """The ``LiftMode``: OFFLINE out of service, the session's mode, else HUMAN."""
        if self.fault == LiftFault.OUT_OF_SERVICE:
            return LiftMode.OFFLINE
        return self._session_mode if self._session else LiftMode.HUMAN

    def state(self, now: float) -> LiftState:
        """Advance to ``now`` and return the lift's Open-RMF state message."""
        self.update(now)
        return LiftState(
            stamp=float(now),
            lift_name=self.name,
            available_floors=list(self.available_floors),
            current_floor=self.current_floor(),
            destination_floor=self._destination,
            door_state=self.door_state(),
            motion_state=self.motion_state(),
            current_mode=self.mode(),
            session_id=self._session,
        )

    def changed(self) -> bool:
        """Whether any reported field differs from the previous call (True at first call).

        For publish-on-change: call after ``update`` or ``state``.
        """
        key = (
            self.current_floor(),
            self._destination,
            self.door_state(),
            self.motion_state(),
            self.mode(),
            self._session,
        )
        if key == self._reported:
            return False
        self._reported = key
        return True
