"""The emergency stop latch: its rules on their own, then holders on a real Zenoh router
(plain buses in this process standing in for the services), one restarting."""

from __future__ import annotations

import logging
import time
from collections.abc import Callable

from shared.config import TransportConfig
from shared.estop import NEVER, EstopLatch, hold_estop
from shared.messages import EmergencyStop
from shared.topics import Keys
from shared.transport import Bus, open_session

LOG = logging.getLogger("test")
STOP = EmergencyStop(1.7e9, True, "wheelnav stop (laptop)", "a person on the ramp")
CLEAR = EmergencyStop(1.7e9 + 60, False, "wheelnav stop (laptop)")


def wait_for(predicate: Callable[[], bool], what: str, timeout_s: float = 30.0) -> None:
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        if predicate():
            return
        time.sleep(0.01)
    raise AssertionError(f"timed out waiting for {what}")


def test_a_holder_counts_as_stopped_until_every_answer_is_in() -> None:
    latch = EstopLatch("controller", ["navigator", "sim"])
    assert latch.active and "not known yet" in latch.reason()
    assert not latch.on_answer("navigator", None)  # no answer: nothing to take up
    assert latch.active
    assert not latch.on_answer("sim", NEVER)
    assert not latch.active and latch.reason() == ""


def test_any_holder_that_is_stopped_stops_the_one_asking() -> None:
    latch = EstopLatch("controller", ["navigator", "sim"])
    assert not latch.on_answer("navigator", CLEAR)
    assert latch.on_answer("sim", STOP)
    assert latch.active
    assert latch.reason() == "emergency stop by wheelnav stop (laptop): a person on the ramp"


def test_a_stop_message_outranks_the_answers() -> None:
    latch = EstopLatch("controller", ["sim"])
    latch.on_message(CLEAR)  # the operator's latest word came first
    assert not latch.on_answer("sim", STOP)
    assert not latch.active and latch.stop is CLEAR


def publish_until(bus, key: str, msg, predicate: Callable[[], bool], timeout_s: float = 30.0):
    """Publish ``msg`` every 0.2 s until ``predicate()`` holds (AssertionError after
    ``timeout_s``)."""
    end = time.monotonic() + timeout_s
    while not predicate():
        assert time.monotonic() < end, f"{msg} on {key} not taken up within {timeout_s} s"
        bus.publish(key, msg)
        time.sleep(0.2)


def holder(endpoint: str, name: str, changes: list[bool]) -> tuple[Bus, EstopLatch]:
    bus = Bus(open_session(TransportConfig(mode="client", connect=[endpoint])), name)
    latch = hold_estop(bus, Keys("chair1"), name, LOG, lambda lt: changes.append(lt.stop.active))
    return bus, latch


def test_a_restarted_holder_takes_up_the_stop_the_others_hold(router) -> None:
    bus, endpoint = router
    keys = Keys("chair1")
    changes: dict[str, list[bool]] = {"controller": [], "navigator": [], "sim": []}
    buses = []
    try:
        controller_bus, controller = holder(endpoint, "controller", changes["controller"])
        navigator_bus, navigator = holder(endpoint, "navigator", changes["navigator"])
        buses += [controller_bus, navigator_bus]
        wait_for(lambda: not controller.active and not navigator.active, "the start-up answers")
        assert changes == {"controller": [], "navigator": [], "sim": []}  # nothing was set
        # sent until both have it: on a loaded machine a subscription may reach the router
        # later than any fixed wait (on_change fires on a change only)
        publish_until(bus, keys.estop, STOP, lambda: controller.active and navigator.active)
        controller_bus.close()  # the controller dies while the chair is stopped...
        buses.remove(controller_bus)
        sim_bus, sim = holder(endpoint, "sim", changes["sim"])  # ...and a holder starts
        buses.append(sim_bus)
        wait_for(lambda: not sim.waiting, "the sim's start-up answers")
        assert sim.active and sim.stop.reason == "a person on the ramp"
        assert changes["sim"] == [True]
        restarted_bus, restarted = holder(endpoint, "controller", changes["controller"])
        buses.append(restarted_bus)
        wait_for(lambda: not restarted.waiting, "the restarted controller's answers")
        assert restarted.active  # the stop was not lost with the controller
        publish_until(
            bus, keys.estop, CLEAR, lambda: not (restarted.active or navigator.active or sim.active)
        )
        assert changes["navigator"] == [True, False] and changes["sim"] == [True, False]
    finally:
        for b in buses:
            b.close()
