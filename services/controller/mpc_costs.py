"""The sampling MPC's cost terms, declared once: name, weight, what each charges.

A rollout's cost is the mean over its steps of the weighted terms below; a term's weight is
the ``MPCConfig`` field it names (``controller.mpc.<weight>``). Both evaluators
(``mpc_numpy``, ``mpc_numba``) compute every term and weight it through the index constants
derived here, and the weights array handed to them is built from this table, so nothing
depends on the order of the rows.

Adding a term: one row here, one index constant below, and its computation in each
evaluator (plus its weight field in ``shared/config.py``'s ``MPCConfig``). The numba kernel
reads the index constants as compile-time constants and is cached on disk; numba does not
notice when a global of another module changes, so after reordering rows without touching
``mpc_numba.py`` clear its cache (``services/controller/__pycache__/mpc_numba*.nb[ic]``).
The tests compare both evaluators term by term and catch a stale kernel.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from shared.config import MPCConfig


@dataclass(frozen=True)
class CostTerm:
    """One cost term: its name, the ``MPCConfig`` weight field, what it charges per step."""

    name: str
    weight: str
    charges: str


TERMS: tuple[CostTerm, ...] = (
    CostTerm("track", "w_track", "cross-track distance: squared, linear beyond track_huber_m"),
    CostTerm("heading", "w_heading", "1 - cos(heading error to the nearest path segment)"),
    CostTerm("speed_ref", "w_speed_ref", "(v - v_ref)^2, v_ref from the path where projected"),
    CostTerm("speed_window", "w_speed_window", "squared excess of v outside the speed window"),
    CostTerm("turn", "w_turn", "input effort: w^2"),
    CostTerm("smooth", "w_smooth", "dv^2 + dw^2 between consecutive inputs"),
    CostTerm("wall", "w_wall", "(1 - clearance / wall_influence_m)^2 against the map's walls"),
    CostTerm("obstacle", "w_obstacle", "(1 - clearance / obstacle_influence_m)^2, LiDAR"),
    CostTerm("goal", "w_goal", "distance to the goal once within goal_radius_m of it"),
    CostTerm(
        "progress",
        "w_progress",
        "shortfall of arc length against what v_ref would cover: progress_running of it "
        "at every step, the rest at the horizon's end",
    ),
)

INDEX: dict[str, int] = {term.name: i for i, term in enumerate(TERMS)}

# Index constants of the evaluators (compile-time constants in the numba kernel)
TRACK = INDEX["track"]
HEADING = INDEX["heading"]
SPEED_REF = INDEX["speed_ref"]
SPEED_WINDOW = INDEX["speed_window"]
TURN = INDEX["turn"]
SMOOTH = INDEX["smooth"]
WALL = INDEX["wall"]
OBSTACLE = INDEX["obstacle"]
GOAL = INDEX["goal"]
PROGRESS = INDEX["progress"]


def weight_names() -> tuple[str, ...]:
    """The ``MPCConfig`` weight field of every term, in table order."""
    return tuple(term.weight for term in TERMS)


def weights(cfg: MPCConfig) -> np.ndarray:
    """The weights array the evaluators read through the index constants (float64)."""
    return np.array([getattr(cfg, term.weight) for term in TERMS], dtype=np.float64)
