"""The per-sample attachment rmw_zenoh_cpp's subscribers expect: sequence number, source
timestamp and publisher GID (``rmf_bridge.rmw_zenoh_attachment``).

A subscriber of rmw_zenoh_cpp drops a sample without an attachment ("Unable to obtain
attachment") and hands the three fields to ROS 2 as the message info; it counts gaps in one
publisher's sequence numbers as lost messages. The layout is rmw_zenoh's
``rmw_zenoh_cpp/src/detail/attachment_helpers.cpp`` (github.com/ros2/rmw_zenoh), written
with the Zenoh serialization format (``zenoh::ext::Serializer`` / zenoh-c's
``ze_serializer_*``: fixed-width integers little endian, a string or byte sequence as its
LEB128 length then its bytes). Two layouts were released:

* ``positional``: int64 sequence number, int64 source timestamp, the GID as
  ``std::array<uint8_t, 16>`` (LEB128 length 16, then the 16 bytes): 33 bytes. Since
  ros2/rmw_zenoh#601 (April 2025): rolling 0.6.0 and later (so Kilted), Jazzy 0.2.4 and
  later (#605), Humble 0.1.2 and later (#606).
* ``keyed``: each field after its name as a string, ``"sequence_number"``,
  ``"source_timestamp"``, ``"source_gid"`` (the GID as a 16-byte buffer): 77 bytes. Jazzy
  0.2.0 to 0.2.3, Humble 0.1.0 and 0.1.1, rolling from the Zenoh 1.0 port (#276) to #601.

The two are not compatible: a subscriber of one release rejects, or misreads, the other's.
The GID is 16 bytes in every release: Humble's ``RMW_GID_STORAGE_SIZE`` is 24, but
rmw_zenoh's Humble branch hard-codes 16 (ros2/rmw_zenoh#388).

Written here, in a few lines, rather than with zenoh-python's ``zenoh.ext.z_serialize``:
only node modules may use zenoh (wheelnav/import_rules.py), and the tests check these bytes
against ``z_serialize``'s (with ``Int64``: a plain ``int`` goes out as int32 there). Read back
(:func:`parse`) by a reader of the same format that checks every length first, where
zenoh-python's ``z_deserialize`` would not. Pure but for :class:`AttachmentWriter`'s clock
and random GID.
"""

from __future__ import annotations

import os
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass

POSITIONAL = "positional"
KEYED = "keyed"
NONE = "none"
LAYOUTS = (POSITIONAL, KEYED, NONE)  # rmf_bridge.rmw_zenoh_attachment (shared/config.py)
GID_SIZE = 16
INT64_MIN, INT64_MAX = -(2**63), 2**63 - 1
KEYS = ("sequence_number", "source_timestamp", "source_gid")  # the keyed layout's names


@dataclass(frozen=True)
class Attachment:
    """One sample's attachment: the publisher's sequence number (from 1), the source
    timestamp (ns since the UNIX epoch, wall clock) and the publisher's GID."""

    sequence_number: int
    source_timestamp: int
    gid: bytes


def build(sequence_number: int, source_timestamp: int, gid: bytes, layout: str) -> bytes:
    """The attachment bytes rmw_zenoh_cpp writes for these fields in ``layout``
    (``positional`` or ``keyed``); ValueError for another layout, a GID not of 16 bytes,
    or a number outside int64."""
    if len(gid) != GID_SIZE:
        raise ValueError(f"a GID has {GID_SIZE} bytes, got {len(gid)}")
    for name, value in (("sequence number", sequence_number), ("timestamp", source_timestamp)):
        if not INT64_MIN <= value <= INT64_MAX:
            raise ValueError(f"{name} {value} is not an int64")
    if layout not in (POSITIONAL, KEYED):
        raise ValueError(f"attachment layout {layout!r}: use {POSITIONAL} or {KEYED}")
    fields = (
        sequence_number.to_bytes(8, "little", signed=True),
        source_timestamp.to_bytes(8, "little", signed=True),
        _sized(bytes(gid)),
    )
    if layout == KEYED:  # each field after its name
        return b"".join(_sized(k.encode()) + f for k, f in zip(KEYS, fields, strict=True))
    return b"".join(fields)


