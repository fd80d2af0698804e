"""Campaign rows: judged against the generator's expectation, stored, summed up."""

from __future__ import annotations

import argparse
import io
from pathlib import Path

import pytest
import yaml

from shared.config import ConfigError, FleetConfig
from wheelnav.campaign.results import ResultStore, clearance_note, door_requirement_m, judge
from wheelnav.campaign.runner import CampaignSpec, add_commands, generate, reusable, run
from wheelnav.campaign.summary import (
    figures,
    format_failures,
    format_figures,
    format_geometry,
    format_table,
    format_tight,
)
from wheelnav.mission.scenario import Scenario


def scenario(expect: str = "success", reason: str = "") -> Scenario:
    return Scenario(
        "b1.m0",
        FleetConfig(),
        None,
        "room",
        100.0,
        Path("b1/m0.yaml"),
        expect,
        reason,
        "same_floor",
    )


def report(success: bool, reason: str = "arrived", **extra) -> dict:
    base = {
        "success": success,
        "state": "succeeded" if success else "failed",
        "reason": reason,
        "collisions": 0,
        "sim_time_s": 40.0,
        "wall_time_s": 8.0,
        "planned_length_m": 10.0,
        "min_clearance_away_m": 0.12,
        "door_clearance": [{"door": "d1", "width_m": 0.9, "min_clearance_m": 0.10}],
    }
    return {**base, **extra}


def test_a_success_as_expected_with_its_time_ratio_and_clearances() -> None:
    row = judge(scenario(), report(True))
    assert row["as_expected"] and row["clearance_ok"] and row["time_ratio"] == 2.0
    assert row["door_clearance"][0]["required_m"] == round(door_requirement_m(0.9, 0.65), 4)
    assert row["replay"] == "wheelnav mission b1/m0.yaml"


def test_an_expected_failure_needs_its_reason() -> None:
    want = scenario("failure", "door d1 did not open")
    assert judge(want, report(False, "door d1 did not open within 20 s; no other route"))[
        "as_expected"
    ]
    assert not judge(want, report(False, "safety stop (obstacle) for more than 60 s"))[
        "as_expected"
    ]
    assert not judge(want, report(True))["as_expected"]


def test_collisions_and_tight_doors_are_counted() -> None:
    row = judge(
        scenario(),
        report(
            True,
            collisions=1,
            door_clearance=[{"door": "d1", "width_m": 0.9, "min_clearance_m": 0.05}],
        ),
    )
    assert not row["as_expected"] and not row["clearance_ok"] and row["tight_doors"] == ["d1"]
    f = figures([row], 2)
    assert f["collisions"] == 1 and f["clearance_violations"] == 1 and f["missions_run"] == 1
    assert "replay: wheelnav mission b1/m0.yaml" in format_failures([row])
    assert "b1.m0" in format_table([row]) and "as expected 0" in format_figures(f)


def test_the_progress_line_says_the_clearance_and_which_limit_a_mission_missed() -> None:
    assert clearance_note(judge(scenario(), report(True))) == "clearance 0.120 m"
    near = judge(
        scenario(),
        report(
            True,
            min_clearance_away_m=0.035,
            door_clearance=[{"door": "d2_009", "width_m": 0.9, "min_clearance_m": 0.05}],
        ),
    )
    assert clearance_note(near) == (
        "clearance 0.035 m, BELOW A LIMIT: under 0.05 m away from doors; tight in d2_009"
    )
    assert clearance_note(judge(scenario(), report(False, min_clearance_away_m=None))) == (
        "clearance -"
    )


def test_rows_survive_a_stop(tmp_path: Path) -> None:
    store = ResultStore(tmp_path)
    assert store.get("b1.m0") is None
    store.put(judge(scenario(), report(True)))
    assert store.get("b1.m0")["as_expected"]
    (tmp_path / "b1.m1.json").write_text("{half")  # a damaged row runs again
    assert store.get("b1.m1") is None


def test_an_open_hinged_leaf_takes_from_the_clear_width_and_tight_spots_say_where() -> None:
    # a 0.90 m hinged door with its leaf open has 0.875 m of clear width: needs 0.0825 m
    door = {
        "door": "d1",
        "width_m": 0.9,
        "free_width_m": 0.875,
        "min_clearance_m": 0.09,
        "nearest": "door d1",
        "at": [2.0, 3.0, 1.5708],
    }
    row = judge(
        scenario(),
        report(
            True,
            door_clearance=[door],
            min_clearance_away_m=0.03,
            min_clearance_away_nearest="wall",
            min_clearance_away_at=[5.0, 1.25, 0.0],
        ),
    )
    assert row["door_clearance"][0]["required_m"] == round(door_requirement_m(0.875, 0.65), 4)
    assert row["tight_doors"] == [] and not row["clearance_ok"]  # 3 cm from a wall
    text = format_tight([row])
    assert "0.030 m away from doors, to wall with the chair at (5.00, 1.25, 0 deg)" in text
    assert format_tight([judge(scenario(), report(True))]) == "every clearance within its limit"


