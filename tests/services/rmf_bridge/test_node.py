"""The bridge's node over a real Zenoh session on loopback: a CDR DoorState on the
building's key comes out as wheelnav's DoorState, a wheelnav DoorRequest goes out as a CDR
DoorRequest for the chair, a malformed payload is counted and the bridge goes on, and what
the chair still holds is let go when the bridge stops; every key it declares is one a
secured router lets it use. On rmw_zenoh keys each request carries rmw_zenoh_cpp's
attachment, numbered per publisher. Its config errors name the key."""

from __future__ import annotations

import queue
import subprocess
import sys
import threading
import time

import numpy as np
import pytest
import zenoh

from services.rmf_bridge import cdr
from services.rmf_bridge.attachment import parse
from services.rmf_bridge.node import make_bridge
from services.rmf_bridge.ros_keys import (
    DOOR_REQUESTS,
    DOOR_STATES,
    LIFT_REQUESTS,
    LIFT_STATES,
    TOPICS,
    RosTopic,
    ros_key,
)
from services.rmf_bridge.translate import to_time
from shared import config
from shared.config import ConfigError
from shared.messages import (
    DoorMode,
    DoorRequest,
    DoorState,
    LiftDoor,
    LiftRequest,
    LiftRequestType,
    LiftState,
)
from shared.topics import TOPICS as WHEELNAV_TOPICS
from shared.topics import Keys
from tests.conftest import ROOT, stop_node
from wheelnav.security.acl import SERVICE, Identity, grants

WAIT_S = 60.0  # for any event: generous, the machine may be loaded
SITE = "sites/two_floors"  # doors d1_lab_1 (powered), ...; lifts lift_a, lift_b
NAMESPACE = "building1"  # as zenoh-bridge-ros2dds's namespace /building1 routes the topics


def rmf_door_state(name: str, mode: int) -> bytes:
    msg = cdr.message(
        cdr.DOOR_STATE,
        door_time=to_time(5.0),
        door_name=name,
        current_mode=cdr.message(cdr.DOOR_MODE, value=mode),
    )
    return cdr.encode(msg, cdr.DOOR_STATE)


def rmf_lift_state(name: str, floor: str, session: str) -> bytes:
    msg = cdr.message(
        cdr.LIFT_STATE,
        lift_time=to_time(5.0),
        lift_name=name,
        available_floors=["L1", "L2"],
        current_floor=floor,
        destination_floor=floor,
        door_state=LiftDoor.OPEN,
        motion_state=0,
        available_modes=np.array([1, 2], dtype=np.uint8),
        current_mode=2,
        session_id=session,
    )
    return cdr.encode(msg, cdr.LIFT_STATE)


def building_keys(key_format: str) -> dict[RosTopic, str]:
    """Where the building puts its states and hears requests, for ``key_format``: as
    zenoh-bridge-ros2dds with namespace /building1 routes them, or as ROS 2 nodes on
    rmw_zenoh in that namespace and domain 3 publish them (with Jazzy's type hash)."""
    return {
        t: ros_key(t, key_format, f"/{NAMESPACE}", 3).replace("*", cdr.type_hash(t.typename))
        for t in TOPICS
    }


def declared(log: str) -> dict[str, list[str]]:
    """The keys the node said it declares (``publishes KEY``, ``subscribes KEY``: its
    Service.declare lines), by what it does with them."""
    out: dict[str, list[str]] = {"publishes": [], "subscribes": []}
    for line in log.splitlines():
        what, _, key = line.partition(": ")[2].partition(" ")
        if what in out:
            out[what].append(key)
    return out


def secured_allows(action: str, key: str) -> bool:
    """Whether a secured router's rules let the ``rmf_bridge`` identity ``action`` ``key``."""
    rules = grants(WHEELNAV_TOPICS, [Identity("rmf_bridge", SERVICE)], "chair1")["rmf_bridge"]
    return any(zenoh.KeyExpr(k).includes(zenoh.KeyExpr(key)) for k in rules[action])


def run_bridge(endpoint: str, *settings: str) -> subprocess.Popen:
    """The bridge's node for chair1 on the two-floor site, connected to ``endpoint``."""
    args = ["--connect", endpoint, "--robot", "chair1", "--set", "clock=wall"]
    args += ["--set", f"site={SITE}", "--set", f"rmf_bridge.namespace=/{NAMESPACE}"]
    for setting in settings:
        args += ["--set", setting]
    return subprocess.Popen(
        [sys.executable, "-m", "services.rmf_bridge.node", *args],
        cwd=ROOT,
        stderr=subprocess.PIPE,
        text=True,
    )


def stop(proc: subprocess.Popen) -> str:
    """Stop the node as the launcher does; its log."""
    err = stop_node(proc, WAIT_S)
    assert proc.returncode == 0, err
    return err


