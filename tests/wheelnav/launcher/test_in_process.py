"""The fleet as threads of one process (wheelnav/launcher/in_process.py): real services on
one real Zenoh session, without a router."""

from __future__ import annotations

import io
import threading
import time
from pathlib import Path

import yaml

from shared import config as config_mod
from shared.messages import Pose2D, RouteReply, RouteRequest
from shared.topics import Keys
from shared.transport import Bus, open_local_session
from tests.conftest import ROOT
from wheelnav.launcher.fleet import ServiceSpec
from wheelnav.launcher.in_process import InProcessFleet
from wheelnav.launcher.supervisor import wait_ready
from wheelnav.mission.scenario import load_scenario

PLANNER = ServiceSpec("planner", "services.planner.node", ("sim",), "routes")
CRASHER = ServiceSpec("crasher", "tests.wheelnav.launcher.crashing_service", (), "raises")


def demo_config(tmp_path: Path) -> str:
    path = tmp_path / "fleet.yaml"
    cfg = load_scenario(ROOT / "scenarios" / "demo.yaml").config
    path.write_text(yaml.safe_dump(config_mod.to_dict(cfg), sort_keys=False))
    return str(path)


def test_hosted_services_answer_on_the_shared_session_and_a_crash_is_reported(tmp_path) -> None:
    session = open_local_session()
    bus = Bus(session, "test", owns_session=False)
    stopped: list[tuple[str, str]] = []
    out = io.StringIO()
    fleet = InProcessFleet(
        [PLANNER, CRASHER],
        demo_config(tmp_path),
        bus,
        out,
        on_stopped=lambda name, why: stopped.append((name, why)),
    )
    keys = Keys("chair1")
    fleet.start()
    try:
        assert wait_ready(bus, keys, ["planner"], 120.0) == []
        # a query to a hosted service is answered inside the one session
        start = Pose2D(2.0, 2.7, 0.0, "1")
        reply = bus.call(keys.route, RouteRequest(start, place="room_b"), RouteReply, 30.0)
        assert reply.ok and reply.path is not None and len(reply.path.waypoints) >= 2
        # a service whose main raises is not restarted: the host hears why, at once
        deadline = time.monotonic() + 30.0
        while not stopped and time.monotonic() < deadline:
            time.sleep(0.05)
        assert stopped == [("crasher", stopped[0][1])] and "boom" in stopped[0][1]
        assert fleet.failed() == ["crasher"]
        assert "boom" in fleet.last_error("crasher")
    finally:
        fleet.stop()
        bus.close()
        session.close()
    # stopped when asked, the planner is neither reported nor left running
    assert [name for name, _ in stopped] == ["crasher"]
    assert fleet.exit_codes["planner"] == 0
    assert not [t.name for t in threading.enumerate() if t.name.startswith("service-")]
    # the services' log lines went to the fleet's output with their names
    assert "planner" in out.getvalue() and "ready" in out.getvalue()
