"""WHILL base driver: cmd_vel to a WHILL Model CR over its serial port, odometry back.

The hardware driver of docs/ARCHITECTURE.md ("Contract for a hardware driver"), for the
base: holds ``alive/driver``; takes ``cmd_vel`` and stops the chair when none has arrived
for ``whill.command_timeout_s`` (0.3 s); publishes ``odom`` at ``whill.odom_rate_hz``
(50 Hz; not while the chair is silent), the base's condition on ``driver/status`` (on
change and at ``whill.status_rate_hz``) and events on ``events/driver`` (the rider took
or let go of the joystick, the command watchdog stopped the chair, a chair error, the
emergency stop). It obeys the emergency stop (shared/estop.py): a stop every cycle while
it is active, whatever ``cmd_vel`` says. Runs on wall time only (``clock: wall``); the
serial port is ``whill.port`` or ``--port``. On stopping it stops the chair and hands it
back to its joystick. Its stamps are this host's clock (plus ``whill.stamp_offset_s``, for
tests of a host whose clock is off).
"""

from __future__ import annotations

import argparse
import logging
import sys

from services.whill_driver.config import whill_section
from services.whill_driver.driver import Driver
from shared.config import ConfigError
from shared.estop import EstopLatch, hold_estop
from shared.messages import Clock, Event, Twist
from shared.service import EXIT_CONFIG, Service

NAME = "driver"  # the contract's liveliness token: wheelnav/<robot>/alive/driver
LOG_LEVELS = {"info": logging.INFO, "warning": logging.WARNING, "error": logging.ERROR}


def _arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--port", help="the chair's serial port (overrides whill.port)")


def main(argv: list[str] | None = None) -> None:
    with Service(NAME, __doc__.splitlines()[0], argv, extra_arguments=_arguments) as svc:
        cfg, keys, bus = svc.cfg, svc.keys, svc.bus
        whill = whill_section(cfg)
        if svc.args.port:
            whill.port = svc.args.port
        try:
            whill.validate()
            if cfg.clock != "wall":
                raise ConfigError(f"clock: the WHILL driver runs on wall time, got {cfg.clock!r}")
        except ConfigError as exc:
            print(f"wheelnav-{NAME}: config error: {exc}", file=sys.stderr)
            raise SystemExit(EXIT_CONFIG) from None
        robot = cfg.robot
        if (
            whill.max_speed < robot.max_speed
            or whill.max_reverse_speed < robot.max_reverse_speed
            or whill.max_turn_rate < robot.max_turn_rate
        ):
            svc.log.warning(
                "whill limits (%g m/s, %g m/s reverse, %g rad/s) are below the robot's: the"
                " chair will be slower than the controller plans",
                whill.max_speed,
                whill.max_reverse_speed,
                whill.max_turn_rate,
            )
        driver = Driver(whill, svc.log)
        odom_key = svc.declare("publishes", keys.odom)
        status_key = svc.declare("publishes", keys.driver_status)
        events_key = svc.declare("publishes", keys.key("events", source=NAME))

        def on_estop(latch: EstopLatch) -> None:
            driver.on_estop(latch.stop.active, latch.reason())

        def step(clock: Clock) -> None:
            stamp = clock.stamp + whill.stamp_offset_s  # this host's clock (tests: off by that)
            out = driver.step(stamp)
            if out.odometry is not None:
                bus.publish(odom_key, out.odometry)
            if out.status is not None:
                bus.publish(status_key, out.status)
            for kind, detail, severity in out.events:
                svc.log.log(LOG_LEVELS.get(severity, logging.WARNING), "%s: %s", kind, detail)
                bus.publish(events_key, Event(stamp, NAME, kind, detail, severity))

        bus.subscribe(svc.declare("subscribes", keys.cmd_vel), Twist, driver.on_cmd_vel)
        hold_estop(bus, keys, NAME, svc.log, on_estop)
        svc.log.info("serial port %s, data every %d ms", whill.port, whill.data_interval_ms)
        driver.start()
        try:
            svc.every(whill.odom_rate_hz, step)
            svc.wait()
        finally:
            driver.close()


if __name__ == "__main__":
    main()
