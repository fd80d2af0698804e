"""The controller's output: one command and the tracking figures the status reports.

Every tracker returns it (pure pursuit, the sampling MPC, docking); the node turns it into a
``Twist`` and a ``FollowStatus``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass
class Command:
    """One control decision: speeds plus the tracking figures the status reports."""

    v: float
    w: float
    state: str  # idle, following, arrived, stale, blocked
    progress: float = 0.0
    distance_to_goal: float = 0.0
    cross_track: float = 0.0
    # a turn on the spot: how far it has left to go (inf: not known, or not such a turn);
    # the safety check sweeps the corners no further than that plus braking
    turn_left_rad: float = math.inf
