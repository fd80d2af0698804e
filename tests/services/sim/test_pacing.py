"""The simulator paced to the wall clock: it waits for its clock to be due, catches up a
short lag, and lets a stall's lost time go instead of running it in a burst the services
could not answer. The pacing alone, then the simulator node on wall time, stopped by
SIGSTOP and let go on, over a real router."""

from __future__ import annotations

import os
import signal
import subprocess
import threading
import time

import pytest

from services.sim.pacing import Pacer
from shared.messages import Event, Odometry
from shared.topics import Keys
from tests.conftest import PYTHON, ROOT


def test_on_pace_it_waits_a_short_lag_is_caught_up_and_a_stall_slips() -> None:
    pacer = Pacer(1.0, 0.1, now=100.0)
    assert pacer.wait_s(0.02, now=100.005) == (pytest.approx(0.015), 0.0)
    # 0.08 s behind: within max_lag_s, no wait (caught up over the next steps), nothing let go
    assert pacer.wait_s(0.04, now=100.12) == (0.0, 0.0)
    # stopped for 2 s: all but max_lag_s of it is let go, then the clock runs on from there
    wait, slip = pacer.wait_s(0.06, now=102.06)
    assert wait == 0.0 and slip == pytest.approx(1.9)
    assert pacer.slipped_s == pytest.approx(1.9)
    # the clock now reads 0 at 101.9: at 102.06 it is due at 0.16, max_lag_s behind
    assert pacer.wait_s(0.08, now=102.06) == (0.0, 0.0)
    assert pacer.wait_s(0.30, now=102.06)[0] == pytest.approx(0.14)
    fast = Pacer(4.0, 0.1, now=0.0)  # four times real time: 0.2 s of clock a 0.05 s wait
    assert fast.wait_s(0.2, now=0.0) == (pytest.approx(0.05), 0.0)


@pytest.mark.parametrize("factor, lag", [(0.0, 0.1), (-1.0, 0.1), (1.0, -0.1)])
def test_settings_it_cannot_pace_with_are_refused(factor: float, lag: float) -> None:
    with pytest.raises(ValueError):
        Pacer(factor, lag, now=0.0)


def test_a_stopped_simulator_lets_the_lost_time_go_and_says_so(router, tmp_path) -> None:
    bus, endpoint = router
    keys = Keys("chair1")
    truth: list[tuple[float, float]] = []  # (arrival, stamp)
    events: list[Event] = []
    lock = threading.Lock()

    def on_truth(m: Odometry) -> None:
        with lock:
            truth.append((time.monotonic(), m.stamp))

    bus.subscribe(keys.ground_truth, Odometry, on_truth)
    bus.subscribe(keys.key("events"), Event, events.append)
    settings = ["clock=wall", "sim.lockstep=false", "sim.start_after=[]", "sim.lidar=planar"]
    args = [a for s in settings for a in ("--set", s)]
    sim = subprocess.Popen(
        [PYTHON, "-m", "services.sim.node", "--connect", endpoint, *args],
        cwd=ROOT,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        deadline = time.monotonic() + 120.0
        while time.monotonic() < deadline and len(truth) < 50:
            time.sleep(0.05)
        assert len(truth) >= 50, "the simulator never ran"
        os.kill(sim.pid, signal.SIGSTOP)
        time.sleep(2.0)
        with lock:
            before = len(truth)
        os.kill(sim.pid, signal.SIGCONT)
        deadline = time.monotonic() + 60.0
        while time.monotonic() < deadline and not any(e.kind == "behind" for e in events):
            time.sleep(0.05)
        time.sleep(1.0)
    finally:
        sim.terminate()
        _, err = sim.communicate(timeout=30)
    stalls = [e for e in events if e.kind == "behind" and e.source == "sim"]
    assert stalls, (events, err[-2000:])
    assert "let go, not run in a burst" in stalls[0].detail
    # after the stop the clock ran no faster than the wall clock, but for what is caught
    # up (max_lag_s) and generous slack: a burst would have run the 2 s in a few ms
    with lock:
        after = truth[before:]
    assert len(after) > 10
    a0, s0 = after[0]
    assert all((s - s0) - (a - a0) <= 0.1 + 0.5 for a, s in after), after[:20]
