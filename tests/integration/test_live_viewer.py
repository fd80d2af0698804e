"""A laptop watches a running fleet live: ``wheelnav viz --connect ... --viewer URL`` streams
to a rerun viewer the user started. The viewer here is a stand-in, ``rerun --save``: the
real rerun binary, receiving on its gRPC port and writing what arrives to a file, which is
then read back (entities the fleet's topics feed, and the layout)."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

from tests.conftest import ROOT, free_port
from tests.services.viz.test_blueprint import recorded

RERUN = shutil.which("rerun") or str(Path(sys.executable).with_name("rerun"))


class Proc:
    """A child process whose output lines are collected as they come."""

    def __init__(self, *cmd: str, cwd: Path = ROOT, group: bool = False) -> None:
        # group: the command starts children of its own (the ``rerun`` script runs the
        # viewer's binary), stopped with it; they outlived the test before
        self.group = group
        self.proc = subprocess.Popen(
            cmd,
            cwd=cwd,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
            start_new_session=group,
        )
        self.lines: list[str] = []
        threading.Thread(target=lambda: self.lines.extend(self.proc.stdout), daemon=True).start()

    def wait_for(self, text: str, timeout_s: float) -> None:
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline and not any(text in ln for ln in self.lines):
            assert self.proc.poll() is None, self.text()
            time.sleep(0.1)
        assert any(text in ln for ln in self.lines), self.text()

    def stop(self, timeout_s: float = 30.0) -> int:
        if self.proc.poll() is None:
            self._signal(signal.SIGINT)
        try:
            return self.proc.wait(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            return self.proc.wait()
        finally:
            if self.group:
                self._signal(signal.SIGKILL)  # whatever of the group is left

    def _signal(self, sig: int) -> None:
        try:
            if self.group:
                os.killpg(self.proc.pid, sig)
            else:
                self.proc.send_signal(sig)
        except ProcessLookupError:
            pass

    def text(self) -> str:
        return "".join(self.lines)[-3000:]


def wheelnav(*args: str) -> Proc:
    return Proc(sys.executable, "-m", "wheelnav.cli", *args)


def test_a_viewer_receives_the_live_stream_of_a_running_fleet(tmp_path) -> None:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    port = free_port()
    rrd = tmp_path / "live.rrd"
    fleet = wheelnav("up", "--listen", endpoint)
    viewer = viz = None
    try:
        fleet.wait_for("fleet up", 90)
        viewer = Proc(RERUN, "--port", str(port), "--save", str(rrd), cwd=tmp_path, group=True)
        viewer.wait_for("Listening for gRPC", 30)
        url = f"rerun+http://127.0.0.1:{port}/proxy"
        viz = wheelnav("viz", "--connect", endpoint, "--viewer", url)
        viz.wait_for("ready: wheelnav/chair1/alive/viz", 60)
        go = subprocess.run(
            [sys.executable, "-m", "wheelnav.cli", "go", "room_b", "--connect", endpoint],
            cwd=ROOT,
            capture_output=True,
            text=True,
            timeout=60,
        )
        assert go.returncode == 0, go.stdout + go.stderr
        time.sleep(8.0)  # wall time: the fleet runs on, the stream flows
        assert viz.stop() == 0, viz.text()
        time.sleep(1.0)
        viewer.stop()
    finally:
        for proc in (viz, viewer):
            if proc is not None:
                proc.stop()
        fleet.stop()
    rows, views, timeline, _reader = recorded(rrd)
    for entity in ("world/map", "world/chair/pose", "world/chair/scan", "world/route/legs"):
        assert rows.get(entity, 0) > 0, (entity, sorted(rows))
    assert rows.get("status/nav", 0) > 0 and rows.get("status/tree_graph", 0) > 0, sorted(rows)
    assert views and timeline == ["sim"], (sorted(views), timeline)
