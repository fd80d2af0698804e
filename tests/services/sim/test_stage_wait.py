"""The simulator's wait for a lockstep stage: it announces the tick again while it waits.

A participant restarted by the launcher declares its subscription to the clock after the
simulator announced the tick it is now due at; without a repeat it would wait for the
next tick while the simulator waited for it until ``sim.lockstep_timeout_s``, and the run
would go on without it (no longer repeatable). Here the participant hears only repeats.
"""

from __future__ import annotations

import threading
import time
from types import SimpleNamespace

from services.sim.node import REANNOUNCE_S, _wait_stage
from shared.config import FleetConfig, SimConfig
from shared.lockstep import Barrier
from shared.messages import Ack


def waiting_sim(timeout_s: float):
    svc = SimpleNamespace(
        cfg=FleetConfig(sim=SimConfig(lockstep_timeout_s=timeout_s)),
        stop_event=threading.Event(),
    )
    barrier = Barrier([["localisation"], ["controller"]])
    barrier.set_alive("controller", True)
    return svc, barrier, threading.Condition()


def test_a_participant_that_missed_the_announcement_answers_a_repeat() -> None:
    svc, barrier, wake = waiting_sim(30.0)
    repeats = []

    def announce() -> None:  # the late participant hears this one and answers
        repeats.append(time.monotonic())
        with wake:
            barrier.ack(Ack("controller", 7, 8, 0.001))
            wake.notify_all()

    started = time.monotonic()
    assert _wait_stage(svc, barrier, wake, 7, 1, announce)
    assert len(repeats) == 1
    assert repeats[0] - started >= REANNOUNCE_S * 0.9
    assert time.monotonic() - started < 10.0  # not the 30 s bound


def test_a_live_participant_that_never_answers_is_given_up_after_the_bound() -> None:
    svc, barrier, wake = waiting_sim(1.2)
    repeats = []
    started = time.monotonic()
    assert not _wait_stage(svc, barrier, wake, 7, 1, lambda: repeats.append(1))
    assert time.monotonic() - started >= 1.2
    assert 1 <= len(repeats) <= 2  # every 0.5 s of the wait (fewer when the machine lags)


def test_a_stage_with_every_answer_in_returns_at_once() -> None:
    svc, barrier, wake = waiting_sim(30.0)
    barrier.ack(Ack("controller", 7, 8, 0.001))
    assert _wait_stage(svc, barrier, wake, 7, 1, lambda: None)
