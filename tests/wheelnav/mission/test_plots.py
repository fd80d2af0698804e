"""The report's trace (kept by the Recorder from synthetic messages) and the mission plots
drawn from it: known pixels of the PNG (path, wall, free floor, door crossing, phase bars),
door crossings, floors, and the ``--plots`` flag. Pure: no fleet, no simulation."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import pytest
from matplotlib.colors import to_rgb
from PIL import Image

from shared.messages import NavStatus, SimStatus
from shared.site import Site, load_site
from tests.conftest import ROOT
from wheelnav.mission import cli as mission_cli
from wheelnav.mission.plots import (
    DOOR_COLOUR,
    PATH_COLOUR,
    MissionFigure,
    door_crossings,
    mission_figure,
    phase_colour,
    save,
    write_plots,
)
from wheelnav.mission.report import MAX_TRACE, TRACE_EVERY_S, Recorder

DT = 0.02  # the simulator's tick


@pytest.fixture(scope="module")
def two_rooms() -> Site:
    return load_site(ROOT / "sites" / "two_rooms")


def straight_trace(x0: float, x1: float, y: float, v: float = 0.5, t0: float = 1.0) -> list[dict]:
    """Trace samples every 0.25 s along y from x0 to x1 on floor 1."""
    n = int(abs(x1 - x0) / (v * TRACE_EVERY_S))
    return [
        {
            "t": round(t0 + i * TRACE_EVERY_S, 3),
            "x": x0 + (x1 - x0) * i / n,
            "y": y,
            "theta": 0.0,
            "floor": "1",
            "speed": v,
            "clearance": 0.4,
        }
        for i in range(n + 1)
    ]


def demo_report(trace: list[dict]) -> dict:
    return {
        "scenario": "demo",
        "success": True,
        "reason": "arrived",
        "collisions": 0,
        "min_clearance_m": 0.3,
        "sim_time_s": trace[-1]["t"] if trace else 20.0,
        "path_length_m": 8.5,
        "phases": [
            {"name": "plan", "start_s": 0.2, "end_s": 1.0},
            {"name": "follow", "start_s": 1.0, "end_s": 8.0},
            {"name": "pass", "start_s": 8.0, "end_s": 12.0},
            {"name": "follow", "start_s": 12.0, "end_s": None},
        ],
        "trace": trace,
    }


def drawn_pixels(drawn: MissionFigure, path: Path) -> np.ndarray:
    save(drawn, path)
    return np.asarray(Image.open(path).convert("RGB"), float) / 255.0


def colour_at(img: np.ndarray, ax, x: float, y: float, coords: str = "data") -> np.ndarray:
    """The 3 x 3 pixels of ``img`` around (x, y) in ``ax``'s data (or axes) coordinates."""
    transform = ax.transData if coords == "data" else ax.transAxes
    dx, dy = transform.transform((x, y))
    row, col = int(img.shape[0] - dy), int(dx)
    return img[row - 1 : row + 2, col - 1 : col + 2].reshape(-1, 3)


def near(pixels: np.ndarray, colour: str | tuple, tol: float = 0.12) -> bool:
    """Whether any of ``pixels`` has ``colour`` (within ``tol`` on each channel)."""
    return bool((np.abs(pixels - np.array(to_rgb(colour))) <= tol).all(axis=1).any())


# -- the trace ---------------------------------------------------------------------------


def drive(r: Recorder, t0: float, t1: float, floor: str = "1", clearance: float = 0.4) -> None:
    """Feed ticks of a chair driving along x at 0.5 m/s, a SimStatus every 0.1 s."""
    for k in range(round((t1 - t0) / DT)):
        t = t0 + k * DT
        if k % 5 == 0:
            r.on_sim_status(SimStatus(t, 0, False, clearance, 0.2))
        r.on_truth(0.5 * t, 2.7, 0.0, t, 0.5, floor)


