"""The small base every wheelnav service process stands on.

It parses the shared flags (config file, overrides, robot, transport), loads and checks
the fleet config, sets up logging, opens the Zenoh session, holds the service's
liveliness token (declared by :meth:`Service.ready`, once the service can answer) and
turns SIGTERM/SIGINT into a clean stop. A node module does::

    with Service("planner", description=__doc__) as svc:
        ...slow set-up, then declare endpoints on svc.bus with keys from svc.keys...
        svc.wait()   # announces the service, then blocks

Bad configuration ends the process with one line on stderr and exit code 2.

Every service publishes its counters (:class:`~shared.messages.Diagnostics`: messages in
and bad messages per key, restarts) on ``wheelnav/<robot>/diagnostics/<service>`` every
``DIAGNOSTICS_EVERY_S`` of wall time and once more when it stops; the launcher tells it
how often it was restarted in the environment variable ``WHEELNAV_RESTARTS``.

A service the launcher started stops by itself when the launcher is gone (killed with
SIGKILL, it cannot stop its children): the launcher puts its pid in
``WHEELNAV_PARENT_PID`` and :func:`watch_parent` stops the service once that process is
no longer its parent. Started by hand or by docker compose, nothing is watched.

A service can also run as a thread of another process (wheelnav/launcher/in_process.py):
the thread that calls its ``main`` first names a :class:`Hosting` with :func:`host_here`.
The service then joins the host's Zenoh session instead of opening its own, leaves
signals, the parent watch and the logging set-up to the host, and registers itself so
that the host can stop it.
"""

from __future__ import annotations

import argparse
import logging
import os
import signal
import sys
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

from shared import config as config_mod
from shared.config import ConfigError, FleetConfig
from shared.lockstep import Participant
from shared.messages import Ack, Clock, Diagnostics, KeyCounters
from shared.topics import Keys
from shared.transport import Bus, Dispatcher, LocalExchange, Session, open_session

EXIT_CONFIG = 2
EXIT_STEP_FAILED = 3  # a wall-clock step raised: the launcher restarts the service
DIAGNOSTICS_EVERY_S = 1.0  # wall time between two Diagnostics of a service
RESTARTS_ENV = "WHEELNAV_RESTARTS"  # set by the launcher: restarts before this process
PARENT_ENV = "WHEELNAV_PARENT_PID"  # set by the launcher: stop when it is no longer the parent
PARENT_CHECK_S = 0.5  # wall time between two looks at the parent


def restarts_from_env(environ: dict[str, str] | None = None) -> int:
    """How often the launcher restarted this service (0 if not told, or told nonsense)."""
    text = (os.environ if environ is None else environ).get(RESTARTS_ENV, "0")
    try:
        return max(0, int(text))
    except ValueError:
        return 0


def launcher_env(environ: dict[str, str] | None = None) -> dict[str, str]:
    """The environment for a child of this process that must stop when this one is gone."""
    return dict(os.environ if environ is None else environ, **{PARENT_ENV: str(os.getpid())})


def watch_parent(
    on_gone: Callable[[int], None], environ: dict[str, str] | None = None
) -> threading.Thread | None:
    """Call ``on_gone(pid)`` once, from a daemon thread, when the launcher whose pid is in
    ``PARENT_ENV`` is no longer this process's parent (it died; the orphan was handed to
    init). None, and nothing watched, when the variable is unset or not a pid."""
    try:
        pid = int((os.environ if environ is None else environ).get(PARENT_ENV, ""))
    except ValueError:
        return None

    def watch() -> None:
        while os.getppid() == pid:
            time.sleep(PARENT_CHECK_S)
        on_gone(pid)

    thread = threading.Thread(target=watch, name="parent-watch", daemon=True)
    thread.start()
    return thread


def add_override_argument(parser: argparse.ArgumentParser) -> None:
    """``--set KEY=VALUE`` (repeatable), collected in ``args.overrides``."""
    parser.add_argument(
        "--set",
        metavar="KEY=VALUE",
        action="append",
        default=[],
        dest="overrides",
        help="override one config value, e.g. --set sim.seed=3 (repeatable)",
    )


def add_transport_arguments(parser: argparse.ArgumentParser) -> None:
    """The flags every program shares (zenoh's examples keep these in one helper too)."""
    parser.add_argument("--config", metavar="FILE", help="fleet config YAML (defaults if absent)")
    add_override_argument(parser)
    parser.add_argument("--robot", help="robot name (namespace of its keys)")
    parser.add_argument(
        "--connect",
        metavar="ENDPOINT",
        action="append",
        help="router endpoint, e.g. tcp/192.168.1.20:7447 (repeatable)",
    )
    parser.add_argument(
        "--listen", metavar="ENDPOINT", action="append", help="endpoint to listen on (repeatable)"
    )
    parser.add_argument("--mode", choices=["client", "peer", "router"], help="Zenoh session mode")
    parser.add_argument(
        "--log-level", default="INFO", choices=["DEBUG", "INFO", "WARNING", "ERROR"]
    )


