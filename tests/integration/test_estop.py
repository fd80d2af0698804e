"""End to end: the emergency stop and the rider's pause on the whole fleet, in lockstep.

One demo mission over a real router: set the emergency stop while the chair drives, and
every layer obeys (the controller's command is zero, the simulated chair stops, the
mission is held past the safety limit, not failed); ``wheelnav stop --clear`` and it goes
on; then the rider takes the joystick (the test stands in for the chair driver), lets go,
and the mission stays paused until ``wheelnav resume``; then it succeeds. Waits are on
messages (wall-time timeouts are only there to fail a stuck run); times are sim time.
"""

from __future__ import annotations

import pytest

from shared.messages import (
    DriverStatus,
    EmergencyStop,
    Event,
    FollowStatus,
    NavGoal,
    Twist,
)
from tests.integration.test_fleet import DEMO, _fleet, _heard, wheelnav

pytestmark = pytest.mark.e2e
SAFETY_TIMEOUT_S = 10.0  # the hold outlasts it: a hold that leaked into the safety gate fails
HOLD_S = 15.0  # sim time the emergency stop is held
STILL_MPS = 0.01


@pytest.fixture
def fleet(router, tmp_path):
    yield from _fleet(
        router, tmp_path, DEMO, overrides=(f"navigator.safety_timeout_s={SAFETY_TIMEOUT_S}",)
    )


def last_stamp(seen: dict) -> float:
    return seen["truth"][-1].stamp


def test_the_emergency_stop_and_the_riders_pause_hold_the_mission_which_then_succeeds(
    fleet,
) -> None:
    bus, endpoint, _sup, keys, scenario, _out = fleet
    heard = _heard(fleet)
    heard.keep("cmd", keys.cmd_vel, Twist)
    heard.keep("follow", keys.follow_status, FollowStatus)
    heard.keep("controller", keys.key("events", source="controller"), Event)
    heard.keep("navigator", keys.key("events", source="navigator"), Event)
    rate = scenario.config.controller.rate_hz
    bus.publish(keys.nav_goal, NavGoal(0.0, "estop", None, scenario.place))
    heard.moving()

    # -- the emergency stop, set while the chair drives ------------------------------------
    with heard.lock:
        set_no_later = last_stamp(heard.seen)  # sim time before the stop went out
    bus.publish(keys.estop, EmergencyStop(1.0, True, "test", "end to end"))
    got = heard.wait_for(
        lambda s: next((e for e in s["controller"] if e.kind == "emergency_stop"), None),
        60,
        "no emergency_stop event from the controller",
    )
    zero = heard.wait_for(
        lambda s: next((c for c in s["cmd"] if c.stamp >= got.stamp and c.v == 0.0), None),
        60,
        "no zero command after the stop",
    )
    print(
        f"stop: the controller heard it at {got.stamp - set_no_later:+.3f} s and commanded"
        f" zero at {zero.stamp - set_no_later:+.3f} s (sim time, from the last the test saw)"
    )
    assert zero.stamp - got.stamp <= 0.5
    assert zero.stamp - set_no_later <= 2.0  # generous: the test's own view of sim time lags
    stopped = heard.wait_for(
        lambda s: next((t for t in s["truth"] if t.stamp > got.stamp and t.v < STILL_MPS), None),
        60,
        "the chair did not stop",
    )
    assert stopped.stamp - got.stamp <= 2.0  # braking from cruise speed
    heard.wait_for(
        lambda s: last_stamp(s) >= got.stamp + HOLD_S, 120, f"{HOLD_S} s held did not pass"
    )
    with heard.lock:
        held = [m for m in heard.seen["status"] if m.stamp > got.stamp + 1.0]
        cmds = [c for c in heard.seen["cmd"] if c.stamp > got.stamp + 1.5 / rate]
        truth = [t for t in heard.seen["truth"] if t.stamp > stopped.stamp]
        follow = [f for f in heard.seen["follow"] if f.stamp > got.stamp + 1.5 / rate]
    assert held and all(m.state == "running" for m in held), held[-1]
    assert all(m.reason.startswith("held: emergency stop by test") for m in held), held[-1]
    assert all(c.v == 0.0 and c.w == 0.0 for c in cmds)
    assert all(abs(t.v) < STILL_MPS for t in truth)
    assert follow and all(f.state == "estop" for f in follow)

    with heard.lock:
        before_clear = last_stamp(heard.seen)
    cleared = wheelnav("stop", "--clear", "--connect", endpoint, "--timeout", "30", timeout=120)
    assert cleared.returncode == 0, cleared.stdout + cleared.stderr
    assert "emergency stop cleared: acknowledged by controller, sim, navigator" in cleared.stdout
    with heard.lock:
        after_clear = last_stamp(heard.seen)
    heard.wait_for(
        lambda s: any(t.stamp > after_clear and t.v > 0.2 for t in s["truth"]),
        60,
        "the chair did not drive on after the stop was cleared",
    )

    # -- the rider takes the joystick, lets go: paused until asked --------------------------
    bus.publish(keys.driver_status, DriverStatus(1.0, 80, 4, 0, True, True))
    paused = heard.wait_for(
        lambda s: next((m for m in s["status"] if "paused: the rider" in m.reason), None),
        60,
        "the mission was not paused for the rider",
    )
    assert paused.state == "running"
    bus.publish(keys.driver_status, DriverStatus(2.0, 80, 4, 0, False, True))
    heard.wait_for(lambda s: last_stamp(s) >= paused.stamp + 8.0, 120, "8 s paused did not pass")
    with heard.lock:
        late = [t for t in heard.seen["truth"] if t.stamp > paused.stamp + 2.0]
        still = [m for m in heard.seen["status"] if m.stamp > paused.stamp]
    assert late and all(abs(t.v) < STILL_MPS for t in late)  # let go: it stays put
    assert all("paused: the rider took the joystick" in m.reason for m in still), still[-1]
    resumed = wheelnav("resume", "--connect", endpoint, "--timeout", "30", timeout=120)
    assert resumed.returncode == 0, resumed.stdout + resumed.stderr
    assert "mission estop resumed by wheelnav resume" in resumed.stdout

    done = heard.mission_end("estop")
    assert done.state == "succeeded", done.reason
    with heard.lock:
        events = list(heard.seen["navigator"])
    kinds = [e.kind for e in events]
    assert kinds.count("hold") == 2 and kinds.count("hold_over") == 2, events
    during = [e for e in events if got.stamp + 1.0 < e.stamp < before_clear]
    assert not [e for e in during if e.kind == "safety_stop"], during  # held above the gate
