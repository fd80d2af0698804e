"""Shared fixtures: a real Zenoh router on a free loopback port."""

from __future__ import annotations

import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from services.launcher.node import open_router
from services.mission.node import free_port
from shared.transport import Bus

ROOT = Path(__file__).resolve().parents[1]
PYTHON = sys.executable


@pytest.fixture
def router() -> Iterator[tuple[Bus, str]]:
    """A router session (the test's own bus) and the endpoint clients connect to."""
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    bus = open_router(endpoint)
    yield bus, endpoint
    bus.close()