def config_from_args(args: argparse.Namespace) -> FleetConfig:
    """Load the fleet config and apply the command-line flags on top."""
    overrides = list(args.overrides)
    if args.robot:
        overrides.append(f"robot.name={args.robot}")
    if args.mode:
        overrides.append(f"transport.mode={args.mode}")
    cfg = config_mod.load(args.config, overrides)
    if args.connect:
        cfg.transport.connect = list(args.connect)
    elif args.mode == "router":
        # a router links to other routers only where told to (--connect): the default
        # endpoint is a client's way to the fleet's router, maybe this one itself
        cfg.transport.connect = []
    if args.listen:
        cfg.transport.listen = list(args.listen)
    return cfg


@dataclass
class Hosting:
    """Services run as threads of one process, on its one Zenoh ``session``; their buses
    deliver on one ``dispatcher`` (None: each its own) and publish to each other through
    one ``exchange`` (None: through the session)."""

    session: Session
    dispatcher: Dispatcher | None = None
    exchange: LocalExchange | None = None
    services: dict[str, Service] = field(default_factory=dict)
    stopping: bool = False
    lock: threading.Lock = field(default_factory=threading.Lock)

    def register(self, svc: Service) -> None:
        """Keep ``svc`` to stop it; one that starts after :meth:`stop_all` stops at once."""
        with self.lock:
            self.services[svc.name] = svc
            if self.stopping:
                svc.stop_event.set()

    def stop_all(self) -> None:
        """Ask every service to stop (as SIGTERM does to a process), also one still starting."""
        with self.lock:
            self.stopping = True
            for svc in self.services.values():
                svc.stop_event.set()


_hosting = threading.local()


def host_here(hosting: Hosting | None) -> None:
    """Services started from this thread from now on run in ``hosting`` (None: on their own)."""
    _hosting.value = hosting


def hosting_here() -> Hosting | None:
    """The hosting this thread's services run in (None: a process of their own)."""
    return getattr(_hosting, "value", None)


def setup_logging(name: str, level: str = "INFO") -> logging.Logger:
    """One-line log records; the launcher adds the service prefix when it gathers outputs.
    A hosted service leaves the process's logging to its host and sets only its level."""
    if hosting_here() is not None:
        logger = logging.getLogger(f"wheelnav.{name}")
        logger.setLevel(level)
        return logger
    logging.basicConfig(
        level=level, format="%(levelname).1s %(name)s: %(message)s", stream=sys.stderr, force=True
    )
    return logging.getLogger(f"wheelnav.{name}")


