"""How old a message is, judged on the receiver's own clock.

On wall time a sender's stamp comes from the sender's clock: a driver on another host, or
one that stamps from its own clock (the simulator's starts at 0, a sensor's at its power
on), made every pose stale or none when the controller compared that stamp with its own
``time.time()``. So on wall time a message's age is the time since it arrived, on the
receiver's monotonic clock. In lockstep every stamp is simulation time from the one clock
the simulator keeps, and the age is the stamp's, as before: deterministic, and the same
for a message that waited in a queue.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable


class Arrivals:
    """When each kind of message last arrived, and the age that gives it.

    ``wall``: judge by arrival on ``monotonic`` (the receiver's clock); else by stamp
    against the fleet's simulation time.
    """

    def __init__(self, wall: bool, monotonic: Callable[[], float] = time.monotonic) -> None:
        self.wall = wall
        self._monotonic = monotonic
        self._at: dict[str, float] = {}

    def arrived(self, kind: str) -> None:
        """A message of ``kind`` arrived now."""
        if self.wall:
            self._at[kind] = self._monotonic()

    def age(self, kind: str, stamp: float, now: float) -> float:
        """Seconds since the latest message of ``kind`` (stamped ``stamp``) was current:
        since its arrival on wall time (infinite before any), else ``now - stamp``."""
        if not self.wall:
            return now - stamp
        at = self._at.get(kind)
        return math.inf if at is None else self._monotonic() - at
