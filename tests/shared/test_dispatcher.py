"""One dispatcher shared by several buses (the in-process fleet's): one delivery order
across buses, each handler under its own bus's lock, and deferred hand-over. Real Zenoh
sessions on loopback, no router (a session routes within itself)."""

from __future__ import annotations

import threading
import time

import pytest

from shared.messages import Clock
from shared.transport import Bus, Dispatcher, open_local_session
from tests.conftest import eventually


class Fleet:
    """Two subscriber buses on one shared dispatcher, and a publisher bus of its own."""

    def __init__(self) -> None:
        self.session = open_local_session()
        self.dispatcher = Dispatcher("test-deliveries")
        self.a = Bus(self.session, "a", owns_session=False, dispatcher=self.dispatcher)
        self.b = Bus(self.session, "b", owns_session=False, dispatcher=self.dispatcher)
        self.pub = Bus(self.session, "pub", owns_session=False)
        self.seen: list[tuple[str, int, str, bool]] = []

    def listen(self, bus: Bus, key: str) -> None:
        def on(msg: Clock) -> None:
            owned = bus.lock._is_owned()  # the handler runs under its own bus's lock
            self.seen.append((bus.name, msg.tick, threading.current_thread().name, owned))

        bus.subscribe(key, Clock, on)

    def close(self) -> None:
        for bus in (self.pub, self.a, self.b):
            bus.close()
        self.dispatcher.close()
        self.session.close()


def test_buses_sharing_a_dispatcher_are_delivered_in_publishing_order_on_its_thread() -> None:
    f = Fleet()
    try:
        f.listen(f.a, "t/a")
        f.listen(f.b, "t/b")
        time.sleep(0.2)
        for tick in range(200):
            f.pub.publish("t/a" if tick % 3 else "t/b", Clock(0.0, tick, 0.02))
        assert eventually(lambda: len(f.seen) == 200)
        assert [tick for _, tick, _, _ in f.seen] == list(range(200))
        assert [name for name, *_ in f.seen] == ["a" if t % 3 else "b" for t in range(200)]
        assert {thread for _, _, thread, _ in f.seen} == {"test-deliveries"}
        assert all(owned for *_, owned in f.seen)
    finally:
        f.close()


def test_deferred_holds_deliveries_until_the_end_then_hands_them_over_in_order() -> None:
    f = Fleet()
    try:
        f.listen(f.a, "t/a")
        f.listen(f.b, "t/b")
        time.sleep(0.2)
        with f.dispatcher.deferred():
            for tick in range(20):
                f.pub.publish("t/b" if tick % 2 else "t/a", Clock(0.0, tick, 0.02))
            with f.dispatcher.deferred():  # nested: the outer one hands over
                f.pub.publish("t/a", Clock(0.0, 20, 0.02))
            time.sleep(0.3)
            assert f.seen == []
        assert eventually(lambda: len(f.seen) == 21)
        assert [tick for _, tick, _, _ in f.seen] == list(range(21))
    finally:
        f.close()


def test_a_failing_handler_is_counted_on_its_bus_and_closing_one_bus_keeps_the_other() -> None:
    f = Fleet()
    try:
        f.a.subscribe("t/a", Clock, lambda msg: 1 / 0)
        f.listen(f.b, "t/b")
        time.sleep(0.2)
        f.pub.publish("t/a", Clock(0.0, 1, 0.02))
        f.pub.publish("t/b", Clock(0.0, 2, 0.02))
        assert eventually(lambda: len(f.seen) == 1)
        assert sum(f.a.bad_messages.values()) == 1 and not f.b.bad_messages
        f.a.close()  # a bus on a shared dispatcher leaves it running for the others
        f.pub.publish("t/b", Clock(0.0, 3, 0.02))
        assert eventually(lambda: len(f.seen) == 2)
        assert f.dispatcher.thread.is_alive()
    finally:
        f.close()
    assert not f.dispatcher.thread.is_alive()


def test_a_lent_dispatcher_delivers_only_in_pump_on_the_borrower_then_on_its_own_again() -> None:
    f = Fleet()
    try:
        f.listen(f.a, "t/a")
        f.listen(f.b, "t/b")
        time.sleep(0.2)
        f.pub.publish("t/a", Clock(0.0, 0, 0.02))  # queued before: its own thread delivers it
        with f.dispatcher.lent():
            assert [tick for _, tick, _, _ in f.seen] == [0]
            for tick in range(1, 11):
                f.pub.publish("t/b" if tick % 2 else "t/a", Clock(0.0, tick, 0.02))
            time.sleep(0.3)
            assert len(f.seen) == 1  # lent: nothing is delivered outside pump
            assert f.dispatcher.pump(lambda: len(f.seen) == 11, 5.0)
            assert not f.dispatcher.pump(lambda: False, 0.2)  # nothing comes: times out
        f.pub.publish("t/a", Clock(0.0, 11, 0.02))
        assert eventually(lambda: len(f.seen) == 12)
        assert [tick for _, tick, _, _ in f.seen] == list(range(12))
        borrower = threading.current_thread().name
        threads = [thread for _, _, thread, _ in f.seen]
        assert threads == ["test-deliveries"] + [borrower] * 10 + ["test-deliveries"]
        assert all(owned for *_, owned in f.seen)
    finally:
        f.close()
    assert not f.dispatcher.thread.is_alive()


def test_pump_needs_the_dispatcher_lent_to_its_thread_and_a_closed_one_delivers_no_more() -> None:
    f = Fleet()
    try:
        f.listen(f.a, "t/a")
        time.sleep(0.2)
        with pytest.raises(RuntimeError, match="only inside lent"):
            f.dispatcher.pump(lambda: True, 0.1)
        with f.dispatcher.lent():
            f.dispatcher.close()  # from the borrower: its thread ends once taken back
            f.pub.publish("t/a", Clock(0.0, 1, 0.02))
            assert not f.dispatcher.pump(lambda: len(f.seen) == 1, 0.3)
        assert eventually(lambda: not f.dispatcher.thread.is_alive())
        assert f.seen == []
    finally:
        f.close()
