"""UDP datagrams from a port, each handed to a callback with its arrival time, on a thread.

The LiDAR streams about 754 packets a second and never resends: the socket's receive
buffer (``buffer_bytes``, capped by the kernel's net.core.rmem_max) must hold what arrives
while the callback decodes a revolution. The thread polls its stop flag every ``POLL_S``,
so :meth:`UdpReceiver.close` returns within that (and a callback's run).
"""

from __future__ import annotations

import logging
import socket
import threading
import time
from collections.abc import Callable

POLL_S = 0.2
MAX_DATAGRAM = 65535  # read whole datagrams: a too-long one shows its true size
log = logging.getLogger("wheelnav.vlp16_driver")


class UdpReceiver:
    """Binds ``(address, port)`` (port 0: any free one, then in :attr:`port`) and calls
    ``on_datagram(data, stamp)`` for each datagram, ``stamp`` its ``time.time()`` of arrival.

    An exception raised by the callback is logged and the thread goes on.
    """

    def __init__(
        self,
        address: str,
        port: int,
        on_datagram: Callable[[bytes, float], None],
        buffer_bytes: int = 4 << 20,
    ) -> None:
        self._on_datagram = on_datagram
        self._stop = threading.Event()
        self._sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            self._sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, buffer_bytes)
            self._sock.bind((address, port))
        except OSError:
            self._sock.close()
            raise
        self._sock.settimeout(POLL_S)
        self.address, self.port = self._sock.getsockname()[:2]
        self.buffer_bytes = self._sock.getsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF)
        self.datagrams = 0
        self._thread = threading.Thread(target=self._run, name="vlp16-udp", daemon=True)

    def start(self) -> None:
        """Start receiving."""
        self._thread.start()

    def close(self, timeout_s: float = 2.0) -> None:
        """Stop the thread (waiting at most ``timeout_s``) and close the socket."""
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(timeout_s)
        self._sock.close()

    def __enter__(self) -> UdpReceiver:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _run(self) -> None:
        while not self._stop.is_set():
            try:
                data = self._sock.recv(MAX_DATAGRAM)
            except TimeoutError:
                continue
            except OSError as exc:
                if not self._stop.is_set():
                    log.error("udp %s:%d: %s; receiving stopped", self.address, self.port, exc)
                return
            stamp = time.time()
            self.datagrams += 1
            try:
                self._on_datagram(data, stamp)
            except Exception:  # a decoding bug must not stop the stream
                log.exception("datagram of %d bytes not handled", len(data))
