"""The building bridge's core: one chair's door and lift requests out to an Open-RMF
building as CDR, the building's door and lift states back as wheelnav messages.

The contract on wheelnav's side is the building emulator's (docs/building-bridge.md):
the same keys, messages, modes and session semantics. What the bridge adds to Open-RMF's:

* **Which doors and lifts.** Only the site's doors with a controller (``controller``
  true, the default) and its lifts are bridged; a request or a state for any other is
  refused (:class:`UnknownName`), so a door the building does not report is left to the
  LiDAR, as the site says.
* **Whose requests.** It speaks for one chair, ``robot``: a DoorRequest goes out only if
  its ``requester_id`` is the chair's name, a LiftRequest only if its session is the
  chair's (``<robot>`` or ``<robot>-<anything>``, as the navigator names them). Another
  chair's requests are left to that chair's bridge (counted as ``foreign``).
* **Leases.** wheelnav's building lets a powered door's open request and a lift session
  go when their holder has been silent for ``door_lease_s`` / ``lift_lease_s`` (the
  navigator renews them meanwhile); Open-RMF's door and lift supervisors keep them until
  they are ended. :meth:`RmfBridge.expire` ends, on the chair's behalf, what it has not
  renewed in time: a DoorRequest CLOSED, a LiftRequest END_SESSION;
  :meth:`RmfBridge.release_all` ends everything held when the bridge stops.
* **Times.** The door supervisor ignores a CLOSED stamped before the requester's last
  OPEN, so a CLOSED goes out stamped no earlier than the OPEN it ends. States coming in are
  stamped with their arrival time (the caller's ``now``), on the chair's clock.

Pure and deterministic: the caller passes ``now`` and the payloads, and publishes what
comes back. Refusals raise from :mod:`services.rmf_bridge.errors`; every call is counted in
:attr:`RmfBridge.counts`.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass

from services.rmf_bridge import cdr
from services.rmf_bridge.errors import BridgeError
from services.rmf_bridge.ros_keys import DOOR_REQUESTS, LIFT_REQUESTS, RosTopic
from services.rmf_bridge.translate import (
    Names,
    door_request_to_rmf,
    door_state_from_rmf,
    lift_request_to_rmf,
    lift_state_from_rmf,
)
from shared.messages import (
    DoorMode,
    DoorRequest,
    DoorState,
    LiftDoor,
    LiftRequest,
    LiftRequestType,
    LiftState,
)


@dataclass(frozen=True)
class Outgoing:
    """A CDR message for the building: which topic, about which site door or lift, why."""

    topic: RosTopic
    name: str
    payload: bytes
    why: str = ""  # set when the bridge sends it on its own: what it ends, and why


class RmfBridge:
    """Translate between one chair's navigator and an Open-RMF building.

    Args:
        robot: the chair's name (its requests' ``requester_id``, its sessions' prefix).
        doors: site ids of the doors the building reports (``controller`` true).
        lifts: site ids of the lifts.
        floors: site floor names.
        door_names, lift_names, floor_names: site name -> the building's, where they differ.
        door_lease_s, lift_lease_s: how long an open request or a session lasts unrenewed.

    Counters in :attr:`counts`: ``states_in`` and ``requests_out`` (translated),
    ``foreign`` (another chair's requests, left alone), ``expired`` (leases ended by the
    bridge), and one per refusal kind (``malformed``, ``bad_field``, ``unknown``).
    """

    def __init__(
        self,
        robot: str,
        doors: Iterable[str],
        lifts: Iterable[str],
        floors: Iterable[str] = (),
        door_names: Mapping[str, str] | None = None,
        lift_names: Mapping[str, str] | None = None,
        floor_names: Mapping[str, str] | None = None,
        door_lease_s: float = 30.0,
        lift_lease_s: float = 30.0,
    ) -> None:
        if door_lease_s <= 0 or lift_lease_s <= 0:
            raise ValueError(f"leases must be > 0 s, got {door_lease_s}, {lift_lease_s}")
        self.robot = robot
        self.doors = Names("door", doors, door_names or {})
        self.lifts = Names("lift", lifts, lift_names or {})
        self.floors = Names("floor", floors, floor_names or {}, strict=False)
        self.door_lease_s = door_lease_s
        self.lift_lease_s = lift_lease_s
        self.counts: Counter[str] = Counter()
        self._open: dict[str, tuple[float, float]] = {}  # door -> (asked at, request stamp)
        self._sessions: dict[tuple[str, str], float] = {}  # (lift, session) -> asked at

    # -- the building's states in ---------------------------------------------------------

    def door_state(self, payload: bytes, now: float) -> DoorState:
        """A CDR DoorState from the building as wheelnav's, stamped ``now``."""
        with self._counted("states_in"):
            msg = cdr.decode(payload, cdr.DOOR_STATE)
            return door_state_from_rmf(msg, self.doors.site(msg.door_name), now)

    def lift_state(self, payload: bytes, now: float) -> LiftState:
        """A CDR LiftState from the building as wheelnav's, stamped ``now``."""
        with self._counted("states_in"):
            msg = cdr.decode(payload, cdr.LIFT_STATE)
            return lift_state_from_rmf(msg, self.lifts.site(msg.lift_name), self.floors, now)

    # -- the chair's requests out ---------------------------------------------------------

    def door_request(self, req: DoorRequest, now: float) -> Outgoing | None:
        """The CDR DoorRequest for the building; None for another chair's request."""
        if req.requester_id != self.robot:
            self.counts["foreign"] += 1
            return None
        with self._counted("requests_out"):
            name = self.doors.building(req.door_name)
            held = self._open.get(req.door_name)
            opening = req.requested_mode == DoorMode.OPEN
            stamp = req.stamp if opening or held is None else max(req.stamp, held[1])
            payload = self._door_payload(req, name, stamp)
            if opening:
                self._open[req.door_name] = (now, req.stamp)
            elif req.requested_mode == DoorMode.CLOSED and held is not None:
                del self._open[req.door_name]
            return Outgoing(DOOR_REQUESTS, req.door_name, payload)

    def lift_request(self, req: LiftRequest, now: float) -> Outgoing | None:
        """The CDR LiftRequest for the building; None for another chair's session."""
        if not self._ours(req.session_id):
            self.counts["foreign"] += 1
            return None
        with self._counted("requests_out"):
            name = self.lifts.building(req.lift_name)
            payload = cdr.encode(lift_request_to_rmf(req, name, self.floors), cdr.LIFT_REQUEST)
            if req.request_type != LiftRequestType.END_SESSION:
                self._sessions[req.lift_name, req.session_id] = now
            else:
                self._sessions.pop((req.lift_name, req.session_id), None)
            return Outgoing(LIFT_REQUESTS, req.lift_name, payload)

    def expire(self, now: float) -> list[Outgoing]:
        """End what the chair holds and has not renewed within its lease: a CLOSED for each
        door asked open ``door_lease_s`` ago, an END_SESSION for each lift session last
        asked for ``lift_lease_s`` ago (door ids in order, then lift ids)."""
        doors = [d for d, (at, _stamp) in self._open.items() if now - at >= self.door_lease_s]
        lifts = [k for k, at in self._sessions.items() if now - at >= self.lift_lease_s]
        out = [
            self._close(door, now, f"no request for {self.door_lease_s:g} s (its lease)")
            for door in sorted(doors)
        ] + [
            self._end_session(lift, now, f"no request for {self.lift_lease_s:g} s (its lease)")
            for lift in sorted(lifts)
        ]
        self.counts["expired"] += len(out)
        return out

    def release_all(self, now: float) -> list[Outgoing]:
        """End everything the chair holds (the bridge is stopping: nobody would end it)."""
        return [self._close(d, now, "the bridge stops") for d in sorted(self._open)] + [
            self._end_session(k, now, "the bridge stops") for k in sorted(self._sessions)
        ]

    def held(self) -> tuple[list[str], list[str]]:
        """The doors the chair holds open and the lifts it holds a session on."""
        return sorted(self._open), sorted({lift for lift, _session in self._sessions})

    # -- helpers --------------------------------------------------------------------------

    def _ours(self, session_id: str) -> bool:
        return session_id == self.robot or session_id.startswith(f"{self.robot}-")

    def _door_payload(self, req: DoorRequest, name: str, stamp: float) -> bytes:
        return cdr.encode(door_request_to_rmf(req, name, stamp), cdr.DOOR_REQUEST)

    def _close(self, door: str, now: float, why: str) -> Outgoing:
        """A CLOSED for ``door`` on the chair's behalf, no earlier than its last OPEN."""
        _at, opened = self._open.pop(door)
        req = DoorRequest(max(now, opened), self.robot, door, DoorMode.CLOSED)
        payload = self._door_payload(req, self.doors.building(door), req.stamp)
        return Outgoing(DOOR_REQUESTS, door, payload, f"door {door}: CLOSED, {why}")

    def _end_session(self, held: tuple[str, str], now: float, why: str) -> Outgoing:
        """An END_SESSION for the chair's session ``held`` (lift, session id)."""
        del self._sessions[held]
        lift, session = held
        req = LiftRequest(now, lift, session, LiftRequestType.END_SESSION, "", LiftDoor.CLOSED)
        rmf = lift_request_to_rmf(req, self.lifts.building(lift), self.floors)
        why = f"lift {lift}: END_SESSION of session {session!r}, {why}"
        return Outgoing(LIFT_REQUESTS, lift, cdr.encode(rmf, cdr.LIFT_REQUEST), why)

    @contextmanager
    def _counted(self, done: str) -> Iterator[None]:
        """Count ``done`` when the block ends normally, the refusal's kind when it raises."""
        try:
            yield
        except BridgeError as exc:
            self.counts[exc.kind] += 1
            raise
        self.counts[done] += 1
