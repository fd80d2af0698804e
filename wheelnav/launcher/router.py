"""A Zenoh router in a process of its own, with no subscribers of its own.

A router session routes on its own threads, but a Python subscriber in the same session
is called on the routing path: while that process's interpreter is busy (a mission
runner decoding ground truth, writing its report), samples from the other processes wait
for it. ``wheelnav mission`` therefore routes through this process and joins the fleet as
a client like every service (measured: the demo in lockstep ran 1.4x faster).

Run as ``python -m wheelnav.launcher.router ENDPOINT``; it prints one line once it listens
and stops on SIGTERM or SIGINT, or when the process that started it is gone (see
:func:`shared.service.watch_parent`). :class:`RouterProcess` starts and stops it.
"""

from __future__ import annotations

import argparse
import signal
import subprocess
import sys
import threading

from shared.config import TransportConfig
from shared.service import launcher_env, watch_parent
from shared.transport import open_session

READY = "router listening on"


class RouterProcess:
    """A router child process listening on ``endpoint``; ``start`` returns once it listens."""

    def __init__(self, endpoint: str, timeout_s: float = 30.0) -> None:
        self.endpoint = endpoint
        self.timeout_s = timeout_s
        self.proc: subprocess.Popen | None = None

    def start(self) -> None:
        """Start the router; RuntimeError with its last words if it does not come up."""
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "wheelnav.launcher.router", self.endpoint],
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
            env=launcher_env(),
        )
        lines: list[str] = []
        ready = threading.Event()

        def read() -> None:
            for line in self.proc.stdout:
                lines.append(line.rstrip())
                if line.startswith(READY):
                    ready.set()

        threading.Thread(target=read, name="router-output", daemon=True).start()
        if not ready.wait(self.timeout_s) or self.proc.poll() is not None:
            self.stop()
            raise RuntimeError(f"router on {self.endpoint} did not start: {' | '.join(lines[-3:])}")

    def stop(self) -> None:
        """Stop the router (SIGTERM, then SIGKILL after 5 s)."""
        if self.proc is None or self.proc.poll() is not None:
            return
        self.proc.terminate()
        try:
            self.proc.wait(5.0)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()

    def __enter__(self) -> RouterProcess:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("endpoint", help="where to listen, e.g. tcp/127.0.0.1:7447")
    args = parser.parse_args(argv)
    stop = threading.Event()
    for sig in (signal.SIGTERM, signal.SIGINT):
        signal.signal(sig, lambda *_: stop.set())
    watch_parent(lambda _pid: stop.set())
    try:
        session = open_session(TransportConfig(mode="router", connect=[], listen=[args.endpoint]))
    except RuntimeError as exc:
        print(f"router: {exc}", flush=True)
        return 1
    print(f"{READY} {args.endpoint}", flush=True)
    while not stop.wait(0.5):
        pass
    session.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
