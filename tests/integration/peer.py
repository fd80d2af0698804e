"""A separate test process: subscribes, publishes and serves over a real router.

Run as ``python -m tests.integration.peer --connect ENDPOINT``. For every valid Twist on
``test/in`` it publishes an Event on ``test/out`` whose detail carries the speed and the
number of bad messages dropped so far; it answers RouteRequests on ``test/echo`` with a
RouteReply naming the requested place.
"""

from __future__ import annotations

import argparse
import signal
import threading

from shared.config import TransportConfig
from shared.messages import Event, RouteReply, RouteRequest, Twist
from shared.transport import Bus, open_session


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--connect", required=True)
    args = parser.parse_args()
    bus = Bus(open_session(TransportConfig(mode="client", connect=[args.connect])), "peer")
    stop = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_: stop.set())

    def on_twist(msg: Twist) -> None:
        bad = sum(bus.bad_messages.values())
        bus.publish("test/out", Event(msg.stamp, "peer", "got", f"v={msg.v} bad={bad}"))

    bus.subscribe("test/in", Twist, on_twist)
    bus.serve("test/echo", RouteRequest, lambda req: RouteReply(True, error=req.place))
    bus.declare_alive("test/alive/peer")
    print("peer ready", flush=True)
    stop.wait(60)
    bus.close()


if __name__ == "__main__":
    main()
