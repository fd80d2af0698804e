"""Probe for tests/wheelnav/test_warm.py: do the services find their kernels cached?

Builds on sites/two_rooms what each service builds at start (the planner's ``Planner``, the
controller's ``Tracker``, the localisation's ``MapLocaliser`` and its warm-up, the
simulator's ``Simulation``), runs one step of each (a plan, a control cycle with LiDAR
points, a simulator tick with its scan), then prints as JSON, for every kernel of the
modules named (default: those ``wheelnav warm`` warms), the signatures numba compiled in
this process (cache misses) and those it loaded from the cache (hits). Run as
``python -m tests.wheelnav.warm_probe [MODULE ...]`` from the tree's root.
"""

from __future__ import annotations

import importlib
import json
import math
import sys

import numpy as np
from numba.core.dispatcher import Dispatcher

from services.controller.tracking import Tracker
from services.localisation.localiser import MapLocaliser, MapModeSettings
from services.localisation.matcher import DistanceField
from services.planner.grid_planner import Planner
from shared import config
from shared.site import load_site
from sim.simulation import Simulation
from wheelnav.warm import MODULES


def run_entry_points() -> None:
    """One start and one step of the planner, controller, localisation and simulator."""
    cfg = config.load(overrides=["site=sites/two_rooms"])
    site = load_site(cfg.site)
    a, b = site.place("room_a"), site.place("room_b")

    plan = Planner(site, cfg.robot, cfg.planner).plan((a.x, a.y), (b.x, b.y), a.floor)

    tracker = Tracker(cfg.controller, cfg.robot, site)
    tracker.set_path("probe", plan.waypoints, plan.v_ref)
    ahead = np.array([[a.x + 1.2, a.y], [a.x + 1.2, a.y + 0.2]])
    tracker.step(a.x, a.y, a.theta, a.floor, 0.0, 0.0, ahead, True, 0.1)

    field = DistanceField.for_floor(site, a.floor)
    settings = MapModeSettings.from_config(cfg.localisation)
    MapLocaliser(field, a.x, a.y, a.theta, a.floor, settings).warm_up()

    sim = Simulation(cfg, site)
    while sim.step().scan is None:
        pass
    assert math.isfinite(sim.state.x)


def kernel_stats(modules: list[str]) -> dict[str, dict[str, list[str]]]:
    """``module.kernel`` -> signatures compiled ("misses") and loaded ("hits") so far."""
    out = {}
    for name in modules:
        module = importlib.import_module(name)
        for attr, obj in vars(module).items():
            if isinstance(obj, Dispatcher) and obj.py_func.__module__ == name:
                stats = obj.stats
                out[f"{name}.{attr}"] = {
                    "misses": [str(sig) for sig in stats.cache_misses],
                    "hits": [str(sig) for sig in stats.cache_hits],
                }
    return out


if __name__ == "__main__":
    run_entry_points()
    print(json.dumps(kernel_stats(sys.argv[1:] or list(MODULES))))
