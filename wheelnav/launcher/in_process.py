"""The fleet as threads of one process, on one Zenoh session: lockstep runs without a router.

A mission in lockstep spends most of a tick's wall time on messaging between processes
(through the router and back, with a process switch at every hop), not on the services'
own work (``wheelnav bench fleet``). Run as threads of the mission runner, the services
keep their code and their Zenoh endpoints, but everything stays inside the one session,
and their buses hand each other checked messages instead of msgpack bytes
(:class:`~shared.transport.LocalExchange`, when the host's bus has one, as the mission
runner's does). The lockstep protocol is the same, so a run gives the same report as
with a process per service.

What processes give and this does not: a service that dies is not restarted (a restart
test needs processes), and one service's crash can take the others with it. A mission
run uses it with ``launcher.in_process: true`` (``wheelnav mission ... --set
launcher.in_process=true``, the campaign's ``--set`` too); ``wheelnav up`` never does.
"""

from __future__ import annotations

import importlib
import logging
import threading
from collections.abc import Callable
from typing import TextIO

from shared.service import EXIT_CONFIG, Hosting, host_here
from shared.transport import Bus
from wheelnav.launcher.backoff import prefix
from wheelnav.launcher.fleet import ServiceSpec

STOP_GRACE_S = 5.0  # wall time a service has to stop once asked


class _Output(logging.Handler):
    """The services' log records, one line each with the service's tag, to ``out``; the
    last error of each service kept for the runner's reason."""

    def __init__(self, out: TextIO, names: list[str]) -> None:
        super().__init__()
        self.out = out
        self.width = max((len(n) for n in names), default=8)
        self.index = {n: i for i, n in enumerate(names)}
        self.last_error: dict[str, str] = {}
        self.setFormatter(logging.Formatter("%(levelname).1s %(name)s: %(message)s"))

    def emit(self, record: logging.LogRecord) -> None:
        service = record.name.split(".")[1] if record.name.count(".") else record.name
        text = self.format(record)
        if record.levelno >= logging.ERROR:
            self.last_error[service] = text
        tag = prefix(service, self.index.get(service, 0), self.width, False)
        try:
            self.out.write(f"{tag} {text}\n")
            self.out.flush()
        except ValueError:  # the output was closed under a late record
            pass


class InProcessFleet:
    """Starts the services of ``specs`` as threads on ``bus``'s session; stops them.

    The same calls as :class:`~wheelnav.launcher.supervisor.Supervisor` where a mission
    run needs them: :meth:`start`, :meth:`failed`, :meth:`last_error`, :meth:`stop`.
    Nothing restarts a service that ends before :meth:`stop`: ``on_stopped(name, why)`` is
    called instead, so that the run can end at once with the reason.
    """

    def __init__(
        self,
        specs: list[ServiceSpec],
        config_path: str,
        bus: Bus,
        out: TextIO,
        on_stopped: Callable[[str, str], None] | None = None,
    ) -> None:
        self.specs = specs
        self.config_path = config_path
        self.on_stopped = on_stopped
        self.hosting = Hosting(bus.session, bus.dispatcher, bus.exchange)
        self.exit_codes: dict[str, int] = {}
        self._threads: list[threading.Thread] = []
        self._output = _Output(out, [s.name for s in specs])
        self._logger = logging.getLogger("wheelnav")
        self._saved = (self._logger.propagate, self._logger.level)

    def start(self) -> None:
        """Route the services' logs to the output, then start one thread per service."""
        self._logger.addHandler(self._output)
        self._logger.propagate = False
        self._logger.setLevel(logging.INFO)
        for spec in self.specs:
            thread = threading.Thread(
                target=self._run, args=(spec,), name=f"service-{spec.name}", daemon=True
            )
            self._threads.append(thread)
            thread.start()

    def _run(self, spec: ServiceSpec) -> None:
        host_here(self.hosting)
        code = 0
        try:
            module = importlib.import_module(spec.module)
            module.main(["--config", self.config_path, *spec.args])
        except SystemExit as exc:
            code = exc.code if isinstance(exc.code, int) else 1
        except Exception as exc:  # the service failed: say so, as a process's exit would
            logging.getLogger(f"wheelnav.{spec.name}").exception("stopped by an error")
            self._output.last_error.setdefault(spec.name, f"{type(exc).__name__}: {exc}")
            code = 1
        self.exit_codes[spec.name] = code
        if not self.hosting.stopping and self.on_stopped is not None:
            why = self.last_error(spec.name) or f"exit code {code}"
            self.on_stopped(spec.name, why)

    def failed(self) -> list[str]:
        """Services that ended with an error before being asked to stop."""
        return sorted(name for name, code in self.exit_codes.items() if code != 0)

    def last_error(self, name: str) -> str:
        """The last error a service logged ("" if none)."""
        if name not in self._output.last_error and self.exit_codes.get(name) == EXIT_CONFIG:
            return "configuration error"
        return self._output.last_error.get(name, "")

    def stop(self, grace_s: float = STOP_GRACE_S) -> None:
        """Ask every service to stop and wait for its thread (``grace_s`` each at most)."""
        self.hosting.stop_all()
        for thread in self._threads:
            thread.join(timeout=grace_s)
        self._logger.removeHandler(self._output)
        self._logger.propagate, level = self._saved[0], self._saved[1]
        self._logger.setLevel(level)
