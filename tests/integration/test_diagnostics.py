"""Diagnostics over a real router: a service's counters per key, and its restarts as the
launcher counts them (a small service process, no simulator)."""

from __future__ import annotations

import os
import signal
import threading

from shared.config import LauncherConfig
from shared.messages import Diagnostics, Event, Twist
from shared.topics import Keys
from tests.integration.test_fleet import Capture
from wheelnav.launcher.fleet import ServiceSpec
from wheelnav.launcher.supervisor import Supervisor, wait_ready


def test_service_publishes_its_counters_and_restarts(router) -> None:
    bus, endpoint = router
    keys = Keys("chair1")
    latest: list[Diagnostics] = []
    seen = threading.Condition()

    def on_diag(msg: Diagnostics) -> None:
        with seen:
            latest.append(msg)
            seen.notify_all()

    def wait_for(pred, what: str, timeout: float = 15.0) -> Diagnostics:
        with seen:
            ok = seen.wait_for(lambda: latest and pred(latest[-1]), timeout=timeout)
        assert ok, (
            f"{what}: last diagnostics {latest[-1] if latest else None}; {''.join(out.lines)}"
        )
        return latest[-1]

    bus.subscribe(keys.key("diagnostics", service="probe"), Diagnostics, on_diag)
    out = Capture()
    spec = ServiceSpec("probe", "tests.integration.probe_service", (), "a probe")
    cfg = LauncherConfig(restart_backoff_s=0.2)
    sup = Supervisor([spec], endpoint, cfg, None, out=out)
    sup.start()
    try:
        assert not wait_ready(bus, keys, ["probe"], 30), "".join(out.lines)
        first = wait_for(lambda d: True, "first diagnostics")
        assert first.restarts == 0 and first.bad_messages == 0 and first.service == "probe"
        assert first.pid == sup.pid("probe")

        for payload in (b"\x00garbage", b"", b"\x93\x01\x02\x03"):
            bus.session.put(keys.cmd_vel, payload)
        bus.publish(keys.cmd_vel, Event(1.0, "test", "a valid message of the wrong type"))
        bus.publish(keys.cmd_vel, Twist(1.0, 0.3, 0.0))
        bus.publish(keys.cmd_vel, Twist(2.0, 0.2, 0.0))
        counted = wait_for(lambda d: d.messages_in >= 6, "six messages counted")
        by_key = {k.key: (k.messages_in, k.bad_messages) for k in counted.keys}
        assert by_key == {keys.cmd_vel: (6, 4)}
        assert (counted.messages_in, counted.bad_messages) == (6, 4)

        old = sup.pid("probe")
        os.kill(old, signal.SIGKILL)
        again = wait_for(lambda d: d.restarts == 1, "restart counted", timeout=30)
        assert again.pid not in (None, old) and again.pid == sup.pid("probe")
        assert again.messages_in == 0  # a new process counts from zero
    finally:
        sup.stop()
    text = "".join(out.lines)
    assert "dropped bad message on wheelnav/chair1/cmd_vel" in text
    assert "Traceback" not in text
