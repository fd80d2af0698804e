"""CDR of the bundled Open-RMF definitions: bytes laid out as ROS 2 puts them on the wire
(checked against hand-packed messages, not only a round trip), malformed payloads refused
with one line, and the names and hashes rmw_zenoh would key them by."""

from __future__ import annotations

import struct

import numpy as np
import pytest
from rosbags.typesys import Stores, get_typestore

from services.rmf_bridge import cdr
from services.rmf_bridge.errors import MalformedCdr

LE = b"\x00\x01\x00\x00"  # CDR encapsulation header: plain CDR, little endian
BE = b"\x00\x00\x00\x00"  # ... big endian


def cdr_string(text: str, order: str = "<") -> bytes:
    """A CDR string: uint32 length counting the NUL, the bytes, the NUL (unpadded)."""
    raw = text.encode() + b"\x00"
    return struct.pack(f"{order}I", len(raw)) + raw


def pad(body: bytes, to: int = 4) -> bytes:
    """``body`` padded so the next field starts aligned (offsets count from after the header)."""
    return body + b"\x00" * (-len(body) % to)


def door_state_bytes(name: str, mode: int, sec: int = 12, nanosec: int = 5, order: str = "<"):
    """An rmf_door_msgs/DoorState packed by hand: Time, door_name, DoorMode.value."""
    body = struct.pack(f"{order}iI", sec, nanosec) + cdr_string(name, order)
    return (LE if order == "<" else BE) + pad(body) + struct.pack(f"{order}I", mode)


def test_a_hand_packed_door_state_decodes_field_by_field() -> None:
    for order in "<>":
        msg = cdr.decode(door_state_bytes("Door_L1_03", 2, order=order), cdr.DOOR_STATE)
        assert msg.door_name == "Door_L1_03" and msg.current_mode.value == 2
        assert (msg.door_time.sec, msg.door_time.nanosec) == (12, 5)


def test_a_door_request_encodes_as_ros_2_lays_it_out() -> None:
    time = cdr.message(cdr.TIME, sec=1700000000, nanosec=250_000_000)
    mode = cdr.message(cdr.DOOR_MODE, value=2)
    req = cdr.message(
        cdr.DOOR_REQUEST, request_time=time, requester_id="chair1", door_name="d1",
        requested_mode=mode,
    )  # fmt: skip
    body = pad(struct.pack("<iI", 1700000000, 250_000_000) + cdr_string("chair1"))
    body = pad(body + cdr_string("d1")) + struct.pack("<I", 2)  # each uint32 4-aligned
    assert cdr.encode(req, cdr.DOOR_REQUEST) == LE + body


def test_lift_messages_round_trip() -> None:
    time = cdr.message(cdr.TIME, sec=3, nanosec=4)
    state = cdr.message(
        cdr.LIFT_STATE, lift_time=time, lift_name="LIFT_A", available_floors=["L1", "L2"],
        current_floor="L1", destination_floor="L2", door_state=1, motion_state=1,
        available_modes=np.array([1, 2], dtype=np.uint8), current_mode=2, session_id="c-7",
    )  # fmt: skip
    back = cdr.decode(cdr.encode(state, cdr.LIFT_STATE), cdr.LIFT_STATE)
    assert back.available_floors == ["L1", "L2"] and back.session_id == "c-7"
    assert back.available_modes.tolist() == [1, 2] and back.current_mode == 2
    req = cdr.message(
        cdr.LIFT_REQUEST, lift_name="LIFT_A", request_time=time, session_id="c-7",
        request_type=1, destination_floor="L2", door_state=2,
    )  # fmt: skip
    back = cdr.decode(cdr.encode(req, cdr.LIFT_REQUEST), cdr.LIFT_REQUEST)
    assert (back.lift_name, back.request_type, back.destination_floor) == ("LIFT_A", 1, "L2")


@pytest.mark.parametrize(
    ("payload", "why"),
    [
        (b"", "unsupported CDR encapsulation"),
        (b"\x07\x07\x00\x00" + door_state_bytes("d", 0)[4:], "unsupported CDR encapsulation"),
        (door_state_bytes("d1", 2)[:12], "requires a buffer"),  # cut inside the name
        (LE + struct.pack("<iII", 0, 0, 0xFFFFFFFF), "string length"),  # a length past the end
        (door_state_bytes("d1", 2) + b"\x00" * 8, "size mismatch"),  # bytes left over
        (LE + struct.pack("<iII", 0, 0, 3) + b"\xff\xfe\x00", "utf-8"),
    ],
)
def test_a_malformed_payload_raises_one_line_naming_the_type(payload: bytes, why: str) -> None:
    with pytest.raises(MalformedCdr, match=f"not a CDR DoorState .*{why}") as err:
        cdr.decode(payload, cdr.DOOR_STATE)
    assert "\n" not in str(err.value)


def test_the_bundled_time_is_ros_2s_and_the_rmw_zenoh_names() -> None:
    # registering our Time.msg into rosbags' store (which has ROS 2's) would fail if it
    # differed; the hash is REP 2011's, checked on a type whose hash is published
    assert cdr.type_hash(cdr.TIME) == get_typestore(Stores.ROS2_JAZZY).hash_rihs01(cdr.TIME)
    assert (
        get_typestore(Stores.ROS2_JAZZY).hash_rihs01("std_msgs/msg/String")
        == "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18"
    )
    assert cdr.dds_type_name(cdr.DOOR_STATE) == "rmf_door_msgs::msg::dds_::DoorState_"
    for typename in cdr.TYPES:
        assert cdr.type_hash(typename).startswith("RIHS01_") and len(cdr.type_hash(typename)) == 71
