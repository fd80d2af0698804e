"""The narrow-door bench's geometry and measurements (the runs themselves are by hand)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from shared.config import RobotConfig
from shared.site import load_site
from wheelnav.bench.doors import (
    WALL_X,
    crossing,
    door_site,
    draw_start,
    footprint_corners,
    measure,
    summarise,
)

ROBOT = RobotConfig()


def test_the_site_has_the_door_where_the_map_has_its_gap(tmp_path) -> None:
    site = load_site(door_site(tmp_path, 0.8, "hinged", 3.1, "left"))
    (door,) = site.doors
    assert door.width_m == pytest.approx(0.8) and door.motion == "hinged"
    grid = site.floors["1"].map
    occ = grid.occupied(True)
    assert not occ[grid.to_cell(WALL_X, 3.1)] and occ[grid.to_cell(WALL_X, 3.1 + 0.45)]


def test_starts_are_2_to_7_m_before_the_door_and_clear_of_the_walls() -> None:
    rng = np.random.default_rng(3)
    for _ in range(200):
        x, y, theta = draw_start(rng, ROBOT)
        assert 2.0 <= WALL_X - x <= 7.0
        corners = footprint_corners(x, y, theta, ROBOT)
        assert corners.min() >= 0.2 - 1e-9 and corners[:, 0].max() <= WALL_X - 0.2 + 1e-9


def test_the_door_plane_crossing_is_taken_at_the_body_centre() -> None:
    ahead = (ROBOT.footprint.front - ROBOT.footprint.rear) / 2
    # driving along y = 3.12 at 0.2 m/s, heading 0: the body centre is ahead of the axle
    trace = [{"t": t, "x": 6.0 + 0.2 * t, "y": 3.12, "theta": 0.0} for t in np.arange(0, 20, 0.25)]
    at = crossing(trace, ROBOT, WALL_X)
    assert at["t"] == pytest.approx((WALL_X - ahead - 6.0) / 0.2) and at["y"] == pytest.approx(3.12)
    report = {
        "success": True,
        "trace": trace,
        "door_clearance": [{"door": "door", "min_clearance_m": 0.06, "free_width_m": 0.875}],
    }
    row = measure(report, 3.1, 0.9, ROBOT)
    assert row["passed"] and row["lateral_m"] == pytest.approx(0.02) and row["heading_deg"] == 0
    assert row["time_s"] == pytest.approx((WALL_X + 1.0 - ahead - 6.0) / 0.2, abs=0.01)
    s = summarise([row, {**row, "lateral_m": -0.04, "passed": False}])
    assert s["passed"] == 1 and s["lateral_max_m"] == 0.04
    assert s["lateral_rms_m"] == pytest.approx(math.sqrt((0.02**2 + 0.04**2) / 2), abs=1e-4)
    assert crossing(trace[:3], ROBOT, WALL_X) is None  # never got there


def test_each_run_names_its_procedure_and_gives_the_simulator_the_world(tmp_path) -> None:
    from wheelnav.bench.doors import _scenario
    from wheelnav.mission.scenario import load_scenario

    door_site(tmp_path / "map", 0.8, "hinged", 3.1 + 0.07, "left")  # the map: 7 cm off
    door_site(tmp_path / "world", 0.8, "hinged", 3.1, "left")
    path = _scenario(tmp_path, "r", 3, (4.0, 3.0, 0.2), "smooth", world=True)
    sc = load_scenario(path)
    assert sc.config.navigator.door_procedure == "smooth"
    assert sc.config.sim.world_site.endswith("world/site.yaml")
    (mapped,) = load_site(sc.config.site).doors
    (real,) = load_site(sc.config.sim.world_site).doors
    assert mapped.p1[1] - real.p1[1] == pytest.approx(0.07)
    same = load_scenario(_scenario(tmp_path, "r", 3, (4.0, 3.0, 0.2), "stop_turn_go", False))
    assert (
        same.config.sim.world_site == "" and same.config.navigator.door_procedure == "stop_turn_go"
    )


def test_overrides_are_checked_before_any_run_and_cannot_undo_the_procedure(capsys) -> None:
    from shared.config import ConfigError
    from wheelnav.bench.doors import check_overrides, main

    check_overrides(["launcher.in_process=true"])
    with pytest.raises(ConfigError, match="navigator.door_procedure"):
        check_overrides(["navigator.door_procedure=smooth"])
    with pytest.raises(SystemExit):
        main(["--set", "launcher.no_such_key=1"])
    err = capsys.readouterr().err
    assert "--set" in err and "no_such_key" in err


def test_the_drawn_door_entry_is_where_the_raster_has_its_gap(tmp_path) -> None:
    """The simulator builds its walls from the map's cells: a door entry between cell
    edges would stand up to half a cell off the gap the chair passes (a 0.90 m door drawn
    at y 2.725 had its gap at 2.30-3.20 and a sliding leaf 2.5 cm into it)."""
    from wheelnav.bench.doors import draw_door_y

    rng = np.random.default_rng(5)
    for i in range(12):
        width = (0.8, 0.9, 1.0)[i % 3]
        door_y = draw_door_y(rng, width)
        (door,) = load_site(door_site(tmp_path / str(i), width, "sliding", door_y, "left")).doors
        grid = load_site(tmp_path / str(i) / "site.yaml").floors["1"].map
        occ = grid.occupied(True)
        for edge, inward in ((door.p1[1], 1), (door.p2[1], -1)):
            assert not occ[grid.to_cell(WALL_X, edge + inward * 0.01)], (door_y, edge)
            assert occ[grid.to_cell(WALL_X, edge - inward * 0.01)], (door_y, edge)


def test_a_fallback_is_read_from_the_door_s_own_phases() -> None:
    """A recovery's turn on the way to the door (a start in a corner) is no fallback; a
    correct phase at the door is (reports of bench runs 0.90 hinged 0 and 0.80 hinged 9)."""
    from wheelnav.bench.doors import fell_back

    recovered = {
        "phases": [{"name": "recover"}, {"name": "turn"}, {"name": "pass"}],
        "checkpoints": [{"kind": "door", "id": "door", "phases": {"pass": 13.5}}],
    }
    stopped = {"checkpoints": [{"id": "door", "phases": {"pass": 15.3, "correct": 23.2}}]}
    assert not fell_back(recovered) and fell_back(stopped) and not fell_back({})
