"""PNG pictures of a planned route and of a floor's rooms (Pillow only).

North is up: map row 0 (the bottom) is the picture's last block of rows. Each cell is a
square of ``scale`` pixels (``SCALE`` = 4, smaller only where a side would pass
``MAX_SIDE_PX``), so cell (row, col) covers pixel rows ``(rows - 1 - row) * scale`` up to
the next multiple and pixel columns ``col * scale`` likewise. Fixed colours (RGB):

- ``WALL`` (40, 40, 40): occupied in the map; ``UNKNOWN`` (110, 110, 110); ``FREE``
  (240, 240, 240).
- ``INFLATED`` (255, 190, 190): free in the map but lethal for the planner (within the
  inflation radius of an obstacle, or under an open door leaf).
- ``PATH`` (0, 0, 255): every cell the planned path passes through, drawn last.
- ``CHECKPOINT`` (255, 140, 0): a door's segment and rings at its approach and exit
  poses; ``START`` (0, 170, 0) and ``GOAL`` (200, 0, 0) discs, under the path.
- Rooms: each room's cells in its own light colour; ``DOOR`` (255, 0, 255) marks doors.
"""

from __future__ import annotations

import colorsys
import math
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

from shared.site import GridMap
from wheelnav.maptools.plan import PlanResult
from wheelnav.maptools.rooms import FloorRooms

SCALE = 4
MAX_SIDE_PX = 8000
WALL = (40, 40, 40)
UNKNOWN = (110, 110, 110)
FREE = (240, 240, 240)
INFLATED = (255, 190, 190)
PATH = (0, 0, 255)
CHECKPOINT = (255, 140, 0)
START = (0, 170, 0)
GOAL = (200, 0, 0)
DOOR = (255, 0, 255)


def picture_scale(grid: GridMap) -> int:
    """Pixels per cell: ``SCALE``, less for a map whose picture would be too large."""
    return max(1, min(SCALE, MAX_SIDE_PX // max(grid.shape)))


def plan_picture(result: PlanResult, path: str | Path) -> int:
    """Write the route's picture to ``path``; returns the pixels per cell."""
    grid = result.grid
    colours = _base(grid)
    colours[result.lethal & ~grid.occupied(True)] = INFLATED
    scale = picture_scale(grid)
    image = _upscale(colours, scale)
    draw = ImageDraw.Draw(image)
    px = _Pixels(grid, scale)
    marker = max(3, round(0.15 / grid.resolution * scale))
    for cp in result.checkpoints:
        heading = cp.approach[2]
        half = cp.width_m / 2
        dx, dy = -math.sin(heading) * half, math.cos(heading) * half
        a = px((cp.centre[0] - dx, cp.centre[1] - dy))
        b = px((cp.centre[0] + dx, cp.centre[1] + dy))
        draw.line([a, b], fill=CHECKPOINT, width=max(2, scale))
        for pose in (cp.approach, cp.exit):
            _disc(draw, px(pose[:2]), marker, outline=CHECKPOINT)
    _disc(draw, px(result.start), marker, fill=START)
    _disc(draw, px(result.goal), marker, fill=GOAL)
    for r, c in path_cells(grid, result.path):
        top, left = (grid.shape[0] - 1 - r) * scale, c * scale
        draw.rectangle([left, top, left + scale - 1, top + scale - 1], fill=PATH)
    image.save(path, format="PNG")
    return scale


def rooms_picture(floor: FloorRooms, path: str | Path) -> int:
    """Write the floor's rooms picture to ``path``; returns the pixels per cell."""
    grid = floor.grid
    colours = _base(grid)
    labels = floor.room_map.labels
    for i, room in enumerate(floor.rooms):
        colours[labels == room.id] = room_colour(i)
    scale = picture_scale(grid)
    image = _upscale(colours, scale)
    draw = ImageDraw.Draw(image)
    px = _Pixels(grid, scale)
    marker = max(3, round(0.1 / grid.resolution * scale))
    for door in floor.doors:
        draw.line([px(door.p1), px(door.p2)], fill=DOOR, width=max(2, scale))
        _disc(draw, px(door.center), marker, fill=DOOR)
    image.save(path, format="PNG")
    return scale


def room_colour(i: int) -> tuple[int, int, int]:
    """A light colour for the ``i``-th room, hues a golden angle apart (none repeats)."""
    hue = (0.13 + i * 0.618033988749895) % 1.0
    r, g, b = colorsys.hsv_to_rgb(hue, 0.45, 0.95)
    return round(r * 255), round(g * 255), round(b * 255)


def path_cells(grid: GridMap, path: np.ndarray) -> list[tuple[int, int]]:
    """The cells (row, col) the polyline ``path`` passes through, sampled finely."""
    cells: dict[tuple[int, int], None] = {}
    step = grid.resolution / 4
    for a, b in zip(path[:-1], path[1:], strict=True):
        n = max(1, math.ceil(float(np.linalg.norm(b - a)) / step))
        for t in np.linspace(0.0, 1.0, n + 1):
            cell = grid.to_cell(*(a + (b - a) * t))
            if grid.contains(*cell):
                cells[cell] = None
    if len(path) == 1 and grid.contains(*grid.to_cell(*path[0])):
        cells[grid.to_cell(*path[0])] = None
    return list(cells)


class _Pixels:
    """World (x, y) to picture (x, y) pixel coordinates: north up, ``scale`` px per cell."""

    def __init__(self, grid: GridMap, scale: int) -> None:
        self.grid, self.scale = grid, scale

    def __call__(self, xy) -> tuple[float, float]:
        g = self.grid
        col = (xy[0] - g.origin[0]) / g.resolution
        row = (xy[1] - g.origin[1]) / g.resolution
        return col * self.scale, (g.shape[0] - row) * self.scale


def _base(grid: GridMap) -> np.ndarray:
    """(rows, cols, 3) colours of the map: walls, unknown and free, row 0 at the bottom."""
    colours = np.empty((*grid.shape, 3), dtype=np.uint8)
    colours[:] = FREE
    colours[grid.cells < 0] = UNKNOWN
    colours[grid.occupied(False)] = WALL
    return colours


def _upscale(colours: np.ndarray, scale: int) -> Image.Image:
    """The picture of per-cell colours: flipped north up, each cell ``scale`` px square."""
    pixels = np.repeat(np.repeat(np.flipud(colours), scale, axis=0), scale, axis=1)
    return Image.fromarray(np.ascontiguousarray(pixels))


def _disc(draw: ImageDraw.ImageDraw, centre, radius: float, fill=None, outline=None) -> None:
    x, y = centre
    box = [x - radius, y - radius, x + radius, y + radius]
    draw.ellipse(box, fill=fill, outline=outline, width=2)
