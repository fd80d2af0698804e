"""A launcher killed with SIGKILL leaves nothing running: its router process and its
services notice they lost their parent and stop (campaign stopped from outside in
session 11: seven routers and their services ran on as orphans)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

from tests.conftest import ROOT, free_port

# the launcher's part, in a process of its own: a router child and a supervised service
PARENT = """
import sys, time
from shared.config import LauncherConfig
from wheelnav.launcher.fleet import ServiceSpec
from wheelnav.launcher.router import RouterProcess
from wheelnav.launcher.supervisor import Supervisor

endpoint = sys.argv[1]
router = RouterProcess(endpoint)
router.start()
spec = ServiceSpec("probe", "tests.integration.probe_service", (), "a probe")
sup = Supervisor([spec], endpoint, LauncherConfig(), None, out=open("/dev/null", "w"))
sup.start()
while sup.pid("probe") is None:
    time.sleep(0.1)
print(router.proc.pid, sup.pid("probe"), flush=True)
time.sleep(600)
"""


def running(pid: int) -> bool:
    """True while ``pid`` exists and is not a zombie (an orphan's new parent may not reap)."""
    stat = Path(f"/proc/{pid}/stat")
    try:
        return stat.read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except (FileNotFoundError, ProcessLookupError, IndexError):
        return False


def test_router_and_services_stop_when_their_launcher_is_killed() -> None:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    parent = subprocess.Popen(
        [sys.executable, "-c", PARENT, endpoint],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        text=True,
        env=dict(os.environ, PYTHONPATH=str(ROOT)),
    )
    children: list[int] = []
    try:
        line = parent.stdout.readline()
        children = [int(p) for p in line.split()]
        assert len(children) == 2 and all(running(p) for p in children), line
        parent.send_signal(signal.SIGKILL)
        parent.wait(10)
        deadline = time.monotonic() + 30.0
        while time.monotonic() < deadline and any(running(p) for p in children):
            time.sleep(0.2)
        left = [p for p in children if running(p)]
        assert not left, f"still running after their launcher was killed: {left}"
    finally:
        for pid in children:
            if running(pid):
                os.kill(pid, signal.SIGKILL)
        if parent.poll() is None:
            parent.kill()
