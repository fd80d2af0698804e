"""Field by field between Open-RMF's messages and wheelnav's: times, modes, names."""

from __future__ import annotations

import numpy as np
import pytest

from services.rmf_bridge import cdr
from services.rmf_bridge.errors import BadField, UnknownName
from services.rmf_bridge.translate import (
    Names,
    door_request_to_rmf,
    door_state_from_rmf,
    from_time,
    lift_request_to_rmf,
    lift_state_from_rmf,
    to_time,
)
from shared.messages import (
    DoorMode,
    DoorRequest,
    LiftDoor,
    LiftMotion,
    LiftRequest,
    LiftRequestType,
)


def test_times_convert_to_the_nanosecond_and_refuse_what_int32_cannot_hold() -> None:
    t = to_time(1700000000.25)
    assert (t.sec, t.nanosec) == (1700000000, 250_000_000)
    assert from_time(t) == 1700000000.25
    t = to_time(4.9999999999)  # rounds up into the next second, never nanosec == 1e9
    assert (t.sec, t.nanosec) == (5, 0)
    with pytest.raises(BadField, match="stamp: .* int32 seconds"):
        to_time(2.0**31)


def test_names_map_both_ways_and_refuse_what_they_do_not_know() -> None:
    doors = Names("door", ["d1", "d2"], {"d1": "Door_L1_01", "d9": "elsewhere"})
    assert doors.building("d1") == "Door_L1_01" and doors.building("d2") == "d2"
    assert doors.site("Door_L1_01") == "d1" and doors.site("d2") == "d2"
    assert doors.unused == ["d9"]
    with pytest.raises(UnknownName, match="door 'd1' of the building"):
        doors.site("d1")  # renamed: the building calls it Door_L1_01
    with pytest.raises(UnknownName, match="door 'd3': not one the building reports"):
        doors.building("d3")
    floors = Names("floor", ["1", "2"], {"1": "L1"}, strict=False)
    assert floors.site("L1") == "1" and floors.site("roof") == "roof"
    with pytest.raises(ValueError, match="doors 'd1' and 'd2' both have the building name"):
        Names("door", ["d1", "d2"], {"d1": "d2"})


def test_every_door_mode_crosses_and_a_foreign_one_is_refused() -> None:
    for mode in range(DoorMode.CLOSED, DoorMode.UNKNOWN + 1):
        rmf = cdr.message(
            cdr.DOOR_STATE,
            door_time=to_time(1.0),
            door_name="Door_1",
            current_mode=cdr.message(cdr.DOOR_MODE, value=mode),
        )
        state = door_state_from_rmf(rmf, "d1", 50.0)
        assert (state.door_name, state.current_mode, state.stamp) == ("d1", mode, 50.0)
        req = door_request_to_rmf(DoorRequest(7.5, "chair1", "d1", mode), "Door_1")
        assert req.requested_mode.value == mode and req.requester_id == "chair1"
        assert req.door_name == "Door_1" and from_time(req.request_time) == 7.5
    rmf.current_mode.value = 9
    with pytest.raises(BadField, match=r"current_mode.value: 9 is not a DoorMode \(0..4\)"):
        door_state_from_rmf(rmf, "d1", 50.0)


def test_lift_messages_cross_with_floor_names_and_checked_values() -> None:
    floors = Names("floor", ["1", "2"], {"1": "L1", "2": "L2"}, strict=False)
    rmf = cdr.message(
        cdr.LIFT_STATE, lift_time=to_time(1.0), lift_name="LIFT_A",
        available_floors=["L1", "L2"], current_floor="L2", destination_floor="L2",
        door_state=LiftDoor.OPEN, motion_state=LiftMotion.STOPPED,
        available_modes=np.array([1, 2], dtype=np.uint8), current_mode=2, session_id="chair1-g1",
    )  # fmt: skip
    state = lift_state_from_rmf(rmf, "lift_a", floors, 80.0)
    assert state.lift_name == "lift_a" and state.available_floors == ["1", "2"]
    assert (state.current_floor, state.destination_floor) == ("2", "2")
    assert (state.door_state, state.motion_state, state.current_mode) == (2, 0, 2)
    assert state.session_id == "chair1-g1" and state.stamp == 80.0
    rmf.motion_state = 7
    with pytest.raises(BadField, match="motion_state: 7 is not a lift motion state"):
        lift_state_from_rmf(rmf, "lift_a", floors, 80.0)
    req = LiftRequest(9.0, "lift_a", "chair1-g1", LiftRequestType.AGV_MODE, "2", LiftDoor.OPEN)
    out = lift_request_to_rmf(req, "LIFT_A", floors)
    assert (out.lift_name, out.session_id, out.request_type) == ("LIFT_A", "chair1-g1", 1)
    assert (out.destination_floor, out.door_state) == ("L2", 2)
    end = LiftRequest(9.0, "lift_a", "chair1-g1", LiftRequestType.END_SESSION, "", 0)
    assert lift_request_to_rmf(end, "LIFT_A", floors).destination_floor == ""
