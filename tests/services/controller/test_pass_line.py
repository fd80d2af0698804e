"""A precise pass holds the door's line: the chair model's caster kick at set-off (a yaw
rate drawn per start) must not swing the footprint's corners into the jambs.

Closed loop of the tracker and the simulator's chair model (motor lag, acceleration
limits, caster kick), the door plane at x = 0 and its centre line y = 0. Campaign at
f62386f: most door clearances under their limit were the nose entering a doorway 1-3 deg
off the line after a kick, 0-6 mm short of (free width - chair width) / 2 - 3 cm.
"""

from __future__ import annotations

import math

import numpy as np

from services.controller.tracking import Tracker
from shared.config import load
from sim.robot import Chair, ChairState

CFG = load(None, [])
FP = CFG.robot.footprint
HALF = FP.width / 2
CONTROL_S = 1.0 / CFG.controller.rate_hz
STEP_S = 0.01


def corner_excess(lateral_m: float, heading_deg: float, seed: int, start_x: float = -1.05) -> float:
    """How far (m) any footprint corner strays beyond the chair's half width from the door's
    centre line while it is within 0.25 m of the door plane, on a pass from rest."""
    chair = Chair(
        CFG.robot,
        ChairState(start_x, lateral_m, math.radians(heading_deg)),
        CFG.sim.motor_lag_s,
        1.0,
        CFG.sim.caster_disturbance,
        np.random.default_rng(seed),
    )
    tracker = Tracker(CFG.controller, CFG.robot, None)
    path = np.linspace((start_x, 0.0), (1.5, 0.0), 12)
    v = np.full(len(path), CFG.planner.door_speed)
    v[-1] = 0.0
    tracker.set_path("pass", path, v, precise=True)
    t, next_control, worst = 0.0, 0.0, -math.inf
    while t < 30.0 and chair.state.x < 1.2:
        s = chair.state
        if t >= next_control - 1e-9:
            cmd = tracker.step(s.x, s.y, s.theta, "1", s.v, s.w, None, True, CONTROL_S)
            chair.command(cmd.v, cmd.w, t)
            next_control += CONTROL_S
        chair.step(STEP_S, t)
        t += STEP_S
        c, sn = math.cos(s.theta), math.sin(s.theta)
        for fx in (FP.front, -FP.rear):
            for fy in (HALF, -HALF):
                x = s.x + fx * c - fy * sn
                if abs(x) <= 0.25:
                    worst = max(worst, abs(s.y + fx * sn + fy * c) - HALF)
    assert chair.state.x >= 1.2, "the pass did not get through"
    return worst


def test_caster_kicks_at_set_off_keep_the_corners_within_2_5_cm_of_the_line() -> None:
    rng = np.random.default_rng(7)
    excess = np.array(
        [
            corner_excess(rng.uniform(-0.015, 0.015), rng.uniform(-1.0, 1.0), seed)
            for seed in range(60)
        ]
    )
    # docking leaves the chair within 1.5 cm and 1 deg of the line; 3 cm is the campaign's
    # whole allowance past the slack, so the pass itself may spend at most half of it on most starts
    assert np.percentile(excess, 90) <= 0.015, np.round(np.sort(excess)[-6:], 4)
    assert excess.max() <= 0.025, np.round(np.sort(excess)[-6:], 4)
