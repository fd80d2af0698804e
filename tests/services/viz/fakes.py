"""A tiny two-floor site for the viz tests, built in memory (no files)."""

from __future__ import annotations

import pathlib

import numpy as np

from shared.site import Floor, GridMap, Place, Site


def tiny_site() -> Site:
    """Two floors of 1 x 0.8 m, a wall along the bottom, a place on each."""
    cells = np.zeros((8, 10), dtype=np.int8)
    cells[0, :] = 100
    floors = {
        name: Floor(
            name, 3.0 * i, GridMap(cells, 0.1, (0.0, 0.0, 0.0)), pathlib.Path(f"{name}.yaml")
        )
        for i, name in enumerate(("1", "2"))
    }
    places = {"a": Place("a", "1", 0.2, 0.4), "b": Place("b", "2", 0.8, 0.4)}
    return Site("tiny", pathlib.Path("."), floors, places=places)
