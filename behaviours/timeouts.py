"""A timeout decorator on the fleet's clock (py_trees' own Timeout reads the wall clock).

wheelnav runs on simulation time, so every wait in a tree must time out on that clock
too; the clock is injected as a callable returning seconds.
"""

from __future__ import annotations

from collections.abc import Callable

import py_trees
from py_trees.common import Status


class Timeout(py_trees.decorators.Decorator):
    """Fail (and stop the child) if the child is still RUNNING after ``duration`` seconds.

    Returns the child's status otherwise. When it fires, ``feedback_message`` says "timed
    out after N s" and ``on_timeout(reason)`` is called, so the reason can reach a report.
    ``extra()``, asked each time it starts, adds to ``duration`` what the situation then
    calls for (a manoeuvre ahead). Time the whole mission was held (the emergency stop,
    the rider's pause: :class:`behaviours.safety.PauseGate`) does not count:
    :meth:`discount_hold` takes it off.
    """

    def __init__(
        self,
        name: str,
        child: py_trees.behaviour.Behaviour,
        duration: float,
        clock: Callable[[], float],
        on_timeout: Callable[[str], None] | None = None,
        extra: Callable[[], float] | None = None,
    ) -> None:
        if duration <= 0:
            raise ValueError(f"{name}: duration must be > 0, got {duration}")
        super().__init__(name=name, child=child)
        self.duration = duration
        self.clock = clock
        self.on_timeout = on_timeout
        self.extra = extra
        self.started = 0.0
        self.limit = duration

    def initialise(self) -> None:
        self.started = self.clock()
        self.limit = self.duration + (max(0.0, self.extra()) if self.extra else 0.0)
        self.feedback_message = ""

    def discount_hold(self, held_s: float) -> None:
        """The mission was held ``held_s`` seconds while this ran: that time does not count."""
        self.started += max(0.0, held_s)

    def expired(self, now: float) -> bool:
        """True once its limit has passed since it started (whether ticked or not)."""
        return now - self.started > self.limit

    def update(self) -> Status:
        if self.decorated.status == Status.RUNNING and self.expired(self.clock()):
            self.feedback_message = f"timed out after {self.limit:g} s"
            self.decorated.stop(Status.INVALID)
            if self.on_timeout is not None:
                self.on_timeout(f"{self.decorated.name}: {self.feedback_message}")
            return Status.FAILURE
        return self.decorated.status
