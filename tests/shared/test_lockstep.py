"""Lockstep bookkeeping: who the simulator waits for, and when participants answer."""

from __future__ import annotations

from shared.lockstep import Barrier, Participant
from shared.messages import Ack, Clock


def test_barrier_waits_for_live_participants_of_the_stage() -> None:
    b = Barrier([["localisation"], ["controller", "navigator"]])
    assert b.waiting_on(0, 1) == []  # nobody alive yet
    b.set_alive("controller", True)
    b.set_alive("navigator", True)
    b.set_alive("stranger", True)  # not a participant: ignored
    assert b.waiting_on(0, 1) == ["controller", "navigator"]
    b.ack(Ack("controller", 0, 2))
    assert b.waiting_on(0, 1) == ["navigator"]
    assert not b.answered(0, 1)
    b.ack(Ack("navigator", 0, 5))
    assert b.waiting_on(0, 1) == []
    assert b.answered(0, 1)
    assert b.waiting_on(2, 1) == ["controller"]
    assert not b.answered(2, 1)
    assert b.waiting_on(5, 1) == ["controller", "navigator"]
    assert b.answered(5, 0)  # nobody alive in stage 0


def test_dead_participant_is_not_waited_for_and_restarts_due() -> None:
    b = Barrier([["controller"]])
    b.set_alive("controller", True)
    b.ack(Ack("controller", 0, 10))
    b.set_alive("controller", False)
    assert b.waiting_on(3, 0) == []
    b.set_alive("controller", True)
    assert b.waiting_on(3, 0) == ["controller"]


def test_participant_steps_at_its_rate_and_holds_acks() -> None:
    acks: list[Ack] = []
    steps: list[int] = []
    p = Participant("navigator", 1, 10.0, lambda c: steps.append(c.tick), acks.append)
    for tick in range(12):
        p.on_clock(Clock(tick * 0.02, tick, 0.02, 1))
        p.on_clock(Clock(tick * 0.02, tick, 0.02, 0))  # other stage: ignored
    assert steps == [0, 5, 10]
    assert [a.next_tick for a in acks] == [5, 10, 15]
    p.hold()
    p.on_clock(Clock(0.3, 15, 0.02, 1))
    assert len(acks) == 3  # withheld
    p.release()
    assert acks[-1] == Ack("navigator", 15, 20)


def test_participant_follows_a_restarted_clock() -> None:
    steps: list[int] = []
    p = Participant("controller", 0, 25.0, lambda c: steps.append(c.tick), lambda a: None)
    p.on_clock(Clock(10.0, 500, 0.02, 0))
    p.on_clock(Clock(0.0, 0, 0.02, 0))  # simulator restarted
    assert steps == [500, 0]
