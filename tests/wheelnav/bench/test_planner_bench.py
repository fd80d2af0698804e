"""The planner benchmark's map is a connected, seed-sized building (timings are not tested)."""

from __future__ import annotations

import numpy as np

from services.planner.grid_astar import astar
from services.planner.inflation import inflate
from wheelnav.bench.planner import RADIUS_M, RESOLUTION, seed_sized_map


def test_benchmark_map_is_seed_sized_and_connected() -> None:
    occ, start, goal = seed_sized_map(0)
    assert occ.shape == (800, 4000)
    lethal, _ = inflate(occ, RESOLUTION, RADIUS_M)
    s = (int(start[1] / RESOLUTION), int(start[0] / RESOLUTION))
    g = (int(goal[1] / RESOLUTION), int(goal[0] / RESOLUTION))
    path = astar(lethal, s, g)
    assert len(path) > 4000  # crosses the whole building
    assert np.array_equal(seed_sized_map(0)[0], occ)  # deterministic


def test_missing_peer_is_one_line_and_status_2(monkeypatch, capsys) -> None:
    import argparse
    import sys

    from wheelnav.bench.cli import run

    monkeypatch.setitem(sys.modules, "pyastar2d", None)  # import fails, as when not installed
    assert run(argparse.Namespace(name="planner", rest=[])) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "pip install -e '.[bench]'" in err
