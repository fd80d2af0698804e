"""The chair over its serial port, through WHILL Inc.'s SDK (``whill.ComWHILL``).

All bytes to and from the chair go through the SDK: this module opens the port, powers
the chair on and starts data set 1, hands every data set to ``on_sample`` from a reader
thread, and sends what the driver decides. A port that cannot be opened or fails is
closed and opened again every ``reconnect_s``; a chair that stops sending for
``data_timeout_s`` (powered off, restarted) is powered on and asked for the data again.
A failed write never raises into the caller: it marks the link for the reader thread to
reopen.

The SDK's ``stop_data_stream`` cannot be sent (whill 1.5 has no length for that command
and raises KeyError), so closing leaves the stream running into a closed port; the chair
does not mind.
"""

from __future__ import annotations

import contextlib
import logging
import select
import threading
import time
from collections.abc import Callable

import serial
from whill import ComWHILL

from services.whill_driver.base import Action
from services.whill_driver.odometry import Sample

READ_TIMEOUT_S = 0.05  # the SDK's read timeout: a torn packet never blocks the reader
SELECT_S = 0.05  # the reader's wait for bytes, so it sees a stop request
POWER_ON_GAP_S = 0.2  # between the two power-on commands (the SDK's gap)


class ChairLink:
    """The SDK on one serial port, kept open, with a reader thread."""

    def __init__(
        self,
        port: str,
        on_sample: Callable[[Sample], None],
        interval_ms: int = 20,
        power_on: bool = True,
        reconnect_s: float = 1.0,
        data_timeout_s: float = 0.5,
        log: logging.Logger | None = None,
        on_lost: Callable[[], None] | None = None,
    ) -> None:
        self.port = port
        self.on_sample = on_sample
        self.on_lost = on_lost
        self.interval_ms = interval_ms
        self.power_on = power_on
        self.reconnect_s = reconnect_s
        self.data_timeout_s = data_timeout_s
        self.log = log or logging.getLogger("wheelnav.driver")
        self.samples = 0  # data sets received
        self.bad_reads = 0  # reads the SDK could not make sense of
        self._com: ComWHILL | None = None
        self._write_lock = threading.Lock()  # one writer at a time: packets never interleave
        self._fault = threading.Event()  # a write failed: the reader reopens
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._last_data = 0.0
        self._last_start = 0.0
        self._down_logged = False

    @property
    def ok(self) -> bool:
        """Whether the port is open (data arriving is the Base's to judge)."""
        return self._com is not None and not self._fault.is_set()

    def start(self) -> None:
        """Start the reader thread (it opens the port)."""
        self._thread = threading.Thread(target=self._run, name="whill-reader", daemon=True)
        self._thread.start()

    def close(self) -> None:
        """Stop the reader, stop the chair and hand it back to its joystick, close."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2.0)
        with self._write_lock:
            com, self._com = self._com, None
            if com is None:
                return
            try:
                com.send_velocity(0, 0)
                com.release_joystick()
            except (serial.SerialException, OSError) as exc:
                self.log.warning("cannot stop the chair on closing: %s", exc)
            com.com.close()

    def send(self, action: Action | None) -> bool:
        """Send ``action`` (None: nothing); False if the link is down or the write failed."""
        if action is None:
            return True
        if action.kind == "release":
            return self._write(lambda com: com.release_joystick())
        return self._write(lambda com: com.send_velocity(front=action.front, side=action.side))

    # -- the reader thread -----------------------------------------------------------------

    def _run(self) -> None:
        while not self._stop.is_set():
            if self._com is None or self._fault.is_set():
                self._drop()
                if not self._open():
                    self._stop.wait(self.reconnect_s)
                continue
            try:
                self._read()
                self._restart_stream_if_silent()
            except (serial.SerialException, OSError) as exc:
                self.log.warning("serial link to %s failed: %s", self.port, exc)
                self._fault.set()
            except Exception:  # a bug must not leave a live driver with a dead reader
                self.log.exception("reading %s failed; reopening", self.port)
                self._fault.set()

    def _open(self) -> bool:
        try:
            com = ComWHILL(port=self.port, timeout=READ_TIMEOUT_S)
        except (serial.SerialException, OSError, ValueError) as exc:
            if not self._down_logged:
                self.log.error(
                    "cannot open %s: %s (retrying every %g s)", self.port, exc, self.reconnect_s
                )
                self._down_logged = True
            return False
        com.register_callback("data_set_1", lambda: self._on_data_set_1(com))
        with self._write_lock:
            self._com = com
            self._fault.clear()
        self._down_logged = False
        self.log.info("serial port %s open", self.port)
        self._start_stream()
        return True

    def _drop(self) -> None:
        with self._write_lock:
            com, self._com = self._com, None
        if com is not None:
            with contextlib.suppress(serial.SerialException, OSError):
                com.com.close()
            if self.on_lost is not None:
                self.on_lost()

    def _start_stream(self) -> None:
        """Power the chair on (if configured) and ask for data set 1.

        Power-on goes twice, ``POWER_ON_GAP_S`` apart, as the SDK's ``send_power_on`` does
        (the first may only wake the chair), without holding the port in between.
        """
        self._last_start = self._last_data = time.monotonic()
        power_on = [ComWHILL.CommandID.SET_POWER, ComWHILL.PowerCommand.ON]
        sends = [power_on, power_on] if self.power_on else []
        for i, command in enumerate(sends):
            if i and self._stop.wait(POWER_ON_GAP_S):
                return
            if not self._write(lambda com, c=command: com.send_command(c)):
                return
        self._write(lambda com: com.start_data_stream(self.interval_ms, 1))

    def _write(self, send: Callable[[ComWHILL], object]) -> bool:
        """``send(com)`` under the write lock; False (and the link marked) if it failed."""
        with self._write_lock:
            com = self._com
            if com is None or self._fault.is_set():
                return False
            try:
                send(com)
            except (serial.SerialException, OSError) as exc:
                self.log.warning("serial write failed on %s: %s", self.port, exc)
                self._fault.set()
                return False
        return True

    def _restart_stream_if_silent(self) -> None:
        now = time.monotonic()
        silent = now - self._last_data > self.data_timeout_s
        if silent and now - self._last_start >= self.reconnect_s:
            self.log.warning(
                "no data from the chair for %.1f s: asking again", now - self._last_data
            )
            self._start_stream()

    def _read(self) -> None:
        com = self._com
        if com is None:
            return
        ready, _, _ = select.select([com.com.fileno()], [], [], SELECT_S)
        if not ready:
            return
        try:
            com.refresh()  # decodes every whole packet waiting; data set 1 calls back
        except (IndexError, ValueError) as exc:  # a torn packet whose checksum passed
            self.bad_reads += 1
            self.log.debug("unreadable packet: %s", exc)

    def _on_data_set_1(self, com: ComWHILL) -> None:
        self._last_data = time.monotonic()
        self.samples += 1
        self.on_sample(
            Sample(
                joy_front=int(com.joy["front"]),
                joy_side=int(com.joy["side"]),
                battery_level=int(com.battery["level"]),
                battery_current_ma=float(com.battery["current"]),
                right_angle=float(com.right_motor["angle"]),
                left_angle=float(com.left_motor["angle"]),
                right_speed_kmh=float(com.right_motor["speed"]),
                left_speed_kmh=float(com.left_motor["speed"]),
                power_on=bool(com.power_status),
                speed_mode=int(com.speed_mode_indicator),
                error_code=int(com.error_code),
                time_diff_ms=float(com.time_diff_ms),
            )
        )
