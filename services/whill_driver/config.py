"""The WHILL driver's settings: the fleet config's ``whill`` section (shared/config.py)."""

from __future__ import annotations

import dataclasses

from shared.config import FleetConfig, WhillConfig

__all__ = ["WhillConfig", "whill_section"]


def whill_section(fleet: FleetConfig) -> WhillConfig:
    """A copy of the fleet config's ``whill`` section (the driver may adjust its own)."""
    return dataclasses.replace(fleet.whill)
