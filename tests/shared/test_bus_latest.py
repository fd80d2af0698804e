"""The bus's ``latest`` delivery on a real Zenoh router: a subscriber that falls behind
takes up the newest message, never a backlog; one that keeps up gets every message."""

from __future__ import annotations

import time

from shared.config import TransportConfig
from shared.messages import Clock
from shared.transport import Bus, open_session
from tests.shared.test_estop import wait_for

KEY = "wheelnav/test/clock"


def test_a_subscriber_that_falls_behind_takes_up_the_newest_tick(router) -> None:
    _router_bus, endpoint = router
    sub = Bus(open_session(TransportConfig(connect=[endpoint])), "sub")
    pub = Bus(open_session(TransportConfig(connect=[endpoint])), "pub")
    other = Bus(open_session(TransportConfig(connect=[endpoint])), "other")
    latest: list[int] = []
    every: list[int] = []
    seen: list[int] = []  # by another session, whose dispatcher is never held
    try:
        sub.subscribe(KEY, Clock, lambda c: latest.append(c.tick), latest=True)
        sub.subscribe(KEY, Clock, lambda c: every.append(c.tick))
        other.subscribe(KEY, Clock, lambda c: seen.append(c.tick))
        probe = 0
        while not latest or not seen:  # until the subscriptions reach the router
            pub.publish(KEY, Clock(0.0, probe, 0.02, 0))
            probe += 1
            time.sleep(0.05)
        wait_for(lambda: every and every[-1] == probe - 1, "the probes")
        latest.clear()
        every.clear()
        # in step: each tick is taken before the next comes, so none is skipped
        for tick in range(1000, 1010):
            pub.publish(KEY, Clock(0.0, tick, 0.02, 0))
            wait_for(lambda t=tick: latest and latest[-1] == t, f"tick {tick}")
        assert latest == list(range(1000, 1010))
        # behind: the dispatcher is busy (its lock held) while 100 ticks arrive
        with sub.lock:
            for tick in range(2000, 2100):
                pub.publish(KEY, Clock(0.0, tick, 0.02, 0))
            wait_for(lambda: seen and seen[-1] == 2099, "the ticks sent")
            time.sleep(0.2)  # and arrived at the held subscriber's queue (a few late: fine)
        wait_for(lambda: every and every[-1] == 2099, "the backlog delivered")
        behind = [t for t in latest if t >= 2000]
        assert every[-100:] == list(range(2000, 2100))  # the plain subscription: all of them
        assert behind[-1] == 2099 and len(behind) < 50, behind  # the latest one: the newest
    finally:
        for bus in (pub, sub, other):
            bus.close()
