"""The simulated VLP-16 as the real one speaks: its returns as UDP data packets, at its pace.

The simulator's VLP-16 (sim/lidar3d.py) casts 16 rings x 1800 azimuths a turn; the real
sensor sends the same returns as 1206-byte UDP packets (VLP-16 User Manual, 63-9243 Rev E,
"Data Packet Format" and "Timing"), which is what the driver (services/vlp16_driver) reads:

* 12 data blocks of 100 bytes: the flag ``FF EE``, the azimuth of the block's first firing
  (uint16 little-endian, 0.01 deg), 32 channel records of distance (uint16 LE, 2 mm units,
  0 = no return) and reflectivity (uint8): channels 0-15 are the 16 lasers of the block's
  first firing sequence, 16-31 those of its second;
* a timestamp: microseconds past the hour of the packet's first firing (uint32 LE);
* two factory bytes: the return mode (0x37 strongest) and the product id (0x22 VLP-16).

Lasers fire in id order, 2.304 us apart, one sequence every 55.296 us (two per block), and
their elevations interleave: -15, +1, -13, +3, ..., -1, +15 degrees for ids 0 to 15. Sensor
azimuths turn clockwise seen from above, from the forward axis: the sim's angle ``phi``
(counter-clockwise from x) is at sensor azimuth ``-phi``.

A revolution of the sim's ``n_az`` azimuths is ``n_az / 24`` packets whose firings run over
sensor azimuths (0, 360] degrees, so the turn wraps between two revolutions' packets: a
driver that cuts revolutions at the wrap gets back exactly one per encoded revolution.

The real lasers fire one after the other while the head turns, so a decoder places laser
``i`` of a sequence ``i x 2.304 us`` of rotation after its block azimuth (up to 0.13 deg at
10 Hz); the sim casts all rings of an azimuth at once. Each block azimuth is therefore set
half that spread (:func:`stagger_cdeg`) before its sim azimuth: a decoded beam lies within
0.07 deg of the sim's, and each laser starts at its own height (the manual's vertical
offsets, up to 11.2 mm), as :func:`reported_points` gives.
"""

from __future__ import annotations

import math
import socket
import threading
import time
from collections.abc import Iterable

import numpy as np

PACKET_SIZE = 1206
BLOCKS_PER_PACKET = 12
LASERS = 16
FIRINGS_PER_BLOCK = 2
FIRINGS_PER_PACKET = BLOCKS_PER_PACKET * FIRINGS_PER_BLOCK
BLOCK_FLAG = 0xEEFF  # the bytes FF EE read as a little-endian uint16
DISTANCE_UNIT_M = 0.002
MAX_DISTANCE_M = 65535 * DISTANCE_UNIT_M
LASER_S = 2.304e-6  # between two lasers of a firing sequence
FIRING_S = 55.296e-6  # one firing sequence of the 16 lasers, recharge included
BLOCK_S = FIRINGS_PER_BLOCK * FIRING_S
PACKET_S = BLOCKS_PER_PACKET * BLOCK_S  # 1.327 ms: 754 packets a second
RETURN_STRONGEST = 0x37
PRODUCT_VLP16 = 0x22
DATA_PORT = 2368  # where a VLP-16 sends its data packets by default
DEFAULT_REFLECTIVITY = 50
US_PER_HOUR = 3_600_000_000
RESYNC_S = 0.1  # a sender this far behind its schedule starts a new one (no burst)

# by laser id (the order of a firing sequence): elevation (deg) and vertical offset of the
# laser's origin above the sensor's (m), from the manual's laser table
ELEVATIONS_DEG = (-15, 1, -13, 3, -11, 5, -9, 7, -7, 9, -5, 11, -3, 13, -1, 15)
VERTICAL_OFFSETS_M = (
    0.0112, -0.0007, 0.0097, -0.0022, 0.0081, -0.0037, 0.0066, -0.0051,
    0.0051, -0.0066, 0.0037, -0.0081, 0.0022, -0.0097, 0.0007, -0.0112,
)  # fmt: skip
# the sim's ring of each laser (rings count up from the lowest elevation, -15 deg)
RING_OF_LASER = np.argsort(np.argsort(ELEVATIONS_DEG))

_CHANNEL = np.dtype([("distance", "<u2"), ("reflectivity", "u1")])
_BLOCK = np.dtype([("flag", "<u2"), ("azimuth", "<u2"), ("channels", _CHANNEL, (32,))])
PACKET_DTYPE = np.dtype(
    [
        ("blocks", _BLOCK, (BLOCKS_PER_PACKET,)),
        ("timestamp", "<u4"),
        ("return_mode", "u1"),
        ("product", "u1"),
    ]
)
assert PACKET_DTYPE.itemsize == PACKET_SIZE


def azimuth_step_cdeg(n_az: int) -> int:
    """Sensor azimuth between two firings (0.01 deg) for ``n_az`` a turn; ValueError unless
    ``n_az`` fills whole packets and divides the turn into whole hundredths of a degree."""
    if n_az <= 0 or n_az % FIRINGS_PER_PACKET or 36000 % n_az:
        raise ValueError(f"n_az: must be a multiple of 24 dividing 36000, got {n_az}")
    return 36000 // n_az


