"""The driver without the bus: the core (:class:`~services.whill_driver.base.Base`) and the
serial link (:class:`~services.whill_driver.chair.ChairLink`) under one lock.

``node.py`` hands it each ``cmd_vel`` and calls :meth:`Driver.step` at the odometry rate;
tests run it the same way against the emulator, without Zenoh. Time is the driver's own
monotonic clock (staleness is judged by arrival, never by another host's stamps); the
stamps of what it publishes come from the caller.
"""

from __future__ import annotations

import logging
import math
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field

from services.whill_driver.base import STOP, Base
from services.whill_driver.chair import ChairLink
from services.whill_driver.config import WhillConfig
from services.whill_driver.odometry import Sample
from shared.messages import DriverStatus, Odometry, Twist


@dataclass
class Output:
    """What one step has for the fleet: odometry (None while the chair is silent), the
    status (None when not due), events (kind, detail, severity)."""

    odometry: Odometry | None
    status: DriverStatus | None
    events: list[tuple[str, str, str]] = field(default_factory=list)


class Driver:
    """One WHILL on one serial port: commands in, odometry, status and events out."""

    def __init__(
        self,
        cfg: WhillConfig,
        log: logging.Logger | None = None,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.cfg = cfg
        self.clock = clock
        self.log = log or logging.getLogger("wheelnav.driver")
        self.base = Base(cfg)
        self.lock = threading.Lock()
        self.link = ChairLink(
            cfg.port,
            self._on_sample,
            interval_ms=cfg.data_interval_ms,
            power_on=cfg.power_on,
            reconnect_s=cfg.reconnect_s,
            data_timeout_s=cfg.data_timeout_s,
            log=self.log,
            on_lost=self._on_lost,
        )
        self._status_at = -math.inf
        self._last_status: DriverStatus | None = None

    def start(self) -> None:
        """Open the port (in the background: the link retries until it opens)."""
        self.link.start()

    def close(self) -> None:
        """Stop the chair, hand it back to its joystick and close the port."""
        self.link.close()

    def on_cmd_vel(self, twist: Twist) -> None:
        """A velocity command from the fleet (NaN and nonsense never get here: the codec)."""
        with self.lock:
            self.base.on_cmd_vel(twist, self.clock())

    def on_estop(self, active: bool, reason: str = "") -> None:
        """The emergency stop was set or cleared; set, the chair is sent a stop at once
        (unless the rider holds it), not at the next step."""
        with self.lock:
            self.base.on_estop(active, reason)
            action = STOP if active and not self.base.rider else None
        self.link.send(action)  # outside the lock, as in step

    def _on_sample(self, sample: Sample) -> None:
        with self.lock:
            self.base.on_sample(sample, self.clock())

    def _on_lost(self) -> None:
        with self.lock:
            self.base.on_link_lost()

    def step(self, stamp: float) -> Output:
        """Send the chair this cycle's command; the odometry, the status if due, events."""
        with self.lock:
            now = self.clock()
            action = self.base.step(now)
        self.link.send(action)  # outside the lock: a write never holds up the reader
        with self.lock:
            fresh = self.base.data_fresh(now)
            odom = self.base.odometry_message(stamp) if fresh else None
            status = self.base.status_message(stamp, self.link.ok and fresh)
            events = self.base.drain_events()
        last = self._last_status
        changed = last is None or _condition(last) != _condition(status)
        if changed or now - self._status_at >= 1.0 / self.cfg.status_rate_hz:
            self._status_at, self._last_status = now, status
        else:
            status = None
        return Output(odom, status, events)


def _condition(s: DriverStatus) -> tuple:
    """The fields whose change is published at once (not the stamp, not the battery)."""
    return (s.joystick_active, s.serial_ok, s.error_code, s.speed_mode)
