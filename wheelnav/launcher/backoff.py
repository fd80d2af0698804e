"""The launcher's decisions, without processes: restart backoff and log line prefixes."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass
class Backoff:
    """Exponential restart delay that resets after a service has run long enough."""

    base_s: float
    max_s: float
    reset_after_s: float
    failures: int = 0

    def on_exit(self, ran_for_s: float) -> float:
        """Seconds to wait before restarting a service that exited after ``ran_for_s``."""
        if ran_for_s >= self.reset_after_s:
            self.failures = 0
        delay = min(self.max_s, self.base_s * (2**self.failures))
        self.failures += 1
        return delay


COLOURS = ("36", "32", "33", "35", "34", "31", "96", "92")


def prefix(name: str, index: int, width: int, colour: bool) -> str:
    """The ``[name]`` prefix of a service's log lines, padded and optionally coloured."""
    text = f"[{name}]".ljust(width + 2)
    return f"\033[{COLOURS[index % len(COLOURS)]}m{text}\033[0m" if colour else text
