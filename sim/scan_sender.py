"""The simulator's LiDAR scans sent as a VLP-16 sends them: UDP data packets at its pace.

On the hardware path the simulator does not publish ``scan``: each scan of its VLP-16
(sim/lidar3d.py, sensor-frame points on its 16 x 1800 beams) becomes one revolution of
data packets (sim/vlp16_packets.py) for the VLP-16 driver to receive and decode. A thread
sends them at the sensor's pace (a revolution takes 0.1 s, as the scans come), so the
simulator's step never waits on the socket. A scan that comes while the last is still
going waits for it; a newer one replaces a waiting one (counted in ``dropped``: a
simulator running late loses revolutions, as a busy host's socket would).

The pace is kept ``CHUNK`` packets at a time (10.6 ms of the sensor's output, back to
back): with one wake-up a packet (754 a second), each waiting its turn for the
interpreter in the busy simulator process, revolutions stretched and more of them were
replaced on a loaded machine. The driver sees the same revolutions at the same rate;
only their packets come in small bursts.
"""

from __future__ import annotations

import contextlib
import math
import threading
import time

import numpy as np

from sim.vlp16_packets import (
    PACKET_S,
    RESYNC_S,
    PacketSender,
    encode_revolution,
    points_to_ranges,
)

N_AZ = 1800  # the simulated VLP-16's azimuths a turn (0.2 deg)
CHUNK = 8  # packets sent back to back, then a wait for the sensor's pace


def revolution_packets(points: np.ndarray, stamp_s: float, n_az: int = N_AZ) -> list[bytes]:
    """The data packets of one scan: ``points`` (N, 3) in the sensor frame, the first
    firing at ``stamp_s`` (the packets carry its microseconds past the hour)."""
    return encode_revolution(points_to_ranges(points, n_az), start_s=stamp_s)


class ScanSender:
    """Sends each scan given to :meth:`submit` to ``(host, port)`` over UDP, in order, on
    its own thread. Counters: ``revolutions`` sent, ``dropped`` (replaced while waiting)."""

    def __init__(self, host: str, port: int, n_az: int = N_AZ) -> None:
        self.n_az = n_az
        self.revolutions = 0
        self.dropped = 0
        self._sender = PacketSender(host, port, speed=math.inf)  # paced here, by chunks
        self._due: float | None = None
        self._pending: tuple[np.ndarray, float] | None = None
        self._wake = threading.Condition()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="vlp16-sender", daemon=True)

    @property
    def packets(self) -> int:
        """Packets sent so far."""
        return self._sender.sent

    def start(self) -> ScanSender:
        """Start the sending thread."""
        self._thread.start()
        return self

    def submit(self, points: np.ndarray, stamp_s: float) -> None:
        """Send this scan next (replacing one still waiting); ``stamp_s``: its time."""
        with self._wake:
            if self._pending is not None:
                self.dropped += 1
            self._pending = (points, stamp_s)
            self._wake.notify()

    def close(self) -> None:
        """Stop the thread (mid-revolution if need be) and close the socket."""
        self._stop.set()
        with self._wake:
            self._wake.notify()
        if self._thread.is_alive():
            self._thread.join(timeout=2.0)
        with contextlib.suppress(OSError):
            self._sender.close()

    def _run(self) -> None:
        while not self._stop.is_set():
            with self._wake:
                self._wake.wait_for(lambda: self._pending is not None or self._stop.is_set())
                job, self._pending = self._pending, None
            if job is None:
                continue
            packets = revolution_packets(job[0], job[1], self.n_az)
            try:
                sent = self._send(packets)
            except OSError:
                continue  # nobody listening yet (an ICMP refusal): the next scan goes anyway
            if sent == len(packets):
                self.revolutions += 1

    def _send(self, packets: list[bytes]) -> int:
        """Send ``packets`` at the sensor's pace, ``CHUNK`` at a time; how many went."""
        sent = 0
        for i in range(0, len(packets), CHUNK):
            now = time.monotonic()
            if self._due is None or now - self._due > RESYNC_S:
                self._due = now  # late (or first): start afresh, no burst to catch up
            if self._stop.wait(max(0.0, self._due - now)):
                break
            chunk = packets[i : i + CHUNK]
            sent += self._sender.send(chunk)
            self._due += len(chunk) * PACKET_S
        return sent
