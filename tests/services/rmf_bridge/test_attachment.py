"""The rmw_zenoh attachment, byte for byte as rmw_zenoh_cpp writes it, and read back.

The expected bytes are written out by hand from the serializer's format, not computed with
it: zenoh-ext's ``serialization.rs`` (eclipse-zenoh/zenoh, zenoh-ext/src/serialization.rs),
which zenoh-c's ``ze_serializer_*`` and zenoh-cpp's ``zenoh::ext::Serializer`` call, writes
an integer as its fixed-width little-endian bytes (``to_le_bytes``), a string or a byte
buffer as ``VarInt`` (LEB128) of its length then its bytes, and a ``std::array<T, N>`` as
LEB128 ``N`` then its elements (zenoh-cpp include/zenoh/api/ext/serialization.hxx,
``__serialize_sequence_with_serializer``). The field order is rmw_zenoh's
rmw_zenoh_cpp/src/detail/attachment_helpers.cpp: after ros2/rmw_zenoh#601 (positional)
and before it (keyed, with ze_serializer_serialize_str / _int64 / _buf).
"""

from __future__ import annotations

import pytest
import zenoh
from zenoh.ext import Int64, z_deserialize, z_serialize

from services.rmf_bridge.attachment import (
    GID_SIZE,
    KEYED,
    KEYS,
    LAYOUTS,
    NONE,
    POSITIONAL,
    Attachment,
    AttachmentWriter,
    build,
    parse,
)
from shared import config
from shared.config import ConfigError

SEQ = 0x0102  # little endian int64: 02 01 00 00 00 00 00 00
STAMP = 0x0123456789ABCDEF  # little endian int64: ef cd ab 89 67 45 23 01
GID = bytes(range(0x10, 0x20))  # 10 11 ... 1f

SEQ_LE = b"\x02\x01\x00\x00\x00\x00\x00\x00"
STAMP_LE = b"\xef\xcd\xab\x89\x67\x45\x23\x01"
GID_SEQUENCE = b"\x10" + b"\x10\x11\x12\x13\x14\x15\x16\x17\x18\x19\x1a\x1b\x1c\x1d\x1e\x1f"

EXPECTED = {
    # int64, int64, std::array<uint8_t, 16>: 8 + 8 + 1 + 16 = 33 bytes
    POSITIONAL: SEQ_LE + STAMP_LE + GID_SEQUENCE,
    # each field after its name, the name as LEB128 length (15, 16, 10) then its bytes
    KEYED: b"\x0fsequence_number"
    + SEQ_LE
    + b"\x10source_timestamp"
    + STAMP_LE
    + b"\x0asource_gid"
    + GID_SEQUENCE,
}


@pytest.mark.parametrize("layout", [POSITIONAL, KEYED])
def test_the_attachment_is_byte_for_byte_rmw_zenohs(layout: str) -> None:
    data = build(SEQ, STAMP, GID, layout)
    assert data == EXPECTED[layout]
    assert len(data) == {POSITIONAL: 33, KEYED: 77}[layout]


@pytest.mark.parametrize("layout", [POSITIONAL, KEYED])
def test_the_attachment_is_what_zenohs_own_serializer_writes(layout: str) -> None:
    # attachment.py writes the format itself (only node modules import zenoh): the same
    # bytes as z_serialize, here also for a GID whose bytes pass 0x7f and a negative stamp
    gid = bytes(range(0xF0, 0x100))
    for seq, stamp in [(SEQ, STAMP), (2**40 + 3, -5), (2**63 - 1, -(2**63))]:
        ours = build(seq, stamp, gid, layout)
        fields = (Int64(seq), Int64(stamp), gid)
        if layout == KEYED:
            fields = (KEYS[0], fields[0], KEYS[1], fields[1], KEYS[2], gid)
        assert ours == z_serialize(fields).to_bytes(), (seq, stamp)


