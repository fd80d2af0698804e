"""``wheelnav up``: the whole fleet as child processes around an in-process Zenoh router.

Each service's output is prefixed with its name; a service that dies is restarted with
exponential backoff (not one that exits with the config-error code 2: restarting cannot
fix its input); Ctrl-C or SIGTERM stops everything, children first, then the router.
"""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass, field
from typing import TextIO

from shared.config import LauncherConfig, SecurityConfig, TransportConfig
from shared.credentials import ROUTER
from shared.service import EXIT_CONFIG, RESTARTS_ENV, launcher_env
from shared.state_store import STATE_DIR_ENV
from shared.topics import Keys
from shared.transport import Bus, open_session
from wheelnav.launcher.backoff import Backoff, prefix
from wheelnav.launcher.fleet import ServiceSpec


def open_router(
    listen: str,
    security_dir: str = "",
    access_control: dict | None = None,
    connect: list[str] = (),
    identity: str = ROUTER,
) -> Bus:
    """A bus on a Zenoh session in router mode listening on ``listen`` (loopback by default)
    and linked to the routers at ``connect`` (other hosts'); secured by the credentials of
    ``identity`` in ``security_dir`` and ``access_control`` if given."""
    transport = TransportConfig(
        mode="router",
        connect=list(connect),
        listen=[listen],
        security=SecurityConfig(dir=security_dir),
    )
    return Bus(open_session(transport, identity, access_control), "launcher")


@dataclass
class _Child:
    spec: ServiceSpec
    index: int
    backoff: Backoff
    proc: subprocess.Popen | None = None
    started_at: float = 0.0
    restart_at: float | None = None
    restarts: int = 0
    given_up: bool = False
    last_error: str = ""
    reader: threading.Thread | None = field(default=None, repr=False)