def stagger_cdeg(n_az: int) -> int:
    """How far before its firing's azimuth a block's azimuth is set (0.01 deg): half the
    rotation while the 16 lasers fire, at the turn rate of ``n_az`` firings a revolution."""
    rate = FIRINGS_PER_BLOCK * azimuth_step_cdeg(n_az) / BLOCK_S  # 0.01 deg per second
    return round(rate * (LASERS - 1) / 2 * LASER_S)


def firing_columns(n_az: int) -> np.ndarray:
    """The sim's azimuth column of each firing of a revolution, in firing order.

    Column ``a`` is the sim's angle ``-180 + a * 360 / n_az`` degrees (sim/lidar3d.py),
    sensor azimuth ``180 - a * 360 / n_az``; firing ``j`` (from 0) is at sensor azimuth
    ``(j + 1) * 360 / n_az``, so a revolution runs over (0, 360] degrees.
    """
    azimuth_step_cdeg(n_az)
    return (n_az // 2 - 1 - np.arange(n_az)) % n_az


def block_azimuths_cdeg(n_az: int) -> np.ndarray:
    """The azimuth field (0.01 deg) of each block of a revolution, in block order."""
    step = azimuth_step_cdeg(n_az)
    first_firing = (np.arange(0, n_az, FIRINGS_PER_BLOCK) + 1) * step
    return (first_firing - stagger_cdeg(n_az)) % 36000


def distance_units(ranges: np.ndarray) -> np.ndarray:
    """Ranges (m) as the packets carry them: 2 mm units, 0 where there is no return (not
    finite, not positive, or beyond the field's 131 m)."""
    r = np.asarray(ranges, dtype=float)
    ok = np.isfinite(r) & (r > 0) & (r < MAX_DISTANCE_M)
    units = np.zeros(r.shape, dtype=np.uint16)
    units[ok] = np.round(r[ok] / DISTANCE_UNIT_M).astype(np.uint16)
    return units


def _check_ranges(ranges: np.ndarray) -> np.ndarray:
    r = np.asarray(ranges)
    if r.ndim != 2 or r.shape[0] != LASERS:
        raise ValueError(f"ranges: must be (16, n_az), one row per ring, got shape {r.shape}")
    azimuth_step_cdeg(r.shape[1])
    return r


def _firing_order(grid: np.ndarray) -> np.ndarray:
    """A (ring, column) grid as (firing, laser id): the order of the channel records."""
    return grid[RING_OF_LASER][:, firing_columns(grid.shape[1])].T


def encode_revolution(
    ranges: np.ndarray,
    start_s: float = 0.0,
    reflectivity: int | np.ndarray = DEFAULT_REFLECTIVITY,
    return_mode: int = RETURN_STRONGEST,
) -> list[bytes]:
    """The data packets of one revolution, in the order the sensor sends them.

    ``ranges``: (16, n_az) metres, ring by ring from the lowest elevation, column ``a`` at
    the sim's angle ``-180 + a * 360 / n_az`` degrees (as sim/lidar3d.py casts them; see
    :func:`points_to_ranges`); inf or NaN where a beam has no return. ``start_s``: the time
    of the first firing (any clock: the packets carry its microseconds past the hour).
    ``reflectivity``: one value for every return, or a (16, n_az) grid like ``ranges``.
    """
    r = _check_ranges(ranges)
    n_az = r.shape[1]
    n_packets = n_az // FIRINGS_PER_PACKET
    refl = np.broadcast_to(np.asarray(reflectivity, dtype=np.uint8), r.shape)
    shape = (n_packets, BLOCKS_PER_PACKET, FIRINGS_PER_BLOCK * LASERS)
    packets = np.zeros(n_packets, dtype=PACKET_DTYPE)
    blocks = packets["blocks"]
    blocks["flag"] = BLOCK_FLAG
    blocks["azimuth"] = block_azimuths_cdeg(n_az).reshape(n_packets, BLOCKS_PER_PACKET)
    blocks["channels"]["distance"] = _firing_order(distance_units(r)).reshape(shape)
    blocks["channels"]["reflectivity"] = _firing_order(refl).reshape(shape)
    first_firing_us = np.round((start_s + np.arange(n_packets) * PACKET_S) * 1e6)
    packets["timestamp"] = (first_firing_us.astype(np.int64) % US_PER_HOUR).astype(np.uint32)
    packets["return_mode"] = return_mode
    packets["product"] = PRODUCT_VLP16
    return [p.tobytes() for p in packets]


def points_to_ranges(points: np.ndarray, n_az: int = 1800) -> np.ndarray:
    """The (16, n_az) range grid of :func:`encode_revolution` from sensor-frame points.

    Each point goes to the nearest ring and sim azimuth column (exact for the sim's own
    scans, whose points lie on its beams); where two share a beam, the nearer is kept;
    beams without a point, and points more than 1 deg from any ring, give no return.
    """
    step = 360.0 / n_az
    azimuth_step_cdeg(n_az)
    p = np.asarray(points, dtype=float).reshape(-1, 3)
    r = np.linalg.norm(p, axis=1)
    elevation = np.degrees(np.arctan2(p[:, 2], np.hypot(p[:, 0], p[:, 1])))
    ring_f = (elevation + 15.0) / 2.0
    ring = np.round(ring_f).astype(int)
    keep = (np.abs(ring_f - ring) <= 0.5) & (ring >= 0) & (ring < LASERS) & (r > 0)
    column = np.round((np.degrees(np.arctan2(p[:, 1], p[:, 0])) + 180.0) / step).astype(int)
    grid = np.full(LASERS * n_az, np.inf)
    np.minimum.at(grid, ring[keep] * n_az + column[keep] % n_az, r[keep])
    return grid.reshape(LASERS, n_az)


def reported_points(
    ranges: np.ndarray, min_range_m: float = 0.0, max_range_m: float = math.inf
) -> np.ndarray:
    """The float32 (N, 3) points a VLP-16 decoder gives for ``encode_revolution(ranges)``,
    in the sensor frame (x forward, y left, z up) and the packets' order.

    Each return is its encoded distance (2 mm units) from its laser's origin (the
    manual's vertical offset above the sensor's) along the laser's elevation, at the
    azimuth where the laser fires (its block's azimuth plus the rotation until its turn);
    returns outside [min_range_m, max_range_m] are left out, as a decoder does.
    """
    r = _check_ranges(ranges)
    n_az = r.shape[1]
    distance, keep = _reported(r, min_range_m, max_range_m)
    rate = FIRINGS_PER_BLOCK * azimuth_step_cdeg(n_az) / 100.0 / BLOCK_S  # deg per second
    block = np.repeat(block_azimuths_cdeg(n_az) / 100.0, FIRINGS_PER_BLOCK)
    in_block = np.tile(np.arange(FIRINGS_PER_BLOCK) * FIRING_S, n_az // FIRINGS_PER_BLOCK)
    sensor_az = block[:, None] + rate * (in_block[:, None] + np.arange(LASERS) * LASER_S)
    phi = np.radians(-sensor_az)
    el = np.radians(np.asarray(ELEVATIONS_DEG, dtype=float))
    pts = np.stack(
        [
            distance * np.cos(el) * np.cos(phi),
            distance * np.cos(el) * np.sin(phi),
            distance * np.sin(el) + np.asarray(VERTICAL_OFFSETS_M),
        ],
        axis=-1,
    )
    return pts[keep].astype(np.float32)


def reported_beams(
    ranges: np.ndarray, min_range_m: float = 0.0, max_range_m: float = math.inf
) -> tuple[np.ndarray, np.ndarray]:
    """Ring and sim azimuth column of each point of :func:`reported_points` (same
    arguments, same order): which of the sim's beams each decoded point is."""
    r = _check_ranges(ranges)
    n_az = r.shape[1]
    _distance, keep = _reported(r, min_range_m, max_range_m)
    firing, laser = np.nonzero(keep)
    return RING_OF_LASER[laser], firing_columns(n_az)[firing]


def _reported(
    ranges: np.ndarray, min_range_m: float, max_range_m: float
) -> tuple[np.ndarray, np.ndarray]:
    """Encoded distances (m) by (firing, laser id), and which of them a decoder reports."""
    distance = _firing_order(distance_units(ranges)) * DISTANCE_UNIT_M
    keep = (distance > 0) & (distance >= min_range_m) & (distance <= max_range_m)
    return distance, keep


class PacketSender:
    """Sends data packets over UDP to ``(host, port)`` at the sensor's pace, ``speed``
    times faster (``math.inf``: as fast as the socket takes them).

    The pace holds across calls to :meth:`send`, so revolutions sent one after another
    leave the same gap between packets as inside one; a sender more than ``RESYNC_S``
    behind (its caller paused) starts afresh instead of catching up in a burst.
    """

    def __init__(self, host: str, port: int, speed: float = 1.0) -> None:
        if not speed > 0:
            raise ValueError(f"speed: must be > 0, got {speed!r}")
        self.address = (host, port)
        self.interval_s = PACKET_S / speed
        self.sent = 0
        self._due: float | None = None
        self._sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self._sock.setsockopt(socket.SOL_SOCKET, socket.SO_BROADCAST, 1)

    def send(self, packets: Iterable[bytes], stop: threading.Event | None = None) -> int:
        """Send ``packets`` in order, each at its time; returns how many went (fewer if
        ``stop`` was set meanwhile)."""
        n = 0
        for packet in packets:
            now = time.monotonic()
            if self._due is None or now - self._due > RESYNC_S:
                self._due = now
            delay = self._due - now
            if delay > 0:
                if stop is None:
                    time.sleep(delay)
                elif stop.wait(delay):
                    break
            if stop is not None and stop.is_set():
                break
            self._sock.sendto(packet, self.address)
            self._due += self.interval_s
            n += 1
        self.sent += n
        return n

    def close(self) -> None:
        """Close the socket."""
        self._sock.close()

    def __enter__(self) -> PacketSender:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
