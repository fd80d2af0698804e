"""A message's age on the receiver's clock (shared/arrivals.py)."""

from __future__ import annotations

import math

from shared.arrivals import Arrivals


def test_on_wall_time_the_age_is_the_time_since_arrival_whatever_the_stamp() -> None:
    t = [100.0]
    arrivals = Arrivals(wall=True, monotonic=lambda: t[0])
    assert arrivals.age("pose", 5.0, 1e9) == math.inf  # nothing yet
    arrivals.arrived("pose")
    t[0] = 100.25
    # stamped an hour ahead or behind (another host's clock): the same age
    assert arrivals.age("pose", 1e9 + 3600, 1e9) == 0.25
    assert arrivals.age("pose", 1e9 - 3600, 1e9) == 0.25


def test_in_lockstep_the_age_is_the_stamps_on_simulation_time() -> None:
    arrivals = Arrivals(wall=False, monotonic=lambda: 1 / 0)  # never read
    arrivals.arrived("pose")
    assert arrivals.age("pose", 9.5, 10.0) == 0.5
