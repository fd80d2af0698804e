"""Open-RMF's door and lift messages <-> wheelnav's, field by field.

wheelnav's DoorState/DoorRequest/LiftState/LiftRequest (shared/messages.py) already carry
Open-RMF's fields and values (``DoorMode``, ``LiftRequestType``, ``LiftDoor``,
``LiftMotion``, the lift modes), so most fields copy across. What changes:

* times: a wheelnav ``stamp`` (float seconds) <-> ``builtin_interfaces/Time``
  (int32 ``sec``, uint32 ``nanosec``);
* ``DoorMode`` is a message of its own in Open-RMF (``current_mode.value``);
* names: a site's door, lift and floor ids <-> the building's names (:class:`Names`);
* ``LiftState.available_modes`` has no wheelnav field and is dropped.

Every wheelnav message built here is checked against its schema (shared/codec.py): a value
it cannot hold raises :class:`BadField` naming the field. Pure: no clock, no I/O.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from typing import Any

from services.rmf_bridge import cdr
from services.rmf_bridge.errors import BadField, UnknownName
from shared.codec import EncodeError, encode
from shared.messages import DoorMode, DoorRequest, DoorState, LiftRequest, LiftState, Msg

INT32_MAX = 2**31 - 1
NANO = 1_000_000_000


class Names:
    """A site's names of one kind (doors, lifts, floors) <-> the building's.

    Each site name is the building's unless ``renamed`` says otherwise (site -> building).
    ``strict`` (doors, lifts): a name on neither list raises :class:`UnknownName`;
    otherwise (floors) it passes unchanged. ValueError if two site names would share a
    building name.
    """

    def __init__(
        self, kind: str, site: Iterable[str], renamed: Mapping[str, str], strict: bool = True
    ) -> None:
        self.kind = kind
        self.strict = strict
        self._to_building = {name: renamed.get(name, name) for name in site}
        self._to_site: dict[str, str] = {}
        for ours, theirs in self._to_building.items():
            if theirs in self._to_site:
                raise ValueError(
                    f"{kind}s {self._to_site[theirs]!r} and {ours!r} both have the building "
                    f"name {theirs!r}"
                )
            self._to_site[theirs] = ours
        self.unused = sorted(set(renamed) - set(self._to_building))  # renamed, not in the site

    def __len__(self) -> int:
        return len(self._to_building)

    def building(self, name: str) -> str:
        """The building's name for site name ``name``."""
        if name in self._to_building:
            return self._to_building[name]
        if self.strict:
            raise UnknownName(f"{self.kind} {name!r}: not one the building reports")
        return name

    def site(self, name: str) -> str:
        """The site's name for building name ``name``."""
        if name in self._to_site:
            return self._to_site[name]
        if self.strict:
            raise UnknownName(
                f"{self.kind} {name!r} of the building: no site {self.kind} maps to it"
            )
        return name


def to_time(stamp: float) -> Any:
    """A ``builtin_interfaces/Time`` for ``stamp`` seconds (rounded to the nanosecond)."""
    if not math.isfinite(stamp) or stamp < 0:
        raise BadField(f"stamp: {stamp!r} is not a time builtin_interfaces/Time can hold")
    sec = math.floor(stamp)
    nanosec = round((stamp - sec) * NANO)
    if nanosec >= NANO:
        sec, nanosec = sec + 1, nanosec - NANO
    if sec > INT32_MAX:
        raise BadField(f"stamp: {stamp!r} s is past builtin_interfaces/Time's int32 seconds")
    return cdr.message(cdr.TIME, sec=sec, nanosec=nanosec)


def from_time(time: Any) -> float:
    """Seconds of a ``builtin_interfaces/Time``."""
    return time.sec + time.nanosec / NANO


def _checked(msg: Msg, topic: str) -> Msg:
    """``msg`` if it satisfies its schema; BadField naming the field otherwise."""
    try:
        encode(msg)
    except EncodeError as exc:
        raise BadField(f"{topic}: {exc}") from None
    return msg


def _enum(value: int, field: str, lo: int, hi: int, what: str) -> int:
    if not lo <= value <= hi:
        raise BadField(f"{field}: {value} is not a {what} ({lo}..{hi})")
    return value


def door_request_to_rmf(req: DoorRequest, door_name: str, stamp: float | None = None) -> Any:
    """``req`` as an Open-RMF DoorRequest for the building's door ``door_name``, stamped
    ``stamp`` (the request's own stamp if None)."""
    return cdr.message(
        cdr.DOOR_REQUEST,
        request_time=to_time(req.stamp if stamp is None else stamp),
        requester_id=req.requester_id,
        door_name=door_name,
        requested_mode=cdr.message(cdr.DOOR_MODE, value=req.requested_mode),
    )


def door_state_from_rmf(msg: Any, door_id: str, stamp: float) -> DoorState:
    """An Open-RMF DoorState as wheelnav's for site door ``door_id``, stamped ``stamp``."""
    mode = _enum(
        msg.current_mode.value, "current_mode.value", DoorMode.CLOSED, DoorMode.UNKNOWN, "DoorMode"
    )
    return _checked(DoorState(stamp, door_id, mode), "door_state")


def lift_request_to_rmf(req: LiftRequest, lift_name: str, floors: Names) -> Any:
    """``req`` as an Open-RMF LiftRequest for the building's lift ``lift_name``."""
    return cdr.message(
        cdr.LIFT_REQUEST,
        lift_name=lift_name,
        request_time=to_time(req.stamp),
        session_id=req.session_id,
        request_type=req.request_type,
        destination_floor=floors.building(req.destination_floor) if req.destination_floor else "",
        door_state=req.door_state,
    )


def lift_state_from_rmf(msg: Any, lift_id: str, floors: Names, stamp: float) -> LiftState:
    """An Open-RMF LiftState as wheelnav's for site lift ``lift_id``, stamped ``stamp``."""

    def floor(name: str) -> str:
        return floors.site(name) if name else ""

    state = LiftState(
        stamp=stamp,
        lift_name=lift_id,
        available_floors=[floor(f) for f in msg.available_floors],
        current_floor=floor(msg.current_floor),
        destination_floor=floor(msg.destination_floor),
        door_state=_enum(msg.door_state, "door_state", 0, 2, "lift door state"),
        motion_state=_enum(msg.motion_state, "motion_state", 0, 3, "lift motion state"),
        current_mode=_enum(msg.current_mode, "current_mode", 0, 5, "lift mode"),
        session_id=msg.session_id,
    )
    return _checked(state, "lift_state")