class Service:
    """Config, session, liveliness and shutdown for one service process."""

    def __init__(
        self,
        name: str,
        description: str = "",
        argv: Sequence[str] | None = None,
        extra_arguments: Callable[[argparse.ArgumentParser], None] | None = None,
    ) -> None:
        parser = argparse.ArgumentParser(prog=f"wheelnav-{name}", description=description)
        add_transport_arguments(parser)
        if extra_arguments:
            extra_arguments(parser)
        self.args = parser.parse_args(argv)
        self.name = name
        self.hosting = hosting_here()
        self.log = setup_logging(name, self.args.log_level)
        try:
            self.cfg = config_from_args(self.args)
        except ConfigError as exc:
            print(f"wheelnav-{name}: config error: {exc}", file=sys.stderr)
            raise SystemExit(EXIT_CONFIG) from None
        self.keys = Keys(self.cfg.robot.name)
        self.stop_event = threading.Event()
        self.step_failed = False
        self.bus: Bus | None = None
        self._ready = False
        self.restarts = restarts_from_env()
        self._started = time.monotonic()
        self._diag_stop = threading.Event()
        self._diag_thread: threading.Thread | None = None

    def __enter__(self) -> Service:
        if self.hosting is not None:
            self.bus = Bus(
                self.hosting.session,
                self.name,
                owns_session=False,
                dispatcher=self.hosting.dispatcher,
                exchange=self.hosting.exchange,
            )
            self.hosting.register(self)
        else:
            self.bus = Bus(self._open_session(), self.name)
        self._diag_key = self.keys.key("diagnostics", service=self.name)
        self._diag_thread = threading.Thread(
            target=self._diagnostics_loop, name=f"{self.name}-diagnostics", daemon=True
        )
        self._diag_thread.start()
        return self

    def _open_session(self) -> Session:
        """A process's own session, with its signals and the launcher watched."""
        for sig in (signal.SIGTERM, signal.SIGINT):
            signal.signal(sig, lambda *_: self.stop_event.set())
        watch_parent(self._launcher_gone)
        try:
            return open_session(self.cfg.transport, identity=self.name)
        except ConfigError as exc:  # missing credentials: a restart cannot fix them
            print(f"wheelnav-{self.name}: config error: {exc}", file=sys.stderr)
            raise SystemExit(EXIT_CONFIG) from None
        except RuntimeError as exc:
            self.log.error("%s", exc)
            raise SystemExit(1) from None

    def _launcher_gone(self, pid: int) -> None:
        self.log.warning("the launcher (pid %d) is gone: stopping", pid)
        self.stop_event.set()

    def ready(self) -> None:
        """Announce the service (liveliness token) once its endpoints are declared.

        Others wait for this token before relying on the service, so it must come after
        the slow start-up work (site loading, JIT compilation) and the declarations.
        """
        if self._ready:
            return
        assert self.bus is not None
        alive_key = self.keys.key("alive", service=self.name)
        self.bus.declare_alive(alive_key)
        self._ready = True
        self.log.info("ready: %s (robot %s)", alive_key, self.cfg.robot.name)

    def __exit__(self, *exc: object) -> None:
        if self.bus is not None:
            self._diag_stop.set()
            if self._diag_thread is not None:
                self._diag_thread.join(timeout=2.0)
            self._publish_diagnostics()  # the last counts, for whoever listens
            self.bus.close()
        self.log.info("stopped")
        if self.step_failed and exc[0] is None:
            raise SystemExit(EXIT_STEP_FAILED)

    def diagnostics(self) -> Diagnostics:
        """This service's counters now (messages in and bad messages per key, restarts)."""
        assert self.bus is not None
        keys = [KeyCounters(k, n_in, n_bad) for k, (n_in, n_bad) in self.bus.counters().items()]
        return Diagnostics(
            time.time(),
            self.name,
            os.getpid(),
            self.restarts,
            time.monotonic() - self._started,
            sum(k.messages_in for k in keys),
            sum(k.bad_messages for k in keys),
            keys,
        )

    def _publish_diagnostics(self) -> None:
        try:
            self.bus.publish(self._diag_key, self.diagnostics())
        except Exception as exc:  # diagnostics must never take the service down
            self.log.warning("cannot publish diagnostics: %s: %s", type(exc).__name__, exc)

    def _diagnostics_loop(self) -> None:
        while not self._diag_stop.wait(DIAGNOSTICS_EVERY_S):
            self._publish_diagnostics()

    def declare(self, what: str, key: str) -> str:
        """Log a key this service declares (zenoh's examples print theirs) and return it."""
        self.log.info("%s %s", what, key)
        return key

    def wait(self) -> None:
        """Announce readiness if not done yet, then block until SIGTERM/SIGINT."""
        self.ready()
        while not self.stop_event.wait(0.2):
            pass

    def every(self, rate_hz: float, step: Callable[[Clock], None]) -> Participant | None:
        """Run ``step(clock)`` at ``rate_hz`` on the fleet clock (``clock`` in the config).

        On ``sim`` time the service answers the simulator's lockstep; on ``wall`` time (a real
        chair) a thread calls ``step`` under the bus lock.
        """
        if self.cfg.clock == "sim":
            return self._participant(rate_hz, step)
        assert self.bus is not None
        lock, counter = self.bus.lock, iter(range(1 << 62))

        def wall_step(now: float) -> None:
            try:
                with lock:
                    step(Clock(stamp=now, tick=next(counter), dt=1.0 / rate_hz))
            except Exception:
                # a dead step thread in a live process would never be restarted: end the
                # process instead, with a code the launcher restarts
                self.log.exception("step failed; stopping (exit code %d)", EXIT_STEP_FAILED)
                self.step_failed = True
                self.stop_event.set()

        threading.Thread(
            target=wall_loop, args=(rate_hz, wall_step, self.stop_event), daemon=True
        ).start()
        return None

    def _participant(self, rate_hz: float, step: Callable[[Clock], None]) -> Participant:
        assert self.bus is not None
        stages = self.cfg.sim.lockstep_stages
        stage = next((i for i, names in enumerate(stages) if self.name in names), None)
        if stage is None:
            stage = len(stages)
            self.log.warning("%s is in no sim.lockstep_stages list; not in lockstep", self.name)
        ack_key = self.declare("publishes", self.keys.ack)
        part = Participant(
            self.name, stage, rate_hz, step, lambda ack: self._publish_ack(ack_key, ack)
        )
        clock_key = self.declare("subscribes", self.keys.clock_of(stage))
        self.bus.subscribe(clock_key, Clock, part.on_clock, latest=True)
        return part

    def _publish_ack(self, key: str, ack: Ack) -> None:
        assert self.bus is not None
        self.bus.publish(key, ack)


def wall_loop(rate_hz: float, step: Callable[[float], None], stop: threading.Event) -> None:
    """Call ``step(now)`` at ``rate_hz`` of wall time until ``stop`` (hardware without a sim).
    A step that overruns is followed by one step at once and the rate from there: the
    steps it missed are skipped, not run back to back (each takes a tick's worth of speed
    ramps and stall watches), as ROS's Rate does."""
    period = 1.0 / rate_hz
    next_t = time.monotonic()
    while not stop.is_set():
        step(time.time())
        next_t = max(next_t + period, time.monotonic())
        stop.wait(max(0.0, next_t - time.monotonic()))
