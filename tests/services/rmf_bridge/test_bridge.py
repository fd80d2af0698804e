"""The bridge's core: CDR states in as wheelnav messages, one chair's requests out as CDR,
refusals counted, and the leases Open-RMF's supervisors do not keep kept by the bridge."""

from __future__ import annotations

import numpy as np
import pytest

from services.rmf_bridge import cdr
from services.rmf_bridge.bridge import RmfBridge
from services.rmf_bridge.errors import KINDS, BadField, MalformedCdr, UnknownName
from services.rmf_bridge.ros_keys import DOOR_REQUESTS, LIFT_REQUESTS
from services.rmf_bridge.translate import from_time, to_time
from shared.messages import (
    DoorMode,
    DoorRequest,
    LiftDoor,
    LiftRequest,
    LiftRequestType,
)

LEASE = 30.0


@pytest.fixture
def bridge() -> RmfBridge:
    """Chair ``chair1`` in a site with doors d1 (the building's Door_L1_01) and d2, a lift
    lift_a (LIFT_A) serving floors 1 and 2 (L1, L2)."""
    return RmfBridge(
        "chair1",
        doors=["d1", "d2"],
        lifts=["lift_a"],
        floors=["1", "2"],
        door_names={"d1": "Door_L1_01"},
        lift_names={"lift_a": "LIFT_A"},
        floor_names={"1": "L1", "2": "L2"},
        door_lease_s=LEASE,
        lift_lease_s=LEASE,
    )


def door_state(name: str, mode: int) -> bytes:
    mode_msg = cdr.message(cdr.DOOR_MODE, value=mode)
    msg = cdr.message(cdr.DOOR_STATE, door_time=to_time(3.0), door_name=name, current_mode=mode_msg)
    return cdr.encode(msg, cdr.DOOR_STATE)


def lift_state(name: str, floor: str, session: str) -> bytes:
    msg = cdr.message(
        cdr.LIFT_STATE, lift_time=to_time(3.0), lift_name=name, available_floors=["L1", "L2"],
        current_floor=floor, destination_floor=floor, door_state=LiftDoor.OPEN, motion_state=0,
        available_modes=np.zeros(0, dtype=np.uint8), current_mode=2, session_id=session,
    )  # fmt: skip
    return cdr.encode(msg, cdr.LIFT_STATE)


def sent_door(out) -> tuple:
    msg = cdr.decode(out.payload, cdr.DOOR_REQUEST)
    return msg.door_name, msg.requester_id, msg.requested_mode.value, from_time(msg.request_time)


def sent_lift(out) -> tuple:
    msg = cdr.decode(out.payload, cdr.LIFT_REQUEST)
    return msg.lift_name, msg.session_id, msg.request_type, msg.destination_floor


def test_door_and_lift_states_come_in_under_the_sites_names(bridge: RmfBridge) -> None:
    state = bridge.door_state(door_state("Door_L1_01", DoorMode.OPEN), now=100.0)
    assert (state.door_name, state.current_mode, state.stamp) == ("d1", DoorMode.OPEN, 100.0)
    lift = bridge.lift_state(lift_state("LIFT_A", "L2", "chair1-g1"), now=101.0)
    assert (lift.lift_name, lift.current_floor, lift.available_floors) == (
        "lift_a",
        "2",
        ["1", "2"],
    )
    assert lift.session_id == "chair1-g1"
    assert bridge.counts["states_in"] == 2


def test_bad_states_are_refused_counted_and_the_bridge_goes_on(bridge: RmfBridge) -> None:
    with pytest.raises(MalformedCdr):
        bridge.door_state(b"\x00\x01\x00\x00garbage", now=1.0)
    with pytest.raises(UnknownName, match="door 'Door_L9_09' of the building"):
        bridge.door_state(door_state("Door_L9_09", DoorMode.OPEN), now=1.0)
    with pytest.raises(BadField, match="current_mode.value: 5"):
        bridge.door_state(door_state("d2", 5), now=1.0)
    with pytest.raises(MalformedCdr, match="not a CDR LiftState"):
        bridge.lift_state(door_state("d2", 0), now=1.0)  # a door's state on the lift topic
    assert bridge.door_state(door_state("d2", DoorMode.CLOSED), now=2.0).door_name == "d2"
    assert {k: bridge.counts[k] for k in KINDS} == {"malformed": 2, "bad_field": 1, "unknown": 1}
    assert bridge.counts["states_in"] == 1


