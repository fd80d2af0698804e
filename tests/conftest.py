"""Shared fixtures: a real Zenoh router on a free loopback port."""

from __future__ import annotations

import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from hypothesis import settings

from shared.transport import Bus
from wheelnav.launcher.supervisor import open_router
from wheelnav.mission.run import free_port

ROOT = Path(__file__).resolve().parents[1]
PYTHON = sys.executable

# Property tests draw the same examples on every run (reproducible CI); derandomize also
# turns the example database off, so a found failure belongs in an @example.
settings.register_profile("wheelnav", derandomize=True)
settings.load_profile("wheelnav")


@pytest.fixture
def router() -> Iterator[tuple[Bus, str]]:
    """A router session (the test's own bus) and the endpoint clients connect to."""
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    bus = open_router(endpoint)
    yield bus, endpoint
    bus.close()


def wheelnav(*args: str, timeout: float = 120) -> subprocess.CompletedProcess:
    """Run the ``wheelnav`` command as a user would, its output captured."""
    return subprocess.run(
        [PYTHON, "-m", "wheelnav.cli", *args],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=timeout,
    )


def start_up(
    *args: str, ready_s: float = 180
) -> tuple[subprocess.Popen, list[str], threading.Thread]:
    """Start ``wheelnav up ARGS`` and wait (at most ``ready_s``) until it says "fleet up";
    its output lines gather in the list, read by the thread."""
    up = subprocess.Popen(
        [PYTHON, "-m", "wheelnav.cli", "up", *args],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    lines: list[str] = []
    reader = threading.Thread(target=lambda: lines.extend(up.stdout), daemon=True)
    reader.start()
    deadline = time.monotonic() + ready_s
    while time.monotonic() < deadline and not any("fleet up" in ln for ln in lines):
        assert up.poll() is None, "".join(lines)
        time.sleep(0.1)
    return up, lines, reader


def stop_node(proc: subprocess.Popen, timeout: float) -> str:
    """Stop a service started on its own as the launcher does (SIGTERM, then SIGKILL if it
    outlasts ``timeout``); its stderr."""
    proc.terminate()
    try:
        _out, err = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        proc.kill()
        _out, err = proc.communicate(timeout=timeout)
    return err


def eventually(predicate, timeout_s: float = 10.0) -> bool:
    """Whether ``predicate()`` holds within ``timeout_s`` of wall time (polled)."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(0.01)
    return predicate()