@pytest.mark.parametrize("key_format", ["ros2dds", "rmw_zenoh"])
def test_the_node_bridges_both_ways_and_survives_bad_input(router, key_format: str) -> None:
    bus, endpoint = router
    building = building_keys(key_format)
    keys = Keys("chair1")
    doors: queue.Queue[DoorState] = queue.Queue()
    lifts: queue.Queue[LiftState] = queue.Queue()
    to_building: queue.Queue[tuple[str, bytes]] = queue.Queue()
    alive = threading.Event()
    bus.subscribe(keys.key("door_state"), DoorState, doors.put)
    bus.subscribe(keys.key("lift_state"), LiftState, lifts.put)
    for topic in (DOOR_REQUESTS, LIFT_REQUESTS):
        bus.subscribe_raw(building[topic], lambda k, p: to_building.put((k, p)))
    bus.watch_alive(keys.key("alive", service="rmf_bridge"), lambda _k, up: up and alive.set())
    proc = run_bridge(
        endpoint,
        "rmf_bridge.door_names={d1_lab_1: Door_L1_lab}",
        "rmf_bridge.floor_names={'1': L1, '2': L2}",
        f"rmf_bridge.key_format={key_format}",
        "rmf_bridge.domain_id=3",
    )
    try:
        assert alive.wait(WAIT_S), "the bridge never announced itself"
        # the building's states in: junk and an unknown door first, then a good one
        bus.session.put(building[DOOR_STATES], b"\x00\x01\x00\x00junk")
        bus.session.put(building[DOOR_STATES], rmf_door_state("Door_L9_99", DoorMode.OPEN))
        bus.session.put(building[DOOR_STATES], rmf_door_state("Door_L1_lab", DoorMode.OPEN))
        state = doors.get(timeout=WAIT_S)
        assert (state.door_name, state.current_mode) == ("d1_lab_1", DoorMode.OPEN)
        bus.session.put(building[LIFT_STATES], rmf_lift_state("lift_a", "L2", "chair1-g1"))
        lift = lifts.get(timeout=WAIT_S)
        assert (lift.lift_name, lift.current_floor, lift.session_id) == ("lift_a", "2", "chair1-g1")

        # the chair's requests out, as the navigator sends them
        door_key = keys.key("door_request", door="d1_lab_1")
        bus.publish(door_key, DoorRequest(time.time(), "chair1", "d1_lab_1", DoorMode.OPEN))
        key, payload = to_building.get(timeout=WAIT_S)
        req = cdr.decode(payload, cdr.DOOR_REQUEST)
        assert key == building[DOOR_REQUESTS]
        assert (req.door_name, req.requester_id, req.requested_mode.value) == (
            "Door_L1_lab",
            "chair1",
            DoorMode.OPEN,
        )
        call = LiftRequest(
            time.time(), "lift_a", "chair1-g1", LiftRequestType.AGV_MODE, "2", LiftDoor.OPEN
        )
        bus.publish(keys.key("lift_request", lift="lift_a"), call)
        key, payload = to_building.get(timeout=WAIT_S)
        req = cdr.decode(payload, cdr.LIFT_REQUEST)
        assert key == building[LIFT_REQUESTS]
        assert (req.lift_name, req.session_id, req.destination_floor) == (
            "lift_a",
            "chair1-g1",
            "L2",
        )
    finally:
        err = stop(proc)
    # stopping, it let go of what the chair held: the door, then the lift session
    released = [to_building.get(timeout=WAIT_S) for _ in range(2)]
    door = cdr.decode(released[0][1], cdr.DOOR_REQUEST)
    assert (door.door_name, door.requested_mode.value) == ("Door_L1_lab", DoorMode.CLOSED)
    lift_end = cdr.decode(released[1][1], cdr.LIFT_REQUEST)
    assert (lift_end.session_id, lift_end.request_type) == ("chair1-g1", 0)
    assert f"dropped a message on {building[DOOR_STATES]} (1 malformed so far)" in err
    assert "(1 unknown so far): door 'Door_L9_99' of the building" in err
    assert "2 states in, 2 requests out, 0 of other chairs, 0 leases ended" in err
    assert "dropped: 1 malformed, 0 bad_field, 1 unknown" in err
    keys = declared(err)
    assert len(keys["publishes"]) == len(keys["subscribes"]) == 4, err
    assert building[DOOR_REQUESTS] in keys["publishes"]
    assert [k for k in keys["publishes"] if not secured_allows("publish", k)] == []
    assert [k for k in keys["subscribes"] if not secured_allows("read", k)] == []


