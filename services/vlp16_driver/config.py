"""The VLP-16 driver's settings: the fleet config's ``vlp16`` section (shared/config.py)."""

from __future__ import annotations

from shared.config import FleetConfig, Vlp16Config

__all__ = ["Vlp16Config", "vlp16_section"]


def vlp16_section(fleet: FleetConfig) -> Vlp16Config:
    """The fleet config's ``vlp16`` section."""
    return fleet.vlp16
