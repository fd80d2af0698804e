"""VLP-16 data packets -> one revolution's points in the sensor frame (x forward, y left, z up).

Pure: no sockets, no clock reads; the caller stamps each packet with its arrival time.

Each packet is checked before velodyne_decoder sees it (size, block flags, azimuths, return
mode, product id), so a malformed one raises :class:`MalformedPacket` with one line and
leaves the revolution being gathered as it was. Packets are gathered into revolutions at
the azimuth wrap (0 deg, the sensor's forward axis): a packet whose blocks wrap, or whose
next block would (so a revolution is out as soon as its last packet is in), ends a
revolution; a packet that starts below where the last one ended (the one with the wrap was
lost) starts the next. A revolution covering less than ``MIN_COVERAGE_DEG`` (the first,
joined mid-turn; one that lost many packets) is dropped.

A revolution is decoded by velodyne_decoder's ScanDecoder with the VLP-16's factory
calibration: each laser's elevation and vertical offset, each return placed at the azimuth
its laser fired at. Its points already come in the ROS convention that the contract asks
for (x forward, y left, z up; the manual's native frame has y forward and x right), so
only their x, y, z columns are kept. Returns of distance 0 (none) and outside
[min_range_m, max_range_m] are left out by the decoder.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import velodyne_decoder as vd

PACKET_SIZE = 1206
BLOCKS = 12
BLOCK_SIZE = 100
BLOCK_FLAG = 0xEEFF  # the bytes FF EE read as a little-endian uint16
PRODUCT_VLP16 = 0x22
RETURN_MODES = {0x37: "strongest", 0x38: "last", 0x39: "dual"}
FULL_TURN = 36000  # azimuth units (0.01 deg) in a turn
MIN_COVERAGE_DEG = 324.0  # 90 % of a turn: a revolution covering less is not published
MAX_PACKETS = 400  # a revolution at the slowest spin (300 rpm) has 151: beyond, no wrap came

_HEADER = np.dtype([("flag", "<u2"), ("azimuth", "<u2")])


class MalformedPacket(ValueError):
    """A datagram that is not a VLP-16 data packet (one line saying why)."""


def check_packet(data: bytes) -> str | None:
    """Why ``data`` is not a VLP-16 data packet, or None if it is one."""
    try:
        block_azimuths(data)
    except MalformedPacket as exc:
        return str(exc)
    return None


def block_azimuths(data: bytes) -> np.ndarray:
    """The azimuths (0.01 deg) of the 12 blocks of a VLP-16 data packet; MalformedPacket
    saying why if ``data`` is none."""
    if len(data) != PACKET_SIZE:
        raise MalformedPacket(f"{len(data)} bytes, not {PACKET_SIZE}")
    raw = np.frombuffer(data, dtype=np.uint8, count=BLOCKS * BLOCK_SIZE)
    heads = raw.reshape(BLOCKS, BLOCK_SIZE)[:, :4].copy().view(_HEADER).reshape(BLOCKS)
    bad = np.flatnonzero(heads["flag"] != BLOCK_FLAG)
    if bad.size:
        flag = int(heads["flag"][bad[0]])
        raise MalformedPacket(f"block {bad[0]}: flag {flag:#06x}, not {BLOCK_FLAG:#06x}")
    bad = np.flatnonzero(heads["azimuth"] >= FULL_TURN)
    if bad.size:
        raise MalformedPacket(f"block {bad[0]}: azimuth {int(heads['azimuth'][bad[0]])} >= 36000")
    mode, product = data[-2], data[-1]
    if product != PRODUCT_VLP16:
        raise MalformedPacket(f"product id {product:#04x}, not a VLP-16 ({PRODUCT_VLP16:#04x})")
    if mode not in RETURN_MODES:
        raise MalformedPacket(f"return mode {mode:#04x} unknown")
    return heads["azimuth"].astype(np.int64)


@dataclass(frozen=True)
class Revolution:
    """One turn's returns: float32 (N, 3) points in the sensor frame, stamped with the
    arrival time of its last packet."""

    stamp: float
    points: np.ndarray
    packets: int
    coverage_deg: float


class RevolutionDecoder:
    """Packets in, one :class:`Revolution` out at each azimuth wrap.

    Counters: ``packets`` (well-formed), ``malformed``, ``revolutions`` (returned) and
    ``dropped`` (revolutions not returned: too little of a turn, or not decodable).
    """

    def __init__(self, min_range_m: float = 0.4, max_range_m: float = 100.0) -> None:
        self._decoder = vd.ScanDecoder(
            vd.Config(model=vd.Model.VLP16, min_range=min_range_m, max_range=max_range_m)
        )
        self._pending: list[vd.VelodynePacket] = []
        self._coverage = 0  # azimuth units covered by the pending packets
        self._last_azimuth = -1  # of the last block of the last pending packet
        self._cut_ahead = False  # the last packet ended a revolution before its wrap came
        self.packets = 0
        self.malformed = 0
        self.revolutions = 0
        self.dropped = 0

    def feed(self, data: bytes, stamp: float) -> Revolution | None:
        """Take one datagram received at ``stamp``; the revolution it completes, if any.

        Raises MalformedPacket (and counts it) for anything but a VLP-16 data packet.
        """
        try:
            azimuth = block_azimuths(data)
        except MalformedPacket:
            self.malformed += 1
            raise
        self.packets += 1
        steps = np.diff(azimuth)
        step = float((steps % FULL_TURN).sum()) / (BLOCKS - 1)  # per block
        # the wrap is inside this packet, or right after it (its next block would pass 0);
        # an inside one just after a revolution was cut ahead of it is that same wrap
        inside = bool((steps < 0).any()) and not self._cut_ahead
        ahead = azimuth[-1] + step >= FULL_TURN
        self._cut_ahead = False
        done = None
        if self._pending and azimuth[0] < self._last_azimuth:
            done = self._finish()  # the wrap fell between two packets (one lost, maybe)
        self._pending.append(vd.VelodynePacket(stamp, data))
        self._coverage += int(round((azimuth[-1] - azimuth[0]) % FULL_TURN + step))
        self._last_azimuth = int(azimuth[-1])
        if inside or ahead or len(self._pending) >= MAX_PACKETS:
            self._cut_ahead = ahead and not inside
            ended = self._finish()
            done = ended if ended is not None else done
        return done

    def _finish(self) -> Revolution | None:
        """Decode the pending packets as one revolution (None if it is dropped)."""
        packets, coverage = self._pending, self._coverage
        self._pending, self._coverage, self._last_azimuth = [], 0, -1
        if coverage < MIN_COVERAGE_DEG * 100:
            self.dropped += 1
            return None
        try:
            _stamp, cloud = self._decoder.decode(vd.PacketVector(packets))
        except RuntimeError as exc:  # checked packets should never get here
            self.dropped += 1
            raise MalformedPacket(f"revolution of {len(packets)} packets: {exc}") from None
        self.revolutions += 1
        points = np.ascontiguousarray(cloud[:, :3], dtype=np.float32)
        return Revolution(packets[-1].stamp.host, points, len(packets), coverage / 100.0)