@pytest.mark.parametrize(
    ("key_format", "layout"),
    [("rmw_zenoh", "positional"), ("rmw_zenoh", "keyed"), ("ros2dds", "positional")],
)
def test_requests_carry_rmw_zenohs_attachment_numbered_per_publisher(
    router, key_format: str, layout: str
) -> None:
    """On rmw_zenoh keys each request carries the attachment of the configured layout:
    sequence numbers 1, 2, ... per publisher, one GID per publisher (the one the log
    names), the wall clock; on zenoh-bridge-ros2dds keys, none."""
    bus, endpoint = router
    building = building_keys(key_format)
    keys = Keys("chair1")
    samples: queue.Queue[tuple[str, bytes | None]] = queue.Queue()
    alive = threading.Event()

    def on_sample(sample: zenoh.Sample) -> None:
        attachment = sample.attachment
        samples.put((str(sample.key_expr), None if attachment is None else attachment.to_bytes()))

    subscribers = [
        bus.session.declare_subscriber(building[t], on_sample)
        for t in (DOOR_REQUESTS, LIFT_REQUESTS)
    ]
    bus.watch_alive(keys.key("alive", service="rmf_bridge"), lambda _k, up: up and alive.set())
    proc = run_bridge(
        endpoint,
        f"rmf_bridge.key_format={key_format}",
        "rmf_bridge.domain_id=3",
        f"rmf_bridge.rmw_zenoh_attachment={layout}",
    )
    got: list[tuple[str, bytes | None]] = []
    try:
        assert alive.wait(WAIT_S), "the bridge never announced itself"
        door_key = keys.key("door_request", door="d1_lab_1")
        started = time.time_ns()
        for _ in range(2):  # an open request and its renewal
            bus.publish(door_key, DoorRequest(time.time(), "chair1", "d1_lab_1", DoorMode.OPEN))
            got.append(samples.get(timeout=WAIT_S))
        call = LiftRequest(
            time.time(), "lift_a", "chair1-g1", LiftRequestType.AGV_MODE, "2", LiftDoor.OPEN
        )
        bus.publish(keys.key("lift_request", lift="lift_a"), call)
        got.append(samples.get(timeout=WAIT_S))
    finally:
        err = stop(proc)
    got += [samples.get(timeout=WAIT_S) for _ in range(2)]  # let go of: the door, the lift
    # two subscribers, two of zenoh's callback threads: the two releases may come in either
    # order (a loaded CI run had the lift's first); each publisher's own order is kept
    got[3:] = sorted(got[3:], key=lambda sample: sample[0])
    stopped = time.time_ns()
    for subscriber in subscribers:
        subscriber.undeclare()
    door, lift = building[DOOR_REQUESTS], building[LIFT_REQUESTS]
    assert [key for key, _ in got] == [door, door, lift, door, lift]
    if key_format == "ros2dds":
        assert [a for _, a in got] == [None] * 5
        assert "attachment: none" in err
        return
    assert None not in [a for _, a in got], "a request without its attachment"
    read = [(key, parse(a, layout)) for key, a in got]
    assert [(key, a.sequence_number) for key, a in read] == [
        (door, 1),
        (door, 2),
        (lift, 1),
        (door, 3),
        (lift, 2),
    ]
    door_gids = {a.gid for key, a in read if key == door}
    lift_gids = {a.gid for key, a in read if key == lift}
    assert len(door_gids) == len(lift_gids) == 1 and door_gids != lift_gids
    (door_gid,), (lift_gid,) = door_gids, lift_gids
    assert f"attachment: {layout}, adapter_door_requests GID {door_gid.hex()}" in err
    assert f"adapter_lift_requests GID {lift_gid.hex()}" in err
    stamps = [a.source_timestamp for _, a in read]
    assert started <= stamps[0] and stamps[-1] <= stopped and stamps == sorted(stamps)


@pytest.mark.parametrize(
    ("override", "message"),
    [
        ("clock=sim", "clock: the building bridge runs on wall time, got 'sim'"),
        ("rmf_bridge.namespace=a b", "rmf_bridge.namespace: must be a ROS namespace"),
        ("rmf_bridge.domain_id=300", "rmf_bridge.domain_id: must be a ROS domain id"),
        ("rmf_bridge.key_format=dds", "rmf_bridge.key_format: must be one of"),
        ("rmf_bridge.lift_names={lift_a: X, lift_b: X}", "'lift_a' and 'lift_b' both map to 'X'"),
        ("rmf_bridge.door_names={d1_lab_1: d2_lab_2}", "doors 'd1_lab_1' and 'd2_lab_2' both"),
    ],
)
def test_config_errors_name_the_key(override: str, message: str) -> None:
    overrides = [f"site={SITE}", "clock=wall", override]
    with pytest.raises(ConfigError, match=message):
        make_bridge(config.load(None, overrides))


def test_the_bridge_takes_the_sites_doors_with_a_controller_and_its_lifts() -> None:
    bridge = make_bridge(config.load(None, [f"site={SITE}", "clock=wall"]))
    assert len(bridge.doors) == 12 and len(bridge.lifts) == 2
    assert bridge.door_lease_s == bridge.lift_lease_s == 30.0  # the building's leases
