"""End to end: a door the building has no controller for is passed on the LiDAR alone.

Most doors of a real building report nothing (issue 16, "a hardware profile that works";
issue 13 item 5). The demo's site, copied with its one door marked ``controller: false``:
the building publishes no state for it, the navigator sends it no request, and the chair
still verifies it open (from its scans) and passes it. A whole fleet in lockstep over a
real router.
"""

from __future__ import annotations

import shutil

import pytest
import yaml

from shared.messages import DoorRequest, DoorState, NavGoal, NavStatus
from tests.conftest import ROOT
from tests.integration.test_fleet import _fleet, _heard

pytestmark = pytest.mark.e2e
DOOR = "door_ab"


@pytest.fixture
def fleet(router, tmp_path):
    site = tmp_path / "two_rooms"
    shutil.copytree(ROOT / "sites" / "two_rooms", site)
    data = yaml.safe_load((site / "site.yaml").read_text())
    (door,) = [d for d in data["doors"] if d["id"] == DOOR]
    door["controller"] = False
    (site / "site.yaml").write_text(yaml.safe_dump(data, sort_keys=False))
    scenario = yaml.safe_load((ROOT / "scenarios" / "demo.yaml").read_text())
    scenario["site"] = str(site)
    path = tmp_path / "demo_no_controller.yaml"
    path.write_text(yaml.safe_dump(scenario, sort_keys=False))
    yield from _fleet(router, tmp_path, path)


def test_a_door_without_a_controller_is_verified_by_lidar_and_passed(fleet) -> None:
    bus, _endpoint, _sup, keys, scenario, _out = fleet
    heard = _heard(fleet)
    heard.keep("state", keys.key("door_state", door=DOOR), DoorState)
    heard.keep("request", keys.key("door_request", door=DOOR), DoorRequest)
    bus.publish(keys.nav_goal, NavGoal(0.0, "no-controller", None, scenario.place))
    done = heard.mission_end("no-controller")
    assert done.state == "succeeded", done.reason
    with heard.lock:
        states, requests = list(heard.seen["state"]), list(heard.seen["request"])
        steps = {(s.phase, s.action) for s in heard.seen["status"] if isinstance(s, NavStatus)}
    assert not states, states[:3]  # the building knows nothing of this door
    assert not requests, requests[:3]  # and the navigator asks it for nothing
    # the door's steps ran (it was not skipped as a mere gap): the smooth pass (the
    # default procedure) verified it open by LiDAR alone as the chair closed in, in time:
    # a door not seen open would have fallen back to stop-turn-go (correct, turn, verify)
    door_phases = {phase for phase, action in steps if DOOR in action}
    assert door_phases == {"pass"}, sorted(steps)
    # the chair drove through: it ended in room B, beyond the door's line (x 6.2)
    with heard.lock:
        end = heard.seen["truth"][-1].pose
    assert end.x > 6.2 + 1.0, (end.x, end.y)