@pytest.mark.parametrize("layout", [POSITIONAL, KEYED])
def test_an_attachment_reads_back(layout: str) -> None:
    assert parse(EXPECTED[layout], layout) == Attachment(SEQ, STAMP, GID)
    # as zenoh's own deserializer reads it (on good bytes only: see attachment._Reader)
    kinds = {
        POSITIONAL: tuple[Int64, Int64, bytes],
        KEYED: tuple[str, Int64, str, Int64, str, bytes],
    }
    fields = z_deserialize(kinds[layout], zenoh.ZBytes(EXPECTED[layout]))
    if layout == KEYED:
        assert fields[0::2] == KEYS
        fields = fields[1::2]
    assert fields == (SEQ, STAMP, GID)
    # int64 throughout: a number past int32, a timestamp of today, both ends of int64
    for seq, stamp in [(2**40 + 3, 1_760_000_000_123_456_789), (2**63 - 1, -(2**63))]:
        assert parse(build(seq, stamp, GID, layout), layout) == Attachment(seq, stamp, GID)


@pytest.mark.parametrize("layout", [POSITIONAL, KEYED])
def test_what_is_not_an_attachment_of_the_layout_is_refused(layout: str) -> None:
    other = KEYED if layout == POSITIONAL else POSITIONAL
    good = EXPECTED[layout]
    for bad in (EXPECTED[other], good[:-1], good + b"\x00", b""):
        with pytest.raises(ValueError, match=f"{layout} attachment"):
            parse(bad, layout)
    short_gid = good[: -len(GID_SEQUENCE)] + b"\x0f" + GID[:15]
    with pytest.raises(ValueError, match="GID of 15 bytes"):
        parse(short_gid, layout)
    # a length prefix claiming far more than there is (2**62): refused, nothing set aside
    huge = good[: -len(GID_SEQUENCE)] + b"\x80\x80\x80\x80\x80\x80\x80\x80\x40" + GID
    with pytest.raises(ValueError, match="too short"):
        parse(huge, layout)
    if layout == KEYED:
        renamed = good.replace(b"source_gid", b"source_gif")
        with pytest.raises(ValueError, match="'source_gid' expected, found b'source_gif'"):
            parse(renamed, layout)


def test_bad_fields_are_refused() -> None:
    with pytest.raises(ValueError, match="a GID has 16 bytes, got 24"):
        build(1, 0, bytes(24), POSITIONAL)
    with pytest.raises(ValueError, match="not an int64"):
        build(2**63, 0, GID, POSITIONAL)
    with pytest.raises(ValueError, match="attachment layout 'none'"):
        build(1, 0, GID, NONE)


def test_a_writer_numbers_its_samples_from_1_under_one_gid() -> None:
    clock = iter(range(1000, 2000, 10))
    writer = AttachmentWriter(POSITIONAL, clock_ns=lambda: next(clock))
    got = [parse(writer.next(), POSITIONAL) for _ in range(3)]
    assert [(a.sequence_number, a.source_timestamp) for a in got] == [
        (1, 1000),
        (2, 1010),
        (3, 1020),
    ]
    assert {a.gid for a in got} == {writer.gid} and len(writer.gid) == GID_SIZE
    # each writer (each publisher, each start of the bridge) takes a GID of its own
    assert AttachmentWriter(POSITIONAL).gid != AttachmentWriter(POSITIONAL).gid
    assert AttachmentWriter(NONE).next() is None
    with pytest.raises(ValueError, match="attachment layout 'v2'"):
        AttachmentWriter("v2")


def test_the_config_key_takes_the_layouts_and_names_itself_on_a_bad_one() -> None:
    assert config.load(None).rmf_bridge.rmw_zenoh_attachment == POSITIONAL
    for layout in LAYOUTS:
        section = config.load(None, [f"rmf_bridge.rmw_zenoh_attachment={layout}"]).rmf_bridge
        section.validate()
    with pytest.raises(ConfigError, match="rmf_bridge.rmw_zenoh_attachment: must be one of"):
        config.load(None, ["rmf_bridge.rmw_zenoh_attachment=jazzy"]).rmf_bridge.validate()