def _sized(data: bytes) -> bytes:
    """A string or byte sequence in the Zenoh serialization format: LEB128 length, bytes."""
    n, head = len(data), bytearray()
    while True:
        byte, n = n & 0x7F, n >> 7
        head.append(byte | (0x80 if n else 0))
        if not n:
            return bytes(head) + data


def parse(data: bytes, layout: str) -> Attachment:
    """The fields of attachment ``data`` written in ``layout``; ValueError with one line if
    it is not one (another layout, too short, bytes left over, a GID not of 16 bytes)."""
    if layout not in (POSITIONAL, KEYED):
        raise ValueError(f"attachment layout {layout!r}: use {POSITIONAL} or {KEYED}")
    reader = _Reader(bytes(data))
    try:
        if layout == KEYED:
            reader.key(KEYS[0])
        seq = reader.int64()
        if layout == KEYED:
            reader.key(KEYS[1])
        stamp = reader.int64()
        if layout == KEYED:
            reader.key(KEYS[2])
        gid = reader.sized()
        if len(gid) != GID_SIZE:
            raise ValueError(f"a GID of {len(gid)} bytes, not {GID_SIZE}")
        if reader.left():
            raise ValueError(f"{reader.left()} bytes left over")
    except ValueError as exc:
        raise ValueError(f"not a {layout} attachment ({len(data)} bytes): {exc}") from None
    return Attachment(seq, stamp, gid)


class _Reader:
    """Reads the Zenoh serialization format, every length checked against what is left
    before anything is taken: zenoh-python's ``z_deserialize`` (1.10) sets aside whatever
    length a prefix claims, so a malformed attachment can abort the process, out of memory."""

    def __init__(self, data: bytes) -> None:
        self._data = data
        self._at = 0

    def left(self) -> int:
        return len(self._data) - self._at

    def take(self, n: int) -> bytes:
        if n > self.left():
            raise ValueError(f"too short for {n} more bytes at byte {self._at}")
        self._at += n
        return self._data[self._at - n : self._at]

    def int64(self) -> int:
        return int.from_bytes(self.take(8), "little", signed=True)

    def sized(self) -> bytes:
        """A string or byte sequence: its LEB128 length, then its bytes."""
        n = shift = 0
        while True:
            byte = self.take(1)[0]
            n |= (byte & 0x7F) << shift
            if byte < 0x80:
                return self.take(n)
            shift += 7
            if shift > 63:
                raise ValueError("a length of more than 64 bits")

    def key(self, name: str) -> None:
        """The keyed layout's name of the next field."""
        found = self.sized()
        if found != name.encode():
            raise ValueError(f"{name!r} expected, found {found!r}")


class AttachmentWriter:
    """The attachments of one publisher's samples, as an rmw_zenoh_cpp publisher writes
    them: sequence numbers 1, 2, ... (one per sample), the wall clock in ns, one GID.

    rmw_zenoh_cpp gives each publisher its own GID (a hash of its liveliness token's key,
    random in earlier versions of its source); the bridge holds no token, so each of its
    publishers takes 16 random bytes when it starts. A restarted bridge thus counts from 1
    under a new GID, which a subscriber takes for a new publisher, not for lost messages.
    Layout ``none``: no attachment (:meth:`next` gives None).
    """

    def __init__(
        self,
        layout: str,
        gid: bytes | None = None,
        clock_ns: Callable[[], int] = time.time_ns,
    ) -> None:
        if layout not in LAYOUTS:
            raise ValueError(f"attachment layout {layout!r}: use one of {', '.join(LAYOUTS)}")
        self.layout = layout
        self.gid = os.urandom(GID_SIZE) if gid is None else bytes(gid)
        if len(self.gid) != GID_SIZE:
            raise ValueError(f"a GID has {GID_SIZE} bytes, got {len(self.gid)}")
        self._clock_ns = clock_ns
        self._next = 1
        self._lock = threading.Lock()

    def next(self) -> bytes | None:
        """The attachment of the publisher's next sample (None for layout ``none``)."""
        if self.layout == NONE:
            return None
        with self._lock:
            seq, self._next = self._next, self._next + 1
        return build(seq, self._clock_ns(), self.gid, self.layout)
