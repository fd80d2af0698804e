"""A secured router over real Zenoh sessions on loopback: who gets in, who may publish.

The router is the one ``wheelnav up --security`` opens (mutual TLS, user/password, access
control derived from the topic table). Every refusal is asserted beside a positive
control: an authorised client on the same key, seen by the same subscriber. Waits are
for events, with generous deadlines: a refusal is shown by the allowed messages arriving
while the refused ones, sent before each of them, never do.
"""

from __future__ import annotations

import shutil
import subprocess
import threading
import time
from collections import Counter
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import pytest
import zenoh

from services.rmf_bridge.ros_keys import DOOR_REQUESTS, DOOR_STATES, ros_key
from shared.codec import encode
from shared.config import SecurityConfig, TransportConfig
from shared.messages import (
    DoorMode,
    DoorRequest,
    DoorState,
    Msg,
    NavGoal,
    Pose2D,
    RouteReply,
    RouteRequest,
    Twist,
)
from shared.topics import Keys
from shared.transport import Bus, open_session, zenoh_config
from tests.conftest import PYTHON, ROOT
from wheelnav.launcher.supervisor import open_router
from wheelnav.mission.run import free_port
from wheelnav.security import store

KEYS = Keys("chair1")
RMF_HOST = "building-rmf"  # the Open-RMF building's Zenoh bridge, linked as a host
DEADLINE_S = 60.0  # for what must happen; the machine may be loaded


@dataclass
class Fleet:
    """A secured router and the clients opened on it, by identity."""

    root: Path
    endpoint: str
    router: Bus
    clients: dict[str, Bus] = field(default_factory=dict)

    def transport(self, root: Path | None = None) -> TransportConfig:
        return TransportConfig(
            connect=[self.endpoint], security=SecurityConfig(dir=str(root or self.root))
        )

    def client(self, user: str) -> Bus:
        if user not in self.clients:
            self.clients[user] = Bus(open_session(self.transport(), user), user)
        return self.clients[user]


@pytest.fixture(scope="module")
def fleet(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Fleet]:
    root = tmp_path_factory.mktemp("secured") / "chair1"
    store.init(root, "chair1", [], ["operator"], ["viewer"])
    store.add(root, "probe", "service")  # tests/integration/probe_service.py
    store.add(root, RMF_HOST, "host", ("rmf",))
    endpoint = f"tls/127.0.0.1:{free_port()}"
    access = store.router_access_control(store.load(root), "chair1")
    router = open_router(endpoint, str(root), access)
    fleet = Fleet(root, endpoint, router)
    yield fleet
    for bus in fleet.clients.values():
        bus.close()
    router.close()


def seen(
    listener: Bus, key: str, refused: tuple[Bus, Msg], allowed: tuple[Bus, Msg]
) -> tuple[int, int]:
    """Publish the refused then the allowed message on ``key``, in turns, until
    ``listener`` has seen the allowed one 3 times; (refused seen, allowed seen)."""
    bad, good = encode(refused[1]), encode(allowed[1])
    counts: Counter[bytes] = Counter()
    arrived = threading.Condition()

    def on_sample(_key: str, payload: bytes) -> None:
        with arrived:
            counts[payload] += 1
            arrived.notify_all()

    listener.subscribe_raw(key, on_sample)
    deadline = time.monotonic() + DEADLINE_S
    with arrived:
        while counts[good] < 3 and time.monotonic() < deadline:
            refused[0].publish(key, refused[1])
            allowed[0].publish(key, allowed[1])
            arrived.wait(0.5)
    return counts[bad], counts[good]


def _refused(open_it) -> str:
    try:
        session = open_it()
    except (RuntimeError, zenoh.ZError) as exc:
        return str(exc)
    session.close()
    return ""


def test_only_a_client_with_its_certificate_and_password_gets_in(
    fleet: Fleet, tmp_path: Path
) -> None:
    port = fleet.endpoint.rsplit(":", 1)[1]
    plain = TransportConfig(connect=[f"tcp/127.0.0.1:{port}"])
    assert "cannot open a Zenoh client session" in _refused(lambda: open_session(plain))

    def tls_without_a_certificate() -> zenoh.Session:
        conf = zenoh_config(TransportConfig(connect=[fleet.endpoint]))
        conf.insert_json5(
            "transport/link/tls/root_ca_certificate", f'"{fleet.root / "viewer" / "ca.pem"}"'
        )
        return zenoh.open(conf)

    assert _refused(tls_without_a_certificate)

    wrong = tmp_path / "wrong"
    shutil.copytree(fleet.root / "viewer", wrong / "viewer")
    (wrong / "viewer" / "password").write_text("not-the-password\n")
    reason = _refused(lambda: open_session(fleet.transport(wrong), "viewer"))
    assert "refused for these credentials" in reason

    assert _refused(lambda: open_session(fleet.transport(), "viewer")) == ""


def test_a_viewer_cannot_send_a_goal_or_a_cancel_an_operator_can(fleet: Fleet) -> None:
    viewer, operator = fleet.client("viewer"), fleet.client("operator")
    goal = NavGoal(0.0, "from-viewer", None, "room_b")
    cancel = NavGoal(0.0, "from-viewer", cancel=True)
    for refused in (goal, cancel):
        bad, good = seen(
            fleet.client("navigator"),
            KEYS.nav_goal,
            (viewer, refused),
            (operator, NavGoal(0.0, "from-operator", None, "room_b")),
        )
        assert good >= 3 and bad == 0


def test_a_viewer_cannot_send_a_velocity_the_controller_can(fleet: Fleet) -> None:
    bad, good = seen(
        fleet.client("driver"),
        KEYS.cmd_vel,
        (fleet.client("viewer"), Twist(0.0, 1.0, 0.0)),
        (fleet.client("controller"), Twist(0.0, 0.2, 0.0)),
    )
    assert good >= 3 and bad == 0


