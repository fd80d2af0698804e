"""Wall-time pacing of the simulator: at most ``realtime_factor`` x real time, no bursts.

After a step the simulator waits until its clock is due by the wall clock. A simulator
that has fallen behind (its process starved on a loaded machine, stopped in a debugger)
used to run the lost time back to back: ticks faster than real time, on which the
services, at their own wall-clock rates, could not answer, so the chair drove the lost
time on the last command (up to the watchdog's 0.3 s, then braked). Beyond
``sim.max_lag_s`` behind, the lost time is let go instead: the simulator's clock slips
against the wall clock, as a world paused while the simulator could not run.
"""

from __future__ import annotations


class Pacer:
    """How long to wait after each step; ``slipped_s``: the wall time let go so far."""

    def __init__(self, realtime_factor: float, max_lag_s: float, now: float) -> None:
        if not realtime_factor > 0:
            raise ValueError(f"realtime_factor must be > 0, got {realtime_factor}")
        if not max_lag_s >= 0:
            raise ValueError(f"max_lag_s must be >= 0, got {max_lag_s}")
        self.realtime_factor = realtime_factor
        self.max_lag_s = max_lag_s
        self.slipped_s = 0.0
        self._start = now  # the wall time at which the clock read 0 (moved by each slip)

    def wait_s(self, stamp: float, now: float) -> tuple[float, float]:
        """The wall time to wait before the step after the one at ``stamp`` (sim time)
        taken at wall time ``now``, and the wall time let go at this step (0 if none)."""
        ahead = stamp / self.realtime_factor - (now - self._start)
        if ahead >= -self.max_lag_s:
            return max(ahead, 0.0), 0.0
        slip = -self.max_lag_s - ahead
        self._start += slip
        self.slipped_s += slip
        return 0.0, slip
