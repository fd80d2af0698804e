"""Kidnapping on the whole fleet (issue 15): the chair moved 2 m and 30 deg while standing.

In a generated building's hall (columns, furniture: no two places look alike) the
localisation finds its pose lost, searches the map, finds it, and the navigator plans
again from there: the mission goes on and arrives. In the bundled two rooms, which mirror
each other, a pose in the other room fits as well as the true one: the localisation must
not guess, and the mission stops at once saying why.
"""

from __future__ import annotations

import pytest
import yaml

from sim.building_gen import generate_building
from tests.conftest import ROOT
from tests.integration.test_fleet import Capture
from wheelnav.mission.run import MissionRun
from wheelnav.mission.scenario import load_scenario

pytestmark = pytest.mark.e2e
HALL_SEED = 5036  # one floor round a 27 x 26 m hall with columns (not a campaign seed)


def run(path) -> tuple[dict, str]:
    out = Capture()
    report = MissionRun(load_scenario(path), out=out, fleet_output=out).run()
    return report, out.text()


def test_a_chair_kidnapped_in_a_hall_is_found_and_the_mission_goes_on(tmp_path) -> None:
    generate_building(HALL_SEED, tmp_path / "b")
    scenario = {
        "name": "kidnapped_in_a_hall",
        "site": "..",
        "seed": 503601,
        "time_limit_s": 120.0,
        "start": {"x": 22.35, "y": 64.0, "theta": -0.3702, "floor": "1"},
        "goal": {"place": "f1_hall1_1"},
        "config": {"sim": {"kidnaps": [{"at_s": 0.0, "dx": 2.0, "dtheta": 0.52}]}},
    }
    path = tmp_path / "b" / "missions" / "kidnapped.yaml"
    path.write_text(yaml.safe_dump(scenario))
    report, out = run(path)
    assert report["success"], (report["reason"], out[-3000:])
    assert report["collisions"] == 0
    kinds = [(e["source"], e["kind"]) for e in report["events"]]
    order = [
        ("sim", "kidnapped"),
        ("localisation", "lost"),
        ("localisation", "relocalised"),
        ("navigator", "pose_jump"),
    ]
    assert [k for k in kinds if k in order][:4] == order, kinds
    moved = next(e for e in report["events"] if e["kind"] == "kidnapped")["detail"]
    assert "while standing" in moved


def test_a_chair_kidnapped_between_mirrored_rooms_is_not_guessed_and_says_why() -> None:
    report, out = run(ROOT / "scenarios" / "kidnapped.yaml")
    assert not report["success"] and report["collisions"] == 0
    assert report["reason"].startswith("localisation lost: no unambiguous pose"), report["reason"]
    assert "ambiguous" in report["reason"]
    assert report["sim_time_s"] < 30.0  # at once, not at the end of the 60 s safety limit
