"""Draw simple buildings into map_server maps: walls as rectangles, doorways as gaps.

Used to (re)generate the bundled sites and the maps of tests, so every bundled map can
be rebuilt from its description: ``python -m sim.buildings two_rooms sites/two_rooms``.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

import numpy as np
import yaml
from PIL import Image

Rect = tuple[float, float, float, float]  # x0, y0, x1, y1 in metres


def draw(
    size: tuple[float, float],
    walls: Iterable[Rect],
    gaps: Iterable[Rect] = (),
    resolution: float = 0.05,
) -> np.ndarray:
    """A bool grid (row 0 at the bottom) with ``walls`` filled and ``gaps`` cut out again."""
    rows, cols = round(size[1] / resolution), round(size[0] / resolution)
    occ = np.zeros((rows, cols), dtype=bool)
    for value, rects in ((True, walls), (False, gaps)):
        for x0, y0, x1, y1 in rects:
            c0, c1 = round(x0 / resolution), round(x1 / resolution)
            r0, r1 = round(y0 / resolution), round(y1 / resolution)
            occ[max(r0, 0) : max(r1, 0), max(c0, 0) : max(c1, 0)] = value
    return occ


def write_map(
    occ: np.ndarray,
    folder: Path,
    stem: str,
    resolution: float = 0.05,
    origin: tuple[float, float, float] = (0.0, 0.0, 0.0),
) -> Path:
    """Write ``occ`` as ``stem.pgm`` + ``stem.yaml`` (map_server format); returns the YAML path."""
    folder.mkdir(parents=True, exist_ok=True)
    pixels = np.where(np.flipud(occ), 0, 254).astype(np.uint8)
    Image.fromarray(pixels).save(folder / f"{stem}.pgm")
    meta = {
        "image": f"{stem}.pgm",
        "resolution": resolution,
        "origin": list(origin),
        "negate": 0,
        "occupied_thresh": 0.65,
        "free_thresh": 0.196,
    }
    path = folder / f"{stem}.yaml"
    path.write_text(yaml.safe_dump(meta, sort_keys=False))
    return path


def two_rooms(folder: Path) -> None:
    """Two 6 m x 5 m rooms joined by an open 1.0 m doorway, a table in the second room."""
    t = 0.2
    w, h = 12.4, 5.4
    walls = [
        (0, 0, w, t),
        (0, h - t, w, h),
        (0, 0, t, h),
        (w - t, 0, w, h),
        (6.1, 0, 6.3, h),
        (8.5, 0.8, 9.3, 1.6),
    ]
    gaps = [(6.1, 2.2, 6.3, 3.2)]
    write_map(draw((w, h), walls, gaps), folder, "floor1")
    site = {
        "name": "two_rooms",
        "floors": [{"name": "1", "elevation": 0.0, "map": "floor1.yaml"}],
        "doors": [
            {"id": "door_ab", "floor": "1", "p1": [6.2, 2.2], "p2": [6.2, 3.2], "type": "manual"}
        ],
        "places": {
            "room_a": {"floor": "1", "x": 2.0, "y": 2.7, "theta": 0.0},
            "room_b": {"floor": "1", "x": 10.5, "y": 2.7, "theta": 0.0},
        },
    }
    (folder / "site.yaml").write_text(yaml.safe_dump(site, sort_keys=False))


SITES = {"two_rooms": two_rooms}
