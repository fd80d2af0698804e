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
  0.2.0 to 0.2.3, Humble 0.1.0 and 0.1.1, rolling before 0.6.0.

The two are not compatible: a subscriber of one release rejects, or misreads, the other's.
The GID is 16 bytes in every release: Humble's ``RMW_GID_STORAGE_SIZE`` is 24, but
rmw_zenoh's Humble branch hard-codes 16 (ros2/rmw_zenoh#388).

Encoded with zenoh-python's own serializer (:func:`zenoh.ext.z_serialize`), so the bytes
are those of the C++ one; a plain ``int`` would go out as int32, hence ``Int64``. Pure but
for :class:`AttachmentWriter`'s clock and random GID.
"""

from __future__ import annotations

import os
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass

import zenoh
from zenoh.ext import Int64, ZDeserializeError, z_deserialize, z_serialize

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
    seq, stamp = Int64(sequence_number), Int64(source_timestamp)
    if layout == POSITIONAL:
        fields: tuple = (seq, stamp, bytes(gid))
    elif layout == KEYED:
        fields = (KEYS[0], seq, KEYS[1], stamp, KEYS[2], bytes(gid))
    else:
        raise ValueError(f"attachment layout {layout!r}: use {POSITIONAL} or {KEYED}")
    return z_serialize(fields).to_bytes()


def parse(data: bytes, layout: str) -> Attachment:
    """The fields of attachment ``data`` written in ``layout``; ValueError with one line if
    it is not one (another layout, too short, bytes left over, a GID not of 16 bytes)."""
    try:
        if layout == POSITIONAL:
            seq, stamp, gid = z_deserialize(tuple[Int64, Int64, bytes], zenoh.ZBytes(data))
        elif layout == KEYED:
            k1, seq, k2, stamp, k3, gid = z_deserialize(
                tuple[str, Int64, str, Int64, str, bytes], zenoh.ZBytes(data)
            )
            if (k1, k2, k3) != KEYS:
                raise ValueError(f"not a keyed attachment: its keys are {k1!r}, {k2!r}, {k3!r}")
        else:
            raise ValueError(f"attachment layout {layout!r}: use {POSITIONAL} or {KEYED}")
    except ZDeserializeError:
        raise ValueError(f"not a {layout} attachment ({len(data)} bytes)") from None
    if len(gid) != GID_SIZE:
        raise ValueError(f"a {layout} attachment with a GID of {len(gid)} bytes, not {GID_SIZE}")
    out = Attachment(int(seq), int(stamp), bytes(gid))
    # zenoh-python's z_deserialize leaves bytes after the last field unread, unlike Rust's
    extra = len(data) - len(build(out.sequence_number, out.source_timestamp, out.gid, layout))
    if extra:
        raise ValueError(f"not a {layout} attachment ({len(data)} bytes): {extra} bytes left over")
    return out


class AttachmentWriter:
    """The attachments of one publisher's samples, as an rmw_zenoh_cpp publisher writes
    them: sequence numbers 1, 2, ... (one per sample), the wall clock in ns, one GID.

    rmw_zenoh_cpp gives each publisher its own GID (a hash of its liveliness token's key,
    random in its earliest releases); the bridge holds no token, so each of its publishers
    takes 16 random bytes when it starts. A restarted bridge thus counts from 1 under a new
    GID, which a subscriber takes for a new publisher rather than for lost messages.
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