class Supervisor:
    """Starts, watches, restarts and stops the fleet's service processes."""

    def __init__(
        self,
        specs: list[ServiceSpec],
        connect: str,
        cfg: LauncherConfig,
        config_path: str | None = None,
        extra_args: list[str] = (),
        out: TextIO = sys.stdout,
        colour: bool | None = None,
    ) -> None:
        self.connect = connect
        self.config_path = config_path
        self.extra_args = list(extra_args)
        self.out = out
        self.colour = out.isatty() if colour is None else colour
        self._width = max(len(s.name) for s in specs) if specs else 8
        self._children = {
            s.name: _Child(
                s,
                i,
                Backoff(
                    cfg.restart_backoff_s, cfg.restart_backoff_max_s, cfg.restart_reset_after_s
                ),
            )
            for i, s in enumerate(specs)
        }
        # where the services keep what a restart needs (shared/state_store.py): the user's
        # folder if the environment names one, else a fresh one for this fleet
        self.state_dir = os.environ.get(STATE_DIR_ENV, "")
        self._own_state = not self.state_dir
        self._stopping = threading.Event()
        self._out_lock = threading.Lock()
        self._monitor: threading.Thread | None = None

    # -- public ---------------------------------------------------------------------------

    def start(self) -> None:
        if self._own_state:
            self.state_dir = tempfile.mkdtemp(prefix="wheelnav-state-")
        for child in self._children.values():
            self._spawn(child)
        self._monitor = threading.Thread(target=self._watch, name="supervisor", daemon=True)
        self._monitor.start()

    def pid(self, name: str) -> int | None:
        proc = self._children[name].proc
        return proc.pid if proc is not None and proc.poll() is None else None

    def restarts(self, name: str) -> int:
        return self._children[name].restarts

    def failed(self) -> list[str]:
        """Services that exited with a configuration error (not restarted)."""
        return [c.spec.name for c in self._children.values() if c.given_up]

    def last_error(self, name: str) -> str:
        """The last error line a service printed ("" if none)."""
        return self._children[name].last_error

    def say(self, text: str) -> None:
        self._print(prefix("launcher", len(self._children), self._width, self.colour), text)

    def stop(self, grace_s: float = 5.0) -> None:
        """SIGTERM every child, then SIGKILL what is left after ``grace_s``."""
        self._stopping.set()
        procs = [c.proc for c in self._children.values() if c.proc and c.proc.poll() is None]
        for proc in procs:
            proc.send_signal(signal.SIGTERM)
        deadline = time.monotonic() + grace_s
        for proc in procs:
            try:
                proc.wait(max(0.0, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
        for child in self._children.values():
            if child.reader is not None:
                child.reader.join(timeout=1.0)
        if self._own_state and self.state_dir:
            shutil.rmtree(self.state_dir, ignore_errors=True)

    # -- internals ------------------------------------------------------------------------

    def _command(self, spec: ServiceSpec) -> list[str]:
        cmd = spec.command(self.config_path or "", self.connect)
        if not self.config_path:
            i = cmd.index("--config")
            del cmd[i : i + 2]
        return [sys.executable, *cmd[1:], *self.extra_args]

    def _spawn(self, child: _Child) -> None:
        # the service publishes how often it was restarted (its Diagnostics)
        env = dict(
            launcher_env(),
            PYTHONUNBUFFERED="1",
            **{RESTARTS_ENV: str(child.restarts), STATE_DIR_ENV: self.state_dir},
        )
        child.proc = subprocess.Popen(
            self._command(child.spec),
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            stdin=subprocess.DEVNULL,
            text=True,
            bufsize=1,
            env=env,
        )
        child.started_at = time.monotonic()
        child.restart_at = None
        tag = prefix(child.spec.name, child.index, self._width, self.colour)
        child.reader = threading.Thread(
            target=self._pump, args=(child, child.proc.stdout, tag), daemon=True
        )
        child.reader.start()

    def _pump(self, child: _Child, stream: TextIO, tag: str) -> None:
        for line in stream:
            text = line.rstrip("\n")
            if " E " in f" {text[:2]}" or "error" in text:
                child.last_error = text
            self._print(tag, text)

    def _print(self, tag: str, text: str) -> None:
        with self._out_lock:
            self.out.write(f"{tag} {text}\n")
            self.out.flush()

    def _watch(self) -> None:
        while not self._stopping.wait(0.05):
            now = time.monotonic()
            for child in self._children.values():
                if child.given_up:
                    continue
                if child.restart_at is not None:
                    if now >= child.restart_at and not self._stopping.is_set():
                        child.restarts += 1
                        self.say(f"restarting {child.spec.name} (restart {child.restarts})")
                        self._spawn(child)
                    continue
                code = child.proc.poll() if child.proc else None
                if code is None:
                    continue
                if code == EXIT_CONFIG:
                    child.given_up = True
                    self.say(
                        f"{child.spec.name} exited with a configuration error; "
                        "not restarting it (fix the config and run again)"
                    )
                    continue
                delay = child.backoff.on_exit(now - child.started_at)
                child.restart_at = now + delay
                self.say(f"{child.spec.name} exited with code {code}; restarting in {delay:.1f} s")


def wait_ready(
    bus: Bus,
    keys: Keys,
    names: list[str],
    timeout_s: float,
    stop: threading.Event | None = None,
    supervisor: Supervisor | None = None,
) -> list[str]:
    """Wait until every service in ``names`` holds its liveliness token; returns the missing.

    Gives up early when ``stop`` is set or a supervised service exited with a config error.
    """
    deadline = time.monotonic() + timeout_s
    missing = set(names)
    while missing and time.monotonic() < deadline and not (stop and stop.is_set()):
        if supervisor is not None and supervisor.failed():
            break
        missing -= {k.rsplit("/", 1)[-1] for k in bus.alive(keys.key("alive"), 0.5)}
        if missing:
            time.sleep(0.1)
    return sorted(missing)