def test_door_requests_go_out_for_this_chair_only(bridge: RmfBridge) -> None:
    out = bridge.door_request(DoorRequest(10.0, "chair1", "d1", DoorMode.OPEN), now=10.0)
    assert out.topic == DOOR_REQUESTS and out.name == "d1" and not out.why
    assert sent_door(out) == ("Door_L1_01", "chair1", DoorMode.OPEN, 10.0)
    assert bridge.door_request(DoorRequest(10.0, "chair2", "d1", DoorMode.OPEN), 10.0) is None
    with pytest.raises(UnknownName, match="door 'd7'"):
        bridge.door_request(DoorRequest(10.0, "chair1", "d7", DoorMode.OPEN), now=10.0)
    assert (bridge.counts["requests_out"], bridge.counts["foreign"]) == (1, 1)
    assert bridge.held() == (["d1"], [])


def test_a_door_held_open_and_not_renewed_is_closed_when_its_lease_runs_out(
    bridge: RmfBridge,
) -> None:
    bridge.door_request(DoorRequest(100.0, "chair1", "d1", DoorMode.OPEN), now=0.0)
    bridge.door_request(DoorRequest(110.0, "chair1", "d1", DoorMode.OPEN), now=10.0)  # renewed
    assert bridge.expire(now=39.9) == []
    (out,) = bridge.expire(now=40.0)
    assert out.why == "door d1: CLOSED, no request for 30 s (its lease)"
    assert bridge.held() == ([], [])
    # stamped no earlier than the OPEN it ends (the supervisor ignores an older CLOSED)
    assert sent_door(out) == ("Door_L1_01", "chair1", DoorMode.CLOSED, 110.0)
    assert bridge.expire(now=100.0) == [] and bridge.counts["expired"] == 1


def test_a_closed_door_is_no_longer_held_and_is_stamped_after_its_open(
    bridge: RmfBridge,
) -> None:
    bridge.door_request(DoorRequest(100.0, "chair1", "d2", DoorMode.OPEN), now=0.0)
    out = bridge.door_request(DoorRequest(99.5, "chair1", "d2", DoorMode.CLOSED), now=5.0)
    assert sent_door(out) == ("d2", "chair1", DoorMode.CLOSED, 100.0)
    assert bridge.held() == ([], []) and bridge.expire(now=1000.0) == []


def test_a_lift_session_is_forwarded_ended_and_let_go_on_its_lease(bridge: RmfBridge) -> None:
    call = LiftRequest(1.0, "lift_a", "chair1-g1", LiftRequestType.AGV_MODE, "1", LiftDoor.OPEN)
    out = bridge.lift_request(call, now=0.0)
    assert out.topic == LIFT_REQUESTS and sent_lift(out) == ("LIFT_A", "chair1-g1", 1, "L1")
    other = LiftRequest(1.0, "lift_a", "chair2-g4", LiftRequestType.AGV_MODE, "2", LiftDoor.OPEN)
    assert bridge.lift_request(other, now=0.0) is None  # another chair's session
    end = LiftRequest(2.0, "lift_a", "chair1-g1", LiftRequestType.END_SESSION, "", LiftDoor.CLOSED)
    assert sent_lift(bridge.lift_request(end, now=1.0)) == ("LIFT_A", "chair1-g1", 0, "")
    assert bridge.held() == ([], [])
    bridge.lift_request(call, now=50.0)
    # a next mission's session while that one is held: each is ended on its own lease
    bridge.lift_request(LiftRequest(60.0, "lift_a", "chair1-g2", 1, "2", 2), now=60.0)
    (out,) = bridge.expire(now=50.0 + LEASE)
    assert sent_lift(out) == ("LIFT_A", "chair1-g1", LiftRequestType.END_SESSION, "")
    assert bridge.held() == ([], ["lift_a"])
    assert out.why == (
        "lift lift_a: END_SESSION of session 'chair1-g1', no request for 30 s (its lease)"
    )


def test_release_all_ends_what_the_chair_holds(bridge: RmfBridge) -> None:
    bridge.door_request(DoorRequest(1.0, "chair1", "d1", DoorMode.OPEN), now=1.0)
    call = LiftRequest(1.0, "lift_a", "chair1", LiftRequestType.AGV_MODE, "2", LiftDoor.OPEN)
    bridge.lift_request(call, now=1.0)
    doors, lifts = bridge.release_all(now=2.0)
    assert sent_door(doors)[:3] == ("Door_L1_01", "chair1", DoorMode.CLOSED)
    assert sent_lift(lifts)[:3] == ("LIFT_A", "chair1", LiftRequestType.END_SESSION)
    assert bridge.held() == ([], []) and bridge.release_all(now=3.0) == []


def test_two_site_names_for_one_building_name_are_refused() -> None:
    with pytest.raises(ValueError, match="lifts 'a' and 'b' both have the building name 'b'"):
        RmfBridge("chair1", doors=[], lifts=["a", "b"], lift_names={"a": "b"})