def test_the_recorder_keeps_a_trace_every_quarter_second() -> None:
    r = Recorder("g1")
    r.on_status(NavStatus(0.0, "g1", "running", phase="follow"))
    drive(r, 0.0, 5.0, floor="1", clearance=0.4)
    drive(r, 5.0, 10.0, floor="2", clearance=0.25)
    rep = r.report("demo", 1.0)
    trace = rep["trace"]
    assert rep["trace_every_s"] == TRACE_EVERY_S
    assert set(trace[0]) == {"t", "x", "y", "theta", "floor", "speed", "clearance"}
    steps = np.diff([s["t"] for s in trace[:-1]])
    assert np.allclose(steps.mean(), TRACE_EVERY_S, atol=0.01) and steps.max() <= 0.27
    assert 39 <= len(trace) <= 42
    assert trace[-1]["t"] == pytest.approx(10.0 - DT)  # ends where the chair stood last
    at_3 = next(s for s in trace if s["t"] >= 3.0)
    assert at_3["x"] == pytest.approx(0.5 * at_3["t"], abs=1e-3) and at_3["floor"] == "1"
    assert at_3["speed"] == 0.5 and at_3["clearance"] == 0.4
    at_8 = next(s for s in trace if s["t"] >= 8.0)
    assert at_8["floor"] == "2" and at_8["clearance"] == 0.25


def test_the_trace_has_no_clearance_before_the_simulator_reports_one() -> None:
    r = Recorder("g1")
    r.on_truth(1.0, 2.0, 0.0, 0.0, 0.0, "1")
    r.on_sim_status(SimStatus(0.1, 0, False, 1e6, 1e6))  # nothing seen: the simulator's 1e6
    r.on_truth(1.0, 2.0, 0.0, 0.5, 0.0, "1")
    rep = r.report("x", 1.0)
    assert [s["clearance"] for s in rep["trace"]] == [None, None]
    # a mission that ended before anything came within range (b2011.m06 fails at
    # planning now) has no least clearance, not the simulator's 1e6
    assert rep["min_clearance_m"] is None and rep["min_clearance_away_m"] is None


def test_the_trace_stays_bounded_and_even_on_a_long_mission() -> None:
    r = Recorder("g1")
    for k in range(20_000):  # 1000 s at 20 Hz
        r.on_truth(0.0, 0.0, 0.0, k * 0.05, 0.1, "1")
    rep = r.report("long", 1.0)
    times = np.array([s["t"] for s in rep["trace"]])
    assert len(times) <= MAX_TRACE + 1
    assert rep["trace_every_s"] == 4 * TRACE_EVERY_S  # 1000 s / 1200 samples: 1 s apart
    assert times[0] == 0.0 and times[-1] == pytest.approx(999.95)
    assert np.allclose(np.diff(times[:-1]), rep["trace_every_s"], atol=0.06)


def test_the_trace_ends_with_the_mission() -> None:
    r = Recorder("g1")
    drive(r, 0.0, 2.0)
    r.on_status(NavStatus(2.0, "g1", "succeeded", reason="arrived"))
    drive(r, 2.0, 4.0)  # the shutdown after the mission
    assert r.report("x", 1.0)["trace"][-1]["t"] < 2.0


# -- door crossings and the picture -----------------------------------------------------


def test_a_path_through_the_door_crosses_it_once(two_rooms: Site) -> None:
    trace = straight_trace(2.0, 10.5, 2.7)
    (crossing,) = door_crossings(trace, two_rooms)
    assert crossing.door == "door_ab" and crossing.floor == "1"
    assert crossing.x == pytest.approx(6.2) and crossing.y == pytest.approx(2.7)
    assert crossing.t == pytest.approx(1.0 + 4.2 / 0.5, abs=0.01)
    assert door_crossings(straight_trace(2.0, 5.0, 2.7), two_rooms) == []


def test_the_picture_shows_the_path_over_the_map(two_rooms: Site, tmp_path: Path) -> None:
    drawn = mission_figure(demo_report(straight_trace(2.0, 10.5, 2.7)), two_rooms)
    img = drawn_pixels(drawn, tmp_path / "demo.png")
    floor = drawn.maps["1"]
    assert near(colour_at(img, floor, 4.0, 2.7), PATH_COLOUR)  # on the path
    assert near(colour_at(img, floor, 9.0, 2.7), PATH_COLOUR)
    assert not near(colour_at(img, floor, 4.0, 4.2), PATH_COLOUR)  # 1.5 m beside it
    assert near(colour_at(img, floor, 4.0, 4.2), "white", tol=0.02)  # free floor
    assert near(colour_at(img, floor, 6.2, 1.0), (0.2, 0.2, 0.2), tol=0.05)  # the wall
    assert near(colour_at(img, floor, 8.9, 1.2), (0.2, 0.2, 0.2), tol=0.05)  # the box in B
    assert near(colour_at(img, floor, 8.9, 4.2), "white", tol=0.02)  # the map is not flipped
    assert near(colour_at(img, floor, 6.2, 2.7), DOOR_COLOUR)  # the crossing's marker


