"""``wheelnav stop`` and ``wheelnav resume`` on a real Zenoh router, against holders and a
navigator stood in by buses in this process (the fleet-level test runs the real ones:
tests/integration/test_estop.py)."""

from __future__ import annotations

import logging
from collections.abc import Iterator

import pytest

from shared.config import TransportConfig
from shared.estop import hold_estop
from shared.messages import Event, NavResume
from shared.topics import Keys
from shared.transport import Bus, open_session
from wheelnav.cli import main

KEYS = Keys("chair1")


def client(endpoint: str, name: str) -> Bus:
    return Bus(open_session(TransportConfig(mode="client", connect=[endpoint])), name)


@pytest.fixture
def holders(router) -> Iterator[tuple[str, dict]]:
    """A controller and a sim holding the stop, each with its liveliness token."""
    _bus, endpoint = router
    buses, latches = [], {}
    for name in ("controller", "sim"):
        bus = client(endpoint, name)
        latches[name] = hold_estop(bus, KEYS, name, logging.getLogger(name))
        bus.declare_alive(KEYS.key("alive", service=name))
        buses.append(bus)
    try:
        yield endpoint, latches
    finally:
        for bus in buses:
            bus.close()


def test_stop_is_confirmed_by_every_live_holder_and_clear_too(holders, capsys) -> None:
    endpoint, latches = holders
    code = main(["stop", "--connect", endpoint, "--reason", "test", "--timeout", "20"])
    out = capsys.readouterr().out
    assert code == 0, out
    assert "emergency stop set: acknowledged by controller, sim" in out
    assert "controller: stopped (by wheelnav stop (" in out and ": test)" in out
    assert "controller status: none heard" in out  # no clock runs here: said, not hidden
    assert latches["controller"].active and latches["sim"].active
    code = main(["stop", "--clear", "--connect", endpoint, "--timeout", "20"])
    out = capsys.readouterr().out
    assert code == 0, out
    assert "emergency stop cleared: acknowledged by controller, sim" in out
    assert "wheelnav resume" in out  # a paused mission needs its own request
    assert not latches["controller"].active and not latches["sim"].active


def test_a_live_holder_that_does_not_answer_is_named(holders, capsys) -> None:
    endpoint, _latches = holders
    mute = client(endpoint, "navigator")  # alive, but holds no stop
    mute.declare_alive(KEYS.key("alive", service="navigator"))
    try:
        code = main(["stop", "--connect", endpoint, "--timeout", "2"])
    finally:
        mute.close()
    out = capsys.readouterr().out
    assert code == 1
    assert "navigator: no answer" in out and "not acknowledged by navigator within 2 s" in out


def test_stop_with_no_holder_alive_says_so(router, capsys) -> None:
    _bus, endpoint = router
    assert main(["stop", "--connect", endpoint, "--timeout", "2"]) == 1
    assert "no service that obeys it is alive" in capsys.readouterr().out


def test_resume_prints_the_navigators_answer(router, capsys) -> None:
    _bus, endpoint = router
    navigator = client(endpoint, "navigator")
    refused = [False]

    def on_resume(msg: NavResume) -> None:  # refuses once, then resumes
        kind, why = (
            ("resume", f"mission g1 resumed by {msg.source}")
            if refused[0]
            else ("resume_refused", f"asked by {msg.source}: the rider still holds the joystick")
        )
        refused[0] = True
        navigator.publish(
            KEYS.key("events", source="navigator"), Event(1.0, "navigator", kind, why)
        )

    navigator.subscribe(KEYS.nav_resume, NavResume, on_resume)
    try:
        assert main(["resume", "--connect", endpoint, "--timeout", "20"]) == 1
        assert "not resumed: asked by wheelnav resume (" in capsys.readouterr().out
        assert main(["resume", "--connect", endpoint, "--timeout", "20"]) == 0
        assert "mission g1 resumed by wheelnav resume (" in capsys.readouterr().out
    finally:
        navigator.close()
    assert main(["resume", "--connect", endpoint, "--timeout", "1"]) == 1
    assert "no answer from the navigator within 1 s" in capsys.readouterr().out
