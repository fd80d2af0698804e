"""Shared fixtures: a real Zenoh router on a free loopback port."""

from __future__ import annotations

import sys
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