def test_a_path_elsewhere_leaves_those_pixels_white(two_rooms: Site, tmp_path: Path) -> None:
    drawn = mission_figure(demo_report(straight_trace(2.0, 5.0, 4.2)), two_rooms)
    img = drawn_pixels(drawn, tmp_path / "other.png")
    floor = drawn.maps["1"]
    assert near(colour_at(img, floor, 4.0, 2.7), "white", tol=0.02)
    assert near(colour_at(img, floor, 4.0, 4.2), PATH_COLOUR)
    assert not near(colour_at(img, floor, 6.2, 2.7), DOOR_COLOUR)  # no door crossed


def test_the_time_plots_show_speed_and_phases(two_rooms: Site, tmp_path: Path) -> None:
    report = demo_report(straight_trace(2.0, 10.5, 2.7))
    drawn = mission_figure(report, two_rooms)
    img = drawn_pixels(drawn, tmp_path / "demo.png")
    assert near(colour_at(img, drawn.speed, 5.0, 0.5), PATH_COLOUR, tol=0.2)  # a thin line
    assert near(colour_at(img, drawn.speed, 5.0, 0.25), "white", tol=0.02)
    names = ["plan", "follow", "pass"]
    assert near(colour_at(img, drawn.phases, 10.0, 2), phase_colour(names, "pass"), tol=0.05)
    assert near(colour_at(img, drawn.phases, 4.0, 1), phase_colour(names, "follow"), tol=0.05)
    assert near(colour_at(img, drawn.phases, 15.0, 1), phase_colour(names, "follow"), tol=0.05)
    assert near(colour_at(img, drawn.phases, 4.0, 2), "white", tol=0.02)  # not passing yet


def test_write_plots_writes_one_png_per_mission(two_rooms: Site, tmp_path: Path) -> None:
    out = tmp_path / "plots"
    paths = write_plots(demo_report(straight_trace(2.0, 10.5, 2.7)), two_rooms, out)
    assert paths == [out / "demo.png"]
    width, height = Image.open(paths[0]).size
    assert width == 1200 and 700 <= height <= 2000
    pixels = np.asarray(Image.open(paths[0]).convert("L"))
    assert (pixels < 250).mean() > 0.05  # drawn on, not blank


def test_a_two_floor_mission_gets_a_panel_per_floor(tmp_path: Path) -> None:
    site = load_site(ROOT / "sites" / "two_floors")
    first = straight_trace(2.0, 20.0, 9.25)
    second = [{**s, "t": s["t"] + 100.0, "floor": "2"} for s in straight_trace(20.0, 5.0, 9.25)]
    drawn = mission_figure(demo_report(first + second), site)
    assert list(drawn.maps) == ["1", "2"]
    img = drawn_pixels(drawn, tmp_path / "two_floors.png")
    assert near(colour_at(img, drawn.maps["1"], 10.0, 9.25), PATH_COLOUR)
    assert near(colour_at(img, drawn.maps["2"], 10.0, 9.25), PATH_COLOUR)


def test_a_report_without_a_trace_still_draws(two_rooms: Site, tmp_path: Path) -> None:
    report = demo_report([])
    del report["trace"]  # a report written before the trace existed
    (path,) = write_plots(report, two_rooms, tmp_path)
    assert path.stat().st_size > 0


# -- the flag ----------------------------------------------------------------------------


@pytest.mark.parametrize(
    "argv",
    [
        ["mission", "scenarios/demo.yaml", "--plots", "out"],
        ["scenarios", "scenarios/demo.yaml", "scenarios/pedestrian.yaml", "--plots", "out"],
    ],
)
def test_both_mission_commands_take_plots(argv: list[str]) -> None:
    parser = argparse.ArgumentParser()
    mission_cli.add_commands(parser.add_subparsers(dest="command"))
    assert parser.parse_args(argv).plots == "out"
    assert parser.parse_args(argv[:-2]).plots is None


def test_phase_colours_cycle() -> None:
    names = [f"p{i}" for i in range(12)]
    assert phase_colour(names, "p0") == phase_colour(names, "p10")
    assert len({phase_colour(names, n) for n in names[:10]}) == 10
