"""Scenario loading and the report recorder."""

from __future__ import annotations

from pathlib import Path

import pytest

from shared.config import ConfigError
from shared.messages import DoorClearance, NavStatus, SimStatus
from tests.conftest import ROOT
from wheelnav.mission.report import Recorder
from wheelnav.mission.scenario import load_scenario


def test_demo_scenario_loads() -> None:
    s = load_scenario(ROOT / "scenarios" / "demo.yaml", ["controller.lookahead_m=0.7"])
    assert s.place == "room_b" and s.goal is None
    assert Path(s.config.site) == ROOT / "sites" / "two_rooms"
    assert s.config.sim.start.x == 2.0 and s.config.sim.seed == 1
    assert s.config.sim.realtime_factor == 0.0
    assert "mission" in s.config.sim.start_after
    assert s.config.controller.lookahead_m == 0.7


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("site: x\nstart: {x: 0, y: 0}\n", "missing key 'goal'"),
        ("site: x\nstart: {x: 0, y: 0}\ngoal: {place: a}\nspeed: 3\n", "unknown key 'speed'"),
        ("site: x\nstart: {x: 0, y: 0, z: 1}\ngoal: {place: a}\n", "sim.start.z: unknown key"),
        ("site: x\nstart: {x: 0, y: 0}\ngoal: {x: 1}\n", "goal: expected"),
        (
            "site: x\nstart: {x: 0, y: 0}\ngoal: {place: a}\ntime_limit_s: -1\n",
            "time_limit_s: must be > 0",
        ),
    ],
)
def test_bad_scenarios(tmp_path: Path, text: str, message: str) -> None:
    (tmp_path / "s.yaml").write_text(text)
    with pytest.raises(ConfigError, match=message):
        load_scenario(tmp_path / "s.yaml")


def test_recorder_phases_and_report() -> None:
    r = Recorder("g1")
    r.on_status(NavStatus(0.1, "other", "running", phase="plan"))  # not our goal
    r.on_status(NavStatus(0.2, "g1", "running", phase="plan"))
    r.on_status(NavStatus(0.4, "g1", "running", phase="follow"))
    for x in range(4):
        r.on_truth(float(x), 0.0)
    r.on_sim_status(SimStatus(1.0, 0, False, 0.4, 0.25))
    r.on_status(NavStatus(9.0, "g1", "succeeded", reason="arrived"))
    r.on_time(9.0, 60.0)
    rep = r.report("demo", 3.0)
    assert rep["success"] and rep["reason"] == "arrived"
    assert rep["path_length_m"] == 3.0 and rep["min_clearance_m"] == 0.25
    assert [(p["name"], p["start_s"], p["end_s"]) for p in rep["phases"]] == [
        ("plan", 0.2, 0.4),
        ("follow", 0.4, 9.0),
    ]
    for key in (
        "success",
        "reason",
        "collisions",
        "min_clearance_m",
        "sim_time_s",
        "wall_time_s",
        "path_length_m",
        "phases",
    ):
        assert key in rep


def test_recorder_time_limit_and_collisions() -> None:
    r = Recorder("g1")
    r.on_status(NavStatus(0.2, "g1", "running", phase="follow"))
    r.on_sim_status(SimStatus(1.0, 2, True, -0.01, -0.01))
    r.on_time(30.0, 30.0)
    rep = r.report("x", 1.0)
    assert not rep["success"] and rep["state"] == "timeout"
    assert rep["reason"] == "time limit of 30 s reached" and rep["collisions"] == 2


def test_the_report_keeps_the_status_text_where_it_changes_in_more_than_numbers() -> None:
    r = Recorder("g1")
    for t, phase, text in [
        (1.0, "pass", "0.06 of 2.25 m by odometry"),
        (2.0, "pass", "1.06 of 2.25 m by odometry"),  # only numbers changed: not kept
        (3.0, "pass", "holding: LiDAR: something in the doorway ahead"),
        (4.0, "pass", "holding: LiDAR: something in the doorway ahead"),
        (5.0, "follow", "following route-3.1"),
        (6.0, "correct", "Door d1_005 (2/6)"),
        (7.0, "correct", "Door d1_004 (3/6)"),  # another door: its name has digits
        (8.0, "turn", "Door d1_004 (3/6)"),  # the same text in the next phase
    ]:
        r.on_status(NavStatus(t, "g1", "running", action=text, phase=phase))
    assert [(a["t"], a["text"]) for a in r.report("demo", 1.0)["actions"]] == [
        (1.0, "0.06 of 2.25 m by odometry"),
        (3.0, "holding: LiDAR: something in the doorway ahead"),
        (5.0, "following route-3.1"),
        (6.0, "Door d1_005 (2/6)"),
        (7.0, "Door d1_004 (3/6)"),
        (8.0, "Door d1_004 (3/6)"),
    ]


def test_recorder_keeps_that_a_doorway_was_entered_once_it_was() -> None:
    r = Recorder("g1")
    r.on_status(NavStatus(0.2, "g1", "running", phase="follow"))
    entered = DoorClearance("d1", 0.9, 0.12, entered=True)
    r.on_sim_status(SimStatus(1.0, 0, False, 0.3, 0.12, doors=[entered]))
    later = DoorClearance("d1", 0.9, 0.08, entered=False)  # lower, from a stale flag
    r.on_sim_status(SimStatus(2.0, 0, False, 0.3, 0.08, doors=[later]))
    (door,) = r.report("x", 1.0)["door_clearance"]
    assert door["min_clearance_m"] == 0.12 and door["entered"] is True
    assert door["outline_clearance_m"] == 0.08
    r = Recorder("g1")  # the least clearance before the chair entered, then it passed
    r.on_status(NavStatus(0.2, "g1", "running", phase="follow"))
    before = DoorClearance("d1", 0.9, 0.08, entered=False, outline_clearance_m=0.08)
    r.on_sim_status(SimStatus(1.0, 0, False, 0.3, 0.08, doors=[before]))
    passing = DoorClearance("d1", 0.9, 0.12, entered=True, outline_clearance_m=0.08)
    r.on_sim_status(SimStatus(2.0, 0, False, 0.3, 0.08, doors=[passing]))
    (door,) = r.report("x", 1.0)["door_clearance"]
    assert door["min_clearance_m"] == 0.12 and door["entered"] is True
    assert door["outline_clearance_m"] == 0.08
    r = Recorder("g1")  # a door only ever passed: no outline figure
    r.on_sim_status(SimStatus(1.0, 0, False, 0.3, 0.12, doors=[entered]))
    assert r.report("x", 1.0)["door_clearance"][0]["outline_clearance_m"] is None


def test_a_world_site_apart_from_the_map_is_read_relative_to_the_scenario(tmp_path) -> None:
    text = (
        f"site: {ROOT / 'sites' / 'two_rooms'}\nworld_site: WORLD\n"
        "start: {x: 2.0, y: 2.7, theta: 0.0, floor: '1'}\ngoal: {place: room_b}\n"
    )
    (tmp_path / "world").symlink_to(ROOT / "sites" / "two_rooms")
    scenario = tmp_path / "s.yaml"
    scenario.write_text(text.replace("WORLD", "world"))
    sc = load_scenario(scenario)
    assert sc.config.sim.world_site == str((tmp_path / "world").resolve())
    assert load_scenario(ROOT / "scenarios" / "demo.yaml").config.sim.world_site == ""
    scenario.write_text(text.replace("WORLD", "nowhere"))
    with pytest.raises(Exception, match="nowhere"):
        load_scenario(scenario)