def test_the_navigator_cannot_send_a_velocity_the_controller_can(fleet: Fleet) -> None:
    bad, good = seen(
        fleet.client("driver"),
        KEYS.cmd_vel,
        (fleet.client("navigator"), Twist(0.0, 0.5, 0.0)),
        (fleet.client("controller"), Twist(0.0, 0.3, 0.0)),
    )
    assert good >= 3 and bad == 0


def test_the_controllers_password_without_its_certificate_grants_nothing(
    fleet: Fleet, tmp_path: Path
) -> None:
    stolen = tmp_path / "stolen" / "controller"
    shutil.copytree(fleet.root / "navigator", stolen)
    shutil.copy(fleet.root / "controller" / "password", stolen / "password")
    thief = Bus(open_session(fleet.transport(stolen.parent), "controller"), "thief")
    try:
        bad, good = seen(
            fleet.client("driver"),
            KEYS.cmd_vel,
            (thief, Twist(0.0, 0.9, 0.0)),
            (fleet.client("controller"), Twist(0.0, 0.1, 0.0)),
        )
    finally:
        thief.close()
    assert good >= 3 and bad == 0


def test_the_navigator_asks_the_planner_for_a_route_an_operator_cannot(fleet: Fleet) -> None:
    fleet.client("planner").serve(
        KEYS.route, RouteRequest, lambda req: RouteReply(True, error=req.place)
    )
    request = RouteRequest(Pose2D(0.0, 0.0, 0.0), place="room_b")
    deadline = time.monotonic() + DEADLINE_S
    reply = None
    while reply is None and time.monotonic() < deadline:
        try:
            reply = fleet.client("navigator").call(KEYS.route, request, RouteReply, 5.0)
        except TimeoutError:  # the queryable is still on its way to the router
            time.sleep(0.2)
    assert reply is not None and reply.error == "room_b"
    with pytest.raises(TimeoutError):
        fleet.client("operator").call(KEYS.route, request, RouteReply, 3.0)


def test_a_service_holds_its_own_liveliness_token_nobody_else_can(fleet: Fleet) -> None:
    spoofed = KEYS.key("alive", service="localisation")
    fleet.client("viewer").declare_alive(spoofed)
    fleet.client("controller").declare_alive(KEYS.key("alive", service="controller"))
    deadline = time.monotonic() + DEADLINE_S
    alive: list[str] = []
    while KEYS.key("alive", service="controller") not in alive and time.monotonic() < deadline:
        alive = fleet.router.alive(KEYS.key("alive"), 1.0)
    assert KEYS.key("alive", service="controller") in alive
    assert spoofed not in alive
    fleet.client("localisation").declare_alive(spoofed)
    while spoofed not in alive and time.monotonic() < deadline:
        alive = fleet.router.alive(KEYS.key("alive"), 1.0)
    assert spoofed in alive


def test_the_building_bridge_speaks_to_the_open_rmf_side_and_sends_no_velocity(
    fleet: Fleet,
) -> None:
    # the building's zenoh-bridge-ros2dds: a router linked to the chair's as its host identity
    access = store.router_access_control(store.load(fleet.root), "chair1", RMF_HOST)
    endpoint = f"tls/127.0.0.1:{free_port()}"
    building = open_router(endpoint, str(fleet.root), access, [fleet.endpoint], RMF_HOST)
    bridge, viewer = fleet.client("rmf_bridge"), fleet.client("viewer")
    try:
        request = ros_key(DOOR_REQUESTS, namespace="/building1")
        bad, good = seen(
            building,
            request,
            (viewer, DoorRequest(0.0, "viewer", "d1", DoorMode.OPEN)),
            (bridge, DoorRequest(0.0, "chair1", "d1", DoorMode.OPEN)),
        )
        assert good >= 3 and bad == 0
        bad, good = seen(
            bridge,
            ros_key(DOOR_STATES, namespace="/building1"),
            (viewer, DoorState(0.0, "d1", DoorMode.CLOSED)),
            (building, DoorState(0.0, "d1", DoorMode.OPEN)),
        )
        assert good >= 3 and bad == 0
        bad, good = seen(
            fleet.client("driver"),
            KEYS.cmd_vel,
            (bridge, Twist(0.0, 0.7, 0.0)),
            (fleet.client("controller"), Twist(0.0, 0.4, 0.0)),
        )
        assert good >= 3 and bad == 0
    finally:
        building.close()


def _probe(endpoint: str, folder: Path) -> subprocess.Popen:
    return subprocess.Popen(
        [PYTHON, "-m", "tests.integration.probe_service", "--connect", endpoint]
        + ["--set", f"transport.security.dir={folder}"],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )


def test_a_service_joins_as_its_own_name_and_stops_without_credentials(
    fleet: Fleet, tmp_path: Path
) -> None:
    probe = _probe(fleet.endpoint, fleet.root)
    token = KEYS.key("alive", service="probe")
    try:
        deadline = time.monotonic() + DEADLINE_S
        alive: list[str] = []
        while token not in alive and time.monotonic() < deadline and probe.poll() is None:
            alive = fleet.router.alive(KEYS.key("alive"), 1.0)
        assert token in alive
    finally:
        probe.terminate()
        out, _ = probe.communicate(timeout=30)
    assert "Traceback" not in out

    empty = _probe(fleet.endpoint, tmp_path)
    out, _ = empty.communicate(timeout=DEADLINE_S)
    assert empty.returncode == 2, out
    assert "config error: no credentials for 'probe'" in out
