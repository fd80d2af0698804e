"""CDR, ROS 2's wire format, for the Open-RMF messages the bridge speaks (with rosbags).

The message definitions are the ``.msg`` files under ``msgs/`` (``rmf_door_msgs``,
``rmf_lift_msgs`` and the ``builtin_interfaces/Time`` they nest), laid out as in a ROS 2
workspace: ``msgs/<package>/msg/<Type>.msg`` is type ``<package>/msg/<Type>``. rosbags
parses them into its type store, which builds the message classes (plain dataclasses),
serialises and deserialises CDR (the 4-byte encapsulation header, then the fields aligned
as XCDR1 says) and computes the RIHS01 type hash rmw_zenoh puts in its keys.

Pure: no I/O but reading the bundled definitions once.
"""

from __future__ import annotations

import functools
from pathlib import Path
from typing import Any

from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rosbags.typesys.store import Typestore

from services.rmf_bridge.errors import MalformedCdr

MSGS_DIR = Path(__file__).with_name("msgs")
TIME = "builtin_interfaces/msg/Time"
DOOR_MODE = "rmf_door_msgs/msg/DoorMode"
DOOR_STATE = "rmf_door_msgs/msg/DoorState"
DOOR_REQUEST = "rmf_door_msgs/msg/DoorRequest"
LIFT_STATE = "rmf_lift_msgs/msg/LiftState"
LIFT_REQUEST = "rmf_lift_msgs/msg/LiftRequest"
TYPES = (TIME, DOOR_MODE, DOOR_STATE, DOOR_REQUEST, LIFT_STATE, LIFT_REQUEST)


def load_definitions(root: Path = MSGS_DIR) -> dict[str, Any]:
    """rosbags' parse of every ``<package>/msg/<Type>.msg`` under ``root``, by type name."""
    types: dict[str, Any] = {}
    for path in sorted(root.glob("*/msg/*.msg")):
        name = f"{path.parent.parent.name}/msg/{path.stem}"
        types.update(get_types_from_msg(path.read_text(), name))
    return types


@functools.cache
def typestore() -> Typestore:
    """The type store holding the bundled definitions (built once).

    It starts from rosbags' empty store (only ``builtin_interfaces``); registering our
    ``Time`` there checks that it is the same definition.
    """
    store = get_typestore(Stores.EMPTY)
    store.register(load_definitions())
    missing = [t for t in TYPES if t not in store.types]
    if missing:
        raise RuntimeError(f"message definitions missing under {MSGS_DIR}: {missing}")
    return store


def message(typename: str, **fields: Any) -> Any:
    """A new message of ``typename`` (every field given, nested messages built already)."""
    return typestore().types[typename](**fields)


def encode(msg: Any, typename: str) -> bytes:
    """``msg`` as CDR (little endian, with its encapsulation header)."""
    return bytes(typestore().serialize_cdr(msg, typename, little_endian=True))


def decode(payload: bytes, typename: str) -> Any:
    """The ``typename`` message in ``payload``; MalformedCdr with one line if it is none
    (a wrong or missing header, too short, a length past the end, bytes left over, text
    that is not UTF-8)."""
    try:
        return typestore().deserialize_cdr(payload, typename)
    except Exception as exc:  # rosbags raises SerdeError, and whatever a bad length trips
        short = typename.split("/")[-1]
        raise MalformedCdr(f"not a CDR {short} ({len(payload)} bytes): {exc}") from None


def type_hash(typename: str) -> str:
    """The RIHS01 hash of ``typename`` (REP 2011), as rmw_zenoh puts it in a key."""
    return typestore().hash_rihs01(typename)


def dds_type_name(typename: str) -> str:
    """The DDS name of a ROS 2 type: ``rmf_door_msgs/msg/DoorState`` ->
    ``rmf_door_msgs::msg::dds_::DoorState_``."""
    package, kind, name = typename.split("/")
    return f"{package}::{kind}::dds_::{name}_"
