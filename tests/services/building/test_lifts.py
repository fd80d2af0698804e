"""Lift state machine: sessions, trapezoidal car motion, doors that close before the car moves."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from services.building.lifts import (
    LiftFault,
    LiftSim,
    LiftTiming,
    trip_profile,
)
from shared.codec import decode, encode
from shared.messages import LiftDoor, LiftMode, LiftMotion, LiftRequest, LiftRequestType, LiftState

FLOORS = {"1": 0.0, "2": 4.5, "3": 9.0, "M": 1.5}
DT = 0.01
DOOR_S = 1.8 / 0.3
V_MAX, ACCEL = 2.0, 1.0


def expected_trip_s(distance: float) -> float:
    """Rest-to-rest time with a trapezoidal profile (triangular when too short to cruise)."""
    if distance >= V_MAX**2 / ACCEL:
        return distance / V_MAX + V_MAX / ACCEL
    return 2.0 * math.sqrt(distance / ACCEL)


def ask(session: str, floor: str, door: int = LiftDoor.OPEN, kind: int = LiftRequestType.AGV_MODE):
    return LiftRequest(0.0, "L1", session, kind, floor, door)


def end(session: str) -> LiftRequest:
    return LiftRequest(0.0, "L1", session, LiftRequestType.END_SESSION, "", LiftDoor.CLOSED)


def make(**kwargs) -> LiftSim:
    lift = LiftSim("L1", FLOORS, "1", **kwargs)
    lift.update(0.0)
    return lift


def run(
    lift: LiftSim, t0: float, t1: float, dt: float = DT
) -> list[tuple[float, LiftState, float]]:
    """(time, state, car elevation) at every step from t0 (exclusive) to t1 (inclusive)."""
    out = []
    for i in range(1, round((t1 - t0) / dt) + 1):
        t = t0 + i * dt
        out.append((t, lift.state(t), lift.car_elevation))
    return out


def check_doors_closed_while_moving(trace, lift: LiftSim) -> None:
    at_floor = set(lift.floors.values())
    for i, (_, s, z) in enumerate(trace):
        moving = s.motion_state != LiftMotion.STOPPED
        off_floor = all(abs(z - f) > 1e-9 for f in at_floor)
        moved = i > 0 and z != trace[i - 1][2]
        if moving or off_floor or moved:
            assert s.door_state == LiftDoor.CLOSED, f"doors not closed at t={trace[i][0]:.2f}"


# --------------------------------------------------------------------------------------
# Trips
# --------------------------------------------------------------------------------------


def test_session_calls_the_car_from_floor_1_to_floor_2() -> None:
    lift = make()
    assert lift.request(0.0, ask("chair1", "2")) is None
    trace = run(lift, 0.0, 20.0)
    check_doors_closed_while_moving(trace, lift)
    travel = expected_trip_s(4.5)
    arrived = next(t for t, s, z in trace if z == 4.5)
    assert arrived == pytest.approx(travel, abs=DT)
    assert next(t for t, s, _ in trace if s.motion_state == LiftMotion.UP) == pytest.approx(DT)
    opened = next(t for t, s, _ in trace if s.door_state == LiftDoor.OPEN)
    assert opened == pytest.approx(travel + DOOR_S, abs=DT)
    last = trace[-1][1]
    assert (last.current_floor, last.destination_floor, last.session_id) == ("2", "2", "chair1")
    assert last.motion_state == LiftMotion.STOPPED and last.current_mode == LiftMode.AGV


def test_doors_close_fully_before_the_car_moves() -> None:
    lift = make()
    lift.request(0.0, ask("chair1", "1"))
    trace = run(lift, 0.0, 10.0)
    assert trace[-1][1].door_state == LiftDoor.OPEN, "called to its own floor: doors open"
    lift.request(10.0, ask("chair1", "3"))
    trace += run(lift, 10.0, 35.0)
    check_doors_closed_while_moving(trace, lift)
    departed = next(t for t, s, _ in trace if s.motion_state != LiftMotion.STOPPED)
    assert departed == pytest.approx(10.0 + DOOR_S, abs=DT)
    arrived = next(t for t, _, z in trace if z == 9.0)
    assert arrived == pytest.approx(10.0 + DOOR_S + expected_trip_s(9.0), abs=DT)


def test_car_motion_is_trapezoidal_within_speed_and_acceleration_limits() -> None:
    lift = make()
    lift.request(0.0, ask("chair1", "3"))
    trace = run(lift, 0.0, 8.0)
    z = [e for _, _, e in trace]
    v = [(b - a) / DT for a, b in zip(z, z[1:], strict=False)]
    acc = [(b - a) / DT for a, b in zip(v, v[1:], strict=False)]
    assert all(b >= a for a, b in zip(z, z[1:], strict=False)), "never goes back down"
    assert max(v) <= V_MAX + 1e-6 and max(v) == pytest.approx(V_MAX, abs=1e-6)
    assert max(abs(a) for a in acc) <= ACCEL + 1e-6
    assert max(s.current_floor == "2" for _, s, _ in trace), "nearest floor reported en route"


def test_short_trip_is_triangular() -> None:
    lift = make()
    lift.request(0.0, ask("chair1", "M"))
    trace = run(lift, 0.0, 5.0)
    assert next(t for t, _, z in trace if z == 1.5) == pytest.approx(expected_trip_s(1.5), abs=DT)
    peak, _ = trip_profile(1.5, V_MAX, ACCEL, expected_trip_s(1.5) / 2)
    assert peak == pytest.approx(0.75)


def test_going_down_reports_down() -> None:
    lift = LiftSim("L1", FLOORS, "3")
    lift.request(0.0, ask("chair1", "1"))
    s = lift.state(1.0)
    assert s.motion_state == LiftMotion.DOWN and lift.car_velocity < 0.0


def test_new_destination_during_a_trip_is_served_after_the_current_stop() -> None:
    lift = make()
    lift.request(0.0, ask("chair1", "2", LiftDoor.OPEN))
    lift.request(1.0, ask("chair1", "3", LiftDoor.OPEN))
    trace = run(lift, 1.0, 20.0)
    check_doors_closed_while_moving(trace, lift)
    s = lift.state(20.0)
    assert lift.car_elevation == 9.0 and s.current_floor == "3" and s.door_state == LiftDoor.OPEN


@pytest.mark.parametrize("step", [0.005, 0.4, 3.3])
def test_state_does_not_depend_on_the_update_step(step: float) -> None:
    lift = make()
    lift.request(0.0, ask("chair1", "1"))
    lift.request(7.0, ask("chair1", "3"))
    t = 7.0
    while t < 17.0:
        t = min(17.0, t + step)
        lift.update(t)
    # Doors close from 7 to 13, then 4 s into a 6.5 s trip: 2 s accelerating, 2 s cruising.
    assert lift.car_elevation == pytest.approx(2.0 + 4.0)
    assert lift.car_velocity == pytest.approx(2.0)


# --------------------------------------------------------------------------------------
# Sessions
# --------------------------------------------------------------------------------------


def test_second_session_is_refused_until_the_first_ends() -> None:
    lift = make()
    assert lift.request(0.0, ask("chair1", "2")) is None
    assert lift.request(0.0, ask("chair1", "2")) is None, "re-sending is harmless"
    error = lift.request(1.0, ask("chair2", "3"))
    assert error is not None and "busy" in error and "chair1" in error
    assert lift.request(1.5, end("chair2")) is not None, "only the holder ends a session"
    assert lift.state(2.0).destination_floor == "2"
    assert lift.request(2.0, end("chair1")) is None
    assert lift.state(2.0).session_id == "" and lift.mode() == LiftMode.HUMAN
    assert lift.request(3.0, ask("chair2", "3", kind=LiftRequestType.HUMAN_MODE)) is None
    s = lift.state(3.0)
    assert (s.session_id, s.destination_floor, s.current_mode) == ("chair2", "3", LiftMode.HUMAN)
    assert [e is None for _, _, e in lift.requests] == [True, True, False, False, True, True]


def test_bad_requests_are_refused_with_a_reason() -> None:
    lift = make()
    assert "does not serve floor" in lift.request(0.0, ask("chair1", "99"))
    wrong = LiftRequest(0.0, "L2", "chair1", LiftRequestType.AGV_MODE, "2", LiftDoor.OPEN)
    assert "L2" in lift.request(0.0, wrong)
    assert "session_id" in lift.request(0.0, ask("", "2"))
    assert "door_state" in lift.request(0.0, ask("chair1", "2", door=LiftDoor.MOVING))
    assert "request type" in lift.request(0.0, ask("chair1", "2", kind=7))
    assert lift.request(0.0, end("chair1")) is None, "ending no session is harmless"
    assert lift.state(10.0).motion_state == LiftMotion.STOPPED and lift.car_elevation == 0.0


def test_doors_close_door_hold_s_after_the_session_ends() -> None:
    lift = make()
    lift.request(0.0, ask("chair1", "1"))
    trace = run(lift, 0.0, 30.0)
    assert all(s.door_state == LiftDoor.OPEN for t, s, _ in trace if t > DOOR_S + DT)
    lift.request(30.0, end("chair1"))
    trace = run(lift, 30.0, 50.0)
    hold = LiftTiming().door_hold_s
    assert all(s.door_state == LiftDoor.OPEN for t, s, _ in trace if t <= 30.0 + hold)
    closed = next(t for t, s, _ in trace if s.door_state == LiftDoor.CLOSED)
    assert closed == pytest.approx(30.0 + hold + DOOR_S, abs=DT)


def test_session_asking_closed_doors_keeps_them_shut() -> None:
    lift = make()
    lift.request(0.0, ask("chair1", "2", LiftDoor.CLOSED))
    trace = run(lift, 0.0, 20.0)
    assert all(s.door_state == LiftDoor.CLOSED for _, s, _ in trace)
    assert lift.car_elevation == 4.5


def test_car_arriving_without_a_session_opens_then_closes() -> None:
    lift = make()
    lift.request(0.0, ask("chair1", "2"))
    lift.request(1.0, end("chair1"))
    trace = run(lift, 1.0, 40.0)
    arrive = expected_trip_s(4.5)
    opened = next(t for t, s, _ in trace if s.door_state == LiftDoor.OPEN)
    assert opened == pytest.approx(arrive + DOOR_S, abs=DT)
    closing = next(t for t, s, _ in trace if t > opened and s.door_state != LiftDoor.OPEN)
    assert closing == pytest.approx(opened + LiftTiming().door_hold_s, abs=2 * DT)
    assert trace[-1][1].door_state == LiftDoor.CLOSED


def test_obstructed_doors_reopen_and_hold_the_car() -> None:
    lift = make()
    lift.request(0.0, ask("chair1", "1"))
    lift.request(10.0, ask("chair1", "2"))
    lift.update(12.0)
    assert lift.state(12.0).door_state == LiftDoor.MOVING
    lift.set_obstructed(12.0, True)
    trace = run(lift, 12.0, 30.0)
    assert trace[-1][1].door_state == LiftDoor.OPEN and lift.car_elevation == 0.0
    lift.set_obstructed(30.0, False)
    trace += run(lift, 30.0, 50.0)
    check_doors_closed_while_moving(trace, lift)
    departed = next(t for t, s, _ in trace if s.motion_state != LiftMotion.STOPPED)
    assert departed == pytest.approx(30.0 + DOOR_S, abs=DT)


# --------------------------------------------------------------------------------------
# Faults
# --------------------------------------------------------------------------------------


def test_out_of_service_lift_refuses_sessions_and_stays_put() -> None:
    lift = make(fault=LiftFault.OUT_OF_SERVICE)
    error = lift.request(0.0, ask("chair1", "2"))
    assert error is not None and "out of service" in error
    s = lift.state(30.0)
    assert s.current_mode == LiftMode.OFFLINE and s.session_id == "" and lift.car_elevation == 0.0


def test_door_slow_doors_take_four_times_as_long() -> None:
    times = []
    for fault in (None, LiftFault.DOOR_SLOW):
        lift = make(fault=fault)
        lift.request(0.0, ask("chair1", "1"))
        trace = run(lift, 0.0, 30.0, dt=0.05)
        times.append(next(t for t, s, _ in trace if s.door_state == LiftDoor.OPEN))
    assert times[0] == pytest.approx(DOOR_S, abs=0.05)
    assert times[1] == pytest.approx(4 * DOOR_S, abs=0.05)


def test_bad_configuration_is_refused() -> None:
    with pytest.raises(ValueError, match="start floor"):
        LiftSim("L1", FLOORS, "9")
    with pytest.raises(ValueError, match="fault"):
        LiftSim("L1", FLOORS, "1", fault="on_fire")
    with pytest.raises(ValueError, match="no floors"):
        LiftSim("L1", {}, "1")


# --------------------------------------------------------------------------------------
# Published state and invariants
# --------------------------------------------------------------------------------------


def test_state_messages_are_valid_and_published_on_change() -> None:
    lift = make()
    s = lift.state(0.0)
    assert decode(encode(s), LiftState) == s
    assert s.available_floors == ["1", "M", "2", "3"]
    assert (s.current_floor, s.door_state, s.motion_state) == ("1", LiftDoor.CLOSED, 0)
    assert lift.changed() and not lift.changed()
    lift.request(0.0, ask("chair1", "2"))
    assert lift.motion_state() == LiftMotion.UP, "doors were closed: leaves at once"
    assert lift.changed() and not lift.changed()
    lift.state(1.0)
    assert not lift.changed()
    lift.state(1.5)
    assert lift.changed() and lift.current_floor() == "M", "passing the mezzanine"


@settings(max_examples=60, deadline=None)
@given(
    fault=st.sampled_from([None, LiftFault.DOOR_SLOW]),
    events=st.lists(
        st.tuples(
            st.floats(0.0, 8.0),
            st.sampled_from(["ask", "end", "block", "clear"]),
            st.sampled_from(["a", "b"]),
            st.sampled_from(sorted(FLOORS)),
            st.sampled_from([LiftDoor.OPEN, LiftDoor.CLOSED]),
        ),
        max_size=12,
    ),
)
def test_any_request_sequence_keeps_the_lift_consistent(fault, events) -> None:
    lifts = [make(fault=fault) for _ in range(2)]
    low, high = min(FLOORS.values()), max(FLOORS.values())
    t = 0.0
    for gap, what, who, floor, door in events:
        for k in range(1, 11):
            lifts[0].update(t + gap * k / 10)
        t += gap
        lifts[1].update(t)
        for lift in lifts:
            if what == "ask":
                lift.request(t, ask(who, floor, door))
            elif what == "end":
                lift.request(t, end(who))
            else:
                lift.set_obstructed(t, what == "block")
        s = lifts[0].state(t)
        assert decode(encode(s), LiftState) == s
        assert lifts[1].state(t) == s
        assert lifts[1].car_elevation == pytest.approx(lifts[0].car_elevation, abs=1e-9)
        assert low <= lifts[0].car_elevation <= high
        if s.motion_state != LiftMotion.STOPPED:
            assert s.door_state == LiftDoor.CLOSED and lifts[0].door_opening == 0.0
        if not s.session_id:
            assert s.current_mode == LiftMode.HUMAN


def test_a_session_whose_holder_goes_silent_expires_after_its_lease() -> None:
    """Issue 12: a lift session is a lease. A holder that stops asking (its navigator died,
    its mission ended without END_SESSION) lets the lift go ``session_lease_s`` after its
    last request; a holder that keeps asking keeps it."""
    lift = make(session_lease_s=30.0)
    assert lift.request(0.0, ask("chair1", "2")) is None
    for t in (10.0, 20.0, 29.0):  # renewed within the lease: still held
        assert lift.request(t, ask("chair1", "2")) is None
    assert "busy" in (lift.request(50.0, ask("chair2", "3")) or "")
    lift.update(58.5)
    assert lift.state(58.5).session_id == "chair1"  # 29.5 s since its last request
    lift.update(59.5)
    assert lift.state(59.5).session_id == ""  # expired: free for the next
    assert lift.request(61.0, ask("chair2", "3")) is None
    assert lift.state(61.0).session_id == "chair2"
    held = make()  # no lease given: a session is held until it ends (as before)
    held.request(0.0, ask("chair1", "2"))
    held.update(1000.0)
    assert held.state(1000.0).session_id == "chair1"