def test_a_doorway_only_the_outline_came_near_is_judged_as_away_from_doors() -> None:
    # turning beside a 1.2 m door it does not pass, the chair's nose 0.10 m from its leaf:
    # inside that opening 0.235 m would be needed, away from doors 0.05 m is
    near = {"door": "d9", "width_m": 1.2, "min_clearance_m": 0.10, "entered": False}
    row = judge(scenario(), report(True, door_clearance=[near]))
    assert row["door_clearance"][0]["required_m"] == 0.05 and row["clearance_ok"]
    row = judge(scenario(), report(True, door_clearance=[{**near, "min_clearance_m": 0.04}]))
    assert row["tight_doors"] == ["d9"] and not row["clearance_ok"]
    passed = judge(scenario(), report(True, door_clearance=[{**near, "entered": True}]))
    assert passed["tight_doors"] == ["d9"]  # passing it, its centring counts


def test_a_doorway_passed_is_judged_on_its_centring_and_on_its_outline_time() -> None:
    # camp23 b2.m08: 0.118 m to a jamb of a 1.2 m door while turning before it (outline
    # only); passing it later, 0.26 m: within both limits
    door = {"door": "d3", "width_m": 1.2, "min_clearance_m": 0.26, "entered": True}
    row = judge(scenario(), report(True, door_clearance=[{**door, "outline_clearance_m": 0.118}]))
    assert row["door_clearance"][0]["outline_required_m"] == 0.05 and row["clearance_ok"]
    row = judge(scenario(), report(True, door_clearance=[{**door, "outline_clearance_m": 0.03}]))
    assert row["tight_doors"] == ["d3"] and not row["clearance_ok"]
    assert "0.030 m with only the outline in d3 (needs 0.050)" in format_tight([row])
    # a 0.80 m door: a front already in it is held to the door's own 0.045 m, not 0.05
    narrow = {**door, "width_m": 0.8, "min_clearance_m": 0.06, "outline_clearance_m": 0.047}
    row = judge(scenario(), report(True, door_clearance=[narrow]))
    assert row["door_clearance"][0]["outline_required_m"] == 0.045 and row["clearance_ok"]


def test_the_geometry_says_what_differed_between_world_and_map() -> None:
    plain = {"floors": 1, "door_widths_m": [0.9], "lift_headings_deg": []}
    world = {
        "doors_moved_m": [0.05, 0.2, 0.2],
        "furniture_added_m2": [0.5, 1.0],
        "furniture_removed_m2": [0.25],
        "walls_moved_m": [0.15],
        "walls_moved_length_m": [3.5],
        "people_radius_m": [0.25, 0.25],
    }
    text = format_geometry([plain, {**plain, "world": world}])
    assert "world differs from the map (1 of 2 buildings)" in text
    assert "doors moved along their wall (3)" in text
    assert "0.20 m    2 ##" in text and "0.05 m    1 #" in text
    assert "furniture the map lacks: 2 (1.5 m2); mapped, not there: 1 (0.2 m2)" in text
    assert "walls moved: 1 (3.5 m of wall; by 0.15 m: 1)" in text
    assert "people standing the map does not show: 2" in text
    assert "world" not in format_geometry([plain])


def test_world_differs_draws_buildings_of_their_own_whose_missions_name_the_world(
    tmp_path: Path,
) -> None:
    parser = argparse.ArgumentParser()
    add_commands(parser.add_subparsers())
    assert parser.parse_args(["campaign", "--world-differs"]).world_differs
    assert not parser.parse_args(["campaign"]).world_differs
    spec = CampaignSpec(tmp_path, buildings=1, seed=5, missions=2, world_differs=True)
    (building,) = generate(spec, io.StringIO())
    assert building["folder"] == tmp_path / "buildings" / "b5w"
    assert (building["folder"] / "world" / "site.yaml").is_file()
    assert "world" in building["built"].geometry
    for path in building["built"].scenarios:
        assert yaml.safe_load(path.read_text())["world_site"] == "../world"
    assert "standing" in building["built"].world.summary()


