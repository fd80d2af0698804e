"""Door state machines: each door type's behaviour, its timings, faults and published states."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from services.building.doors import DoorFault, DoorMotion, DoorSim, DoorTiming
from shared.codec import decode, encode
from shared.messages import DoorMode, DoorRequest, DoorState
from shared.site import Door

DT = 0.05
HINGED_OPEN_S = (math.pi / 2) / 0.5


def make(kind: str, width: float = 0.9, **kwargs) -> DoorSim:
    return DoorSim(Door("d1", "1", (0.0, 0.0), (width, 0.0), kind), **kwargs)


def req(who: str, mode: int, t: float = 0.0) -> DoorRequest:
    return DoorRequest(t, who, "d1", mode)


def run(sim: DoorSim, t0: float, t1: float, dt: float = DT) -> list[tuple[float, float, int]]:
    """(time, opening, mode) at every step from t0 (exclusive) to t1 (inclusive)."""
    out = []
    n = round((t1 - t0) / dt)
    for i in range(1, n + 1):
        t = t0 + i * dt
        sim.update(t)
        out.append((t, sim.opening, sim.mode()))
    return out


def first(trace: list[tuple[float, float, int]], mode: int) -> float:
    return next(t for t, _, m in trace if m == mode)


# --------------------------------------------------------------------------------------
# Manual doors
# --------------------------------------------------------------------------------------


def test_manual_door_follows_its_schedule() -> None:
    sim = make("manual", schedule=[(20.0, "close"), (2.0, "open")])
    sim.update(0.0)
    trace = run(sim, 0.0, 30.0)
    assert all(m == DoorMode.CLOSED for t, _, m in trace if t <= 2.0)
    assert first(trace, DoorMode.OPEN) == pytest.approx(2.0 + HINGED_OPEN_S, abs=DT)
    assert all(m == DoorMode.OPEN for t, _, m in trace if 2.0 + HINGED_OPEN_S + DT < t <= 20.0)
    closed_again = next(t for t, _, m in trace if t > 20.0 and m == DoorMode.CLOSED)
    assert closed_again == pytest.approx(20.0 + HINGED_OPEN_S, abs=DT)


def test_manual_door_ignores_requests_but_records_them() -> None:
    sim = make("manual")
    sim.request(1.0, req("chair1", DoorMode.OPEN))
    sim.request(1.5, DoorRequest(1.5, "chair1", "other_door", DoorMode.OPEN))
    run(sim, 1.5, 15.0)
    assert sim.opening == 0.0 and sim.mode() == DoorMode.CLOSED
    assert [r.requester_id for _, r in sim.requests] == ["chair1"]
    assert sim.sessions == frozenset()


def test_schedule_entries_before_the_first_update_apply_at_once() -> None:
    sim = make("manual", schedule=[(0.0, "open")])
    sim.update(5.0)
    sim.update(5.0 + HINGED_OPEN_S)
    assert sim.mode() == DoorMode.OPEN


# --------------------------------------------------------------------------------------
# Automatic doors
# --------------------------------------------------------------------------------------


def test_automatic_door_opens_only_on_motion_and_closes_after_the_hold_time() -> None:
    sim = make("automatic")
    sim.request(0.0, req("chair1", DoorMode.OPEN))
    sim.set_presence(1.0, False)
    run(sim, 1.0, 10.0)
    assert sim.mode() == DoorMode.CLOSED, "a request or a still presence must not open it"
    sim.set_presence(10.0, True)
    trace = run(sim, 10.0, 13.0)
    sim.set_presence(13.0, False)
    trace += run(sim, 13.0, 30.0)
    assert first(trace, DoorMode.OPEN) == pytest.approx(10.0 + HINGED_OPEN_S, abs=DT)
    hold_end = 13.0 + DoorTiming().hold_open_s
    assert all(m == DoorMode.OPEN for t, _, m in trace if 10.0 + HINGED_OPEN_S + DT < t <= hold_end)
    assert next(t for t, _, m in trace if t > hold_end and m != DoorMode.OPEN) <= hold_end + DT
    closed = next(t for t, _, m in trace if t > hold_end and m == DoorMode.CLOSED)
    assert closed == pytest.approx(hold_end + HINGED_OPEN_S, abs=DT)


def test_automatic_door_stays_open_while_motion_continues() -> None:
    sim = make("automatic")
    sim.set_presence(0.0, True)
    trace = run(sim, 0.0, 60.0)
    assert all(m == DoorMode.OPEN for t, _, m in trace if t > HINGED_OPEN_S + DT)


def test_automatic_door_reopens_when_obstructed_while_closing() -> None:
    sim = make("automatic")
    sim.set_presence(0.0, True)
    sim.set_presence(1.0, False)
    run(sim, 1.0, 7.0)
    assert sim.mode() == DoorMode.MOVING and not sim.commanded_open, "closing since t=6"
    closing_at = sim.opening
    sim.set_obstructed(7.0, True)
    trace = run(sim, 7.0, 30.0)
    assert trace[0][1] > closing_at, "it must reverse at once"
    assert all(m == DoorMode.OPEN for t, _, m in trace if t > 7.0 + HINGED_OPEN_S)
    sim.set_obstructed(30.0, False)
    trace = run(sim, 30.0, 45.0)
    hold_end = 30.0 + DoorTiming().hold_open_s
    assert all(m == DoorMode.OPEN for t, _, m in trace if t <= hold_end)
    assert trace[-1][2] == DoorMode.CLOSED


# --------------------------------------------------------------------------------------
# Powered doors
# --------------------------------------------------------------------------------------


def test_powered_door_stays_open_while_any_requester_holds_a_session() -> None:
    sim = make("powered")
    sim.request(0.0, req("chair1", DoorMode.OPEN))
    sim.request(1.0, req("chair2", DoorMode.OPEN))
    trace = run(sim, 1.0, 10.0)
    assert first(trace, DoorMode.OPEN) == pytest.approx(HINGED_OPEN_S, abs=DT)
    sim.request(10.0, req("chair1", DoorMode.CLOSED))
    trace = run(sim, 10.0, 20.0)
    assert all(m == DoorMode.OPEN for _, _, m in trace)
    assert sim.sessions == {"chair2"}
    sim.request(20.0, req("chair2", DoorMode.CLOSED))
    trace = run(sim, 20.0, 30.0)
    assert first(trace, DoorMode.CLOSED) == pytest.approx(20.0 + HINGED_OPEN_S, abs=DT)


def test_powered_door_repeated_and_unknown_requests_are_harmless() -> None:
    sim = make("powered")
    for t in (0.0, 1.0, 2.0):
        sim.request(t, req("chair1", DoorMode.OPEN))
    sim.request(3.0, req("chair1", DoorMode.MOVING))
    sim.request(4.0, req("nobody", DoorMode.CLOSED))
    run(sim, 4.0, 10.0)
    assert sim.mode() == DoorMode.OPEN
    sim.request(10.0, req("chair1", DoorMode.CLOSED))
    run(sim, 10.0, 15.0)
    assert sim.mode() == DoorMode.CLOSED


def test_a_powered_door_session_whose_holder_goes_silent_expires_after_its_lease() -> None:
    """Issue 12: door requests are leases. A requester that stops asking (its navigator
    died mid-pass) lets the door close ``session_lease_s`` after its last OPEN; one that
    keeps asking keeps it open; an obstruction still keeps a closing door open."""
    sim = make("powered", session_lease_s=30.0)
    sim.request(0.0, req("chair1", DoorMode.OPEN))
    for t in (10.0, 20.0, 30.0):
        sim.request(t, req("chair1", DoorMode.OPEN))
    run(sim, 30.0, 59.5)
    assert sim.mode() == DoorMode.OPEN and sim.sessions == {"chair1"}
    trace = run(sim, 59.5, 70.0)
    assert sim.sessions == set()  # 30 s after its last request
    assert first(trace, DoorMode.MOVING) == pytest.approx(60.0, abs=DT)
    assert sim.mode() == DoorMode.CLOSED
    held = make("powered")  # no lease given: held until CLOSED (as before)
    held.request(0.0, req("chair1", DoorMode.OPEN))
    run(held, 0.0, 200.0, dt=1.0)
    assert held.mode() == DoorMode.OPEN


def test_powered_door_does_not_close_on_an_obstruction() -> None:
    sim = make("powered")
    sim.request(0.0, req("chair1", DoorMode.OPEN))
    sim.update(5.0)
    sim.set_obstructed(5.0, True)
    sim.request(5.0, req("chair1", DoorMode.CLOSED))
    run(sim, 5.0, 20.0)
    assert sim.mode() == DoorMode.OPEN
    sim.set_obstructed(20.0, False)
    run(sim, 20.0, 25.0)
    assert sim.mode() == DoorMode.CLOSED


# --------------------------------------------------------------------------------------
# Timings
# --------------------------------------------------------------------------------------


def test_hinged_door_opens_in_about_3_1_s() -> None:
    sim = make("powered", motion=DoorMotion.HINGED)
    sim.request(0.0, req("chair1", DoorMode.OPEN))
    trace = run(sim, 0.0, 10.0)
    assert first(trace, DoorMode.OPEN) == pytest.approx(math.pi, abs=DT)
    assert sim.full_open_s == pytest.approx(math.pi)
    assert sim.angle_rad == pytest.approx(math.pi / 2) and sim.slide_m == 0.0


@pytest.mark.parametrize("width", [0.8, 0.9, 1.2])
def test_sliding_door_opens_at_0_2_m_per_s(width: float) -> None:
    sim = make("powered", width=width, motion=DoorMotion.SLIDING)
    sim.request(0.0, req("chair1", DoorMode.OPEN))
    trace = run(sim, 0.0, 10.0)
    assert first(trace, DoorMode.OPEN) == pytest.approx(width / 0.2, abs=DT)
    assert sim.slide_m == pytest.approx(width) and sim.angle_rad == 0.0


@pytest.mark.parametrize("step", [0.01, 0.3, 1.7])
def test_opening_does_not_depend_on_the_update_step(step: float) -> None:
    sim = make("automatic")
    sim.set_presence(0.5, True)
    sim.set_presence(1.0, False)
    t = 1.0
    while t < 7.5:
        t = min(7.5, t + step)
        sim.update(t)
    # Opens from 0.5 to pi + 0.5, held until 6.0, then 1.5 s of closing at 1/pi per s.
    assert sim.opening == pytest.approx(1.0 - 1.5 / math.pi)


def test_time_going_backwards_is_ignored() -> None:
    sim = make("powered")
    sim.request(0.0, req("chair1", DoorMode.OPEN))
    sim.update(1.0)
    before = sim.opening
    sim.update(0.5)
    assert sim.opening == before


# --------------------------------------------------------------------------------------
# Faults
# --------------------------------------------------------------------------------------


@pytest.mark.parametrize("kind", ["manual", "automatic", "powered"])
def test_stuck_closed_door_never_opens(kind: str) -> None:
    sim = make(kind, fault=DoorFault.STUCK_CLOSED, schedule=[(0.0, "open")])
    sim.set_presence(0.0, True)
    sim.request(0.0, req("chair1", DoorMode.OPEN))
    trace = run(sim, 0.0, 30.0)
    assert all(o == 0.0 and m == DoorMode.CLOSED for _, o, m in trace)


@pytest.mark.parametrize("kind", ["manual", "automatic", "powered"])
def test_stuck_half_open_door_never_reports_open(kind: str) -> None:
    sim = make(kind, fault=DoorFault.STUCK_HALF_OPEN, schedule=[(0.0, "open")])
    sim.set_presence(0.0, True)
    sim.request(0.0, req("chair1", DoorMode.OPEN))
    trace = run(sim, 0.0, 30.0)
    assert max(o for _, o, _ in trace) == pytest.approx(0.5)
    assert all(m == DoorMode.MOVING for _, _, m in trace)
    jammed = make(kind, fault=DoorFault.STUCK_HALF_OPEN, start_open=True)
    assert jammed.opening == 0.5 and jammed.state(0.0).current_mode == DoorMode.MOVING


def test_offline_door_reports_offline_and_does_not_move() -> None:
    sim = make("powered", fault=DoorFault.OFFLINE)
    sim.request(0.0, req("chair1", DoorMode.OPEN))
    run(sim, 0.0, 10.0)
    assert sim.opening == 0.0 and sim.mode() == DoorMode.OFFLINE


def test_bad_configuration_is_refused() -> None:
    with pytest.raises(ValueError, match="fault"):
        make("powered", fault="melted")
    with pytest.raises(ValueError, match="motion"):
        make("powered", motion="revolving")
    with pytest.raises(ValueError, match="schedule"):
        make("manual", schedule=[(1.0, "slam")])
    with pytest.raises(ValueError, match="coincide"):
        make("manual", width=0.0)


@settings(max_examples=60, deadline=None)
@given(
    kind=st.sampled_from(["manual", "automatic", "powered"]),
    fault=st.sampled_from([None, DoorFault.STUCK_HALF_OPEN, DoorFault.STUCK_CLOSED]),
    events=st.lists(
        st.tuples(
            st.floats(0.0, 2.0),
            st.sampled_from(["open", "close", "move", "still", "block", "clear"]),
            st.sampled_from(["a", "b"]),
        ),
        max_size=20,
    ),
)
def test_any_input_sequence_keeps_the_door_consistent(kind, fault, events) -> None:
    schedule = [(float(i), "open" if i % 2 else "close") for i in range(0, 40, 3)]
    sims = [make(kind, fault=fault, schedule=schedule) for _ in range(2)]
    t = 0.0
    for gap, what, who in events:
        t += gap
        for sim in sims:
            if what in ("open", "close"):
                mode = DoorMode.OPEN if what == "open" else DoorMode.CLOSED
                sim.request(t, req(who, mode, t))
            elif what in ("move", "still"):
                sim.set_presence(t, what == "move")
            else:
                sim.set_obstructed(t, what == "block")
        sims[1].update(t + 0.37)
        sims[0].update(t + 0.11)
        sims[0].update(t + 0.37)
        opening, mode = sims[0].opening, sims[0].mode()
        assert 0.0 <= opening <= 1.0
        assert sims[1].opening == pytest.approx(opening, abs=1e-9)
        assert (mode == DoorMode.CLOSED) == (opening <= 1e-9)
        assert (mode == DoorMode.OPEN) == (opening >= 1.0 - 1e-9)
        if fault is not None:
            assert mode != DoorMode.OPEN


# --------------------------------------------------------------------------------------
# Published state
# --------------------------------------------------------------------------------------


def test_state_messages_are_valid_and_published_on_change() -> None:
    sim = make("powered")
    msg = sim.state(0.0)
    assert decode(encode(msg), DoorState) == msg
    assert msg.current_mode == DoorMode.CLOSED and msg.door_name == "d1"
    assert sim.changed() and not sim.changed()
    sim.request(1.0, req("chair1", DoorMode.OPEN))
    assert not sim.changed()
    sim.state(1.5)
    assert sim.changed() and not sim.changed()
    msg = sim.state(10.0)
    assert sim.changed() and msg.current_mode == DoorMode.OPEN
    assert decode(encode(msg), DoorState) == msg
