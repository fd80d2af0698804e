"""The simulator's wait for a lockstep stage: it announces the tick again while it waits.

A participant restarted by the launcher declares its subscription to the clock after the
simulator announced the tick it is now due at; without a repeat it would wait for the
next tick while the simulator waited for it until ``sim.lockstep_timeout_s``, and the run
would go on without it (no longer repeatable). Here the participant hears only repeats.
The simulator waits with the bus's dispatcher lent to it (it delivers the answers itself),
as the node does in lockstep.
"""

from __future__ import annotations

import contextlib
import threading
import time
from collections.abc import Iterator
from types import SimpleNamespace

from services.sim.node import REANNOUNCE_S, _wait_stage
from shared.config import FleetConfig, SimConfig
from shared.lockstep import Barrier
from shared.messages import Ack
from shared.transport import Dispatcher


@contextlib.contextmanager
def waiting_sim(timeout_s: float) -> Iterator[tuple]:
    dispatcher = Dispatcher("test-sim-bus")
    svc = SimpleNamespace(
        cfg=FleetConfig(sim=SimConfig(lockstep_timeout_s=timeout_s)),
        stop_event=threading.Event(),
        bus=SimpleNamespace(dispatcher=dispatcher),
    )
    barrier = Barrier([["localisation"], ["controller"]])
    barrier.set_alive("controller", True)
    try:
        with dispatcher.lent():
            yield svc, barrier, threading.Condition()
    finally:
        dispatcher.close()


def test_a_participant_that_missed_the_announcement_answers_a_repeat() -> None:
    repeats = []
    with waiting_sim(30.0) as (svc, barrier, wake):

        def announce() -> None:  # the late participant hears this one and answers
            repeats.append(time.monotonic())
            with wake:
                barrier.ack(Ack("controller", 7, 8, 0.001))

        started = time.monotonic()
        assert _wait_stage(svc, barrier, wake, 7, 1, announce)
    assert len(repeats) == 1
    assert repeats[0] - started >= REANNOUNCE_S * 0.9
    assert time.monotonic() - started < 10.0  # not the 30 s bound


def test_a_live_participant_that_never_answers_is_given_up_after_the_bound() -> None:
    repeats = []
    with waiting_sim(1.2) as (svc, barrier, wake):
        started = time.monotonic()
        assert not _wait_stage(svc, barrier, wake, 7, 1, lambda: repeats.append(1))
    assert time.monotonic() - started >= 1.2
    assert 1 <= len(repeats) <= 2  # every 0.5 s of the wait (fewer when the machine lags)


def test_a_stage_with_every_answer_in_returns_at_once() -> None:
    with waiting_sim(30.0) as (svc, barrier, wake):
        barrier.ack(Ack("controller", 7, 8, 0.001))
        assert _wait_stage(svc, barrier, wake, 7, 1, lambda: None)