def test_the_localisation_at_doors_and_missions_lost_to_it_are_summed_up() -> None:
    """Issue 15's campaign figures: 0 missions lost to the localisation, and its error at
    every door checkpoint on the ground truth, as a distribution."""
    crossed = [
        {"kind": "door", "id": "d1", "loc_error_m": 0.004},
        {"kind": "door", "id": "d2", "loc_error_m": 0.061},
        {"kind": "elevator", "id": "lift_a"},
    ]
    lost_and_found = [
        {"source": "localisation", "kind": "lost"},
        {"source": "localisation", "kind": "relocalised"},
    ]
    gave_up = "localisation lost: no unambiguous pose after 5 searches of the floor"
    lost = [{"source": "localisation", "kind": "lost"}]
    rows = [
        judge(scenario(), report(True, checkpoints=crossed, events=lost_and_found)),
        judge(scenario(), report(False, gave_up, events=lost)),
        judge(scenario(), report(True)),  # a row from before these figures
    ]
    assert rows[0]["door_loc_errors_m"] == [0.004, 0.061] and rows[0]["relocalised"] == 1
    assert not rows[0]["lost_to_localisation"] and rows[1]["lost_to_localisation"]
    for r in rows[2:]:  # stored before: none of the new keys
        for key in ("door_loc_errors_m", "times_lost", "relocalised", "lost_to_localisation"):
            r.pop(key)
    f = figures(rows, 3)
    assert f["lost_to_localisation"] == 1 and f["missions_ever_lost"] == 2
    d = f["door_loc_error"]
    assert d["doors"] == 2 and d["max_m"] == 0.061 and d["over_5_cm"] == 1
    text = format_figures(f)
    assert "missions lost to it 1" in text and "over 5 cm 1" in text
    assert figures([rows[2]], 1)["door_loc_error"] is None


def test_where_the_time_goes_is_summed_by_phase_over_the_successes() -> None:
    door = [
        {"name": "follow", "start_s": 0.0, "end_s": 20.0},
        {"name": "correct", "start_s": 20.0, "end_s": 30.0},
        {"name": "pass", "start_s": 30.0, "end_s": 40.0},
        {"name": "follow", "start_s": 40.0, "end_s": 60.0},
        {"name": "verify", "start_s": 60.0, "end_s": None},  # still running at the end
    ]
    rows = [
        judge(scenario(), report(True, phases=door)),
        judge(
            scenario(),
            report(False, "stuck", phases=[{"name": "pass", "start_s": 0.0, "end_s": 90.0}]),
        ),
        judge(scenario(), report(True)),  # no phases
    ]
    assert rows[0]["phase_s"] == {"correct": 10.0, "follow": 40.0, "pass": 10.0}
    rows[2].pop("phase_s")  # a row stored before phase times
    f = figures(rows, 3)
    # the failure's 90 s of pass is not a success's time
    assert f["time_shares"] == {"follow": 0.6667, "correct": 0.1667, "pass": 0.1667}
    assert "by phase: follow 67 %, correct 17 %, pass 17 %" in format_figures(f)
    assert "no phase times" in format_figures(figures([rows[2]], 1))


def test_the_time_ratio_is_taken_against_the_first_route() -> None:
    # a re-plan from near the goal leaves a short last route: not the mission's ideal
    row = judge(scenario(), report(True, planned_length_m=1.0, first_planned_length_m=10.0))
    assert row["time_ratio"] == 2.0


def test_a_campaign_runs_with_config_overrides_and_keeps_their_rows_apart(tmp_path: Path) -> None:
    """``wheelnav campaign --set navigator.door_procedure=smooth``: every mission with the
    override; a row stored without it (or with another) is run again, not reused; a key
    that does not exist is refused before any building is drawn."""
    parser = argparse.ArgumentParser()
    add_commands(parser.add_subparsers())
    args = parser.parse_args(["campaign", "--set", "navigator.door_procedure=smooth"])
    assert args.overrides == ["navigator.door_procedure=smooth"]
    smooth = CampaignSpec(tmp_path, overrides=("navigator.door_procedure=smooth",))
    plain = CampaignSpec(tmp_path)
    row = {"id": "b0.m00", "outcome": "success"}  # stored before overrides were recorded
    assert reusable(row, plain) and not reusable(row, smooth)
    assert reusable(dict(row, overrides=["navigator.door_procedure=smooth"]), smooth)
    assert not reusable(None, plain)
    bad = CampaignSpec(tmp_path, overrides=("navigator.door_procedur=smooth",))
    with pytest.raises(ConfigError, match="door_procedur"):
        run(bad, err=io.StringIO(), out=io.StringIO())
    assert not (tmp_path / "buildings").exists()
