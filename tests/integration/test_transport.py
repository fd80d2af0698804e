"""Pub/sub, request/response and bad-message handling between two real processes."""

from __future__ import annotations

import subprocess
import threading
import time

from shared.messages import Event, Pose2D, RouteReply, RouteRequest, Twist
from tests.conftest import PYTHON, ROOT


def start_peer(endpoint: str, bus) -> subprocess.Popen:
    proc = subprocess.Popen(
        [PYTHON, "-m", "tests.integration.peer", "--connect", endpoint],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline and not bus.alive("test/alive/*", 0.5):
        assert proc.poll() is None, proc.stdout.read()
        time.sleep(0.1)
    assert bus.alive("test/alive/*"), "peer did not come up"
    return proc


def test_pubsub_request_and_bad_messages_across_processes(router) -> None:
    bus, endpoint = router
    got: list[Event] = []
    arrived = threading.Condition()

    def on_out(msg: Event) -> None:
        with arrived:
            got.append(msg)
            arrived.notify_all()

    bus.subscribe("test/out", Event, on_out)
    peer = start_peer(endpoint, bus)
    try:
        # request/response
        reply = bus.call(
            "test/echo", RouteRequest(Pose2D(0, 0, 0), place="room_b"), RouteReply, 5.0
        )
        assert reply.ok and reply.error == "room_b"

        # malformed payloads first, then a good one: the peer must survive and count them
        bus.session.put("test/in", b"\x00garbage")
        bus.session.put("test/in", b"")
        bus.publish("test/in", Event(0.0, "x", "wrong type"))
        time.sleep(0.2)
        bus.publish("test/in", Twist(1.0, 0.25, 0.0))
        with arrived:
            assert arrived.wait_for(lambda: got, timeout=10)
        assert got[0].detail == "v=0.25 bad=3"
        assert peer.poll() is None, "the subscriber process died on bad input"

        # and it keeps working afterwards
        bus.publish("test/in", Twist(2.0, 0.5, 0.0))
        with arrived:
            assert arrived.wait_for(lambda: len(got) >= 2, timeout=10)
        assert got[1].detail == "v=0.5 bad=3"
    finally:
        peer.terminate()
        out, _ = peer.communicate(timeout=10)
    assert "dropped bad message on test/in" in out


def test_request_to_nobody_times_out_with_one_line(router) -> None:
    bus, _ = router
    errors: list[str] = []
    done = threading.Event()
    bus.request(
        "test/nobody",
        RouteRequest(Pose2D(0, 0, 0)),
        RouteReply,
        0.5,
        lambda reply, err: (errors.append(err), done.set()),
    )
    assert done.wait(5)
    assert "no answer from test/nobody" in errors[0]
