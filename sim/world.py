"""The pybullet world built from a site floor: walls extruded from occupied cells.

Occupied cells are merged into few axis-aligned boxes (runs per row, extended over rows
while they repeat), so a large map loads as hundreds of bodies, not millions.
"""

from __future__ import annotations

import numpy as np
import pybullet as pb

from shared.site import GridMap

WALL_HEIGHT_M = 2.2


def merge_boxes(occ: np.ndarray) -> list[tuple[int, int, int, int]]:
    """Cover the True cells of ``occ`` with rectangles ``(row0, col0, row1, col1)`` (exclusive)."""
    boxes: list[tuple[int, int, int, int]] = []
    open_runs: dict[tuple[int, int], int] = {}
    rows = occ.shape[0]
    for r in range(rows + 1):
        runs: set[tuple[int, int]] = set()
        if r < rows:
            line = np.concatenate([[False], occ[r], [False]]).astype(np.int8)
            edges = np.flatnonzero(np.diff(line))
            runs = {(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2], strict=True)}
        for run in list(open_runs):
            if run not in runs:
                boxes.append((open_runs.pop(run), run[0], r, run[1]))
        for run in runs:
            open_runs.setdefault(run, r)
    return boxes


class World:
    """A pybullet DIRECT client holding the walls of one or more floors, stacked."""

    def __init__(
        self, grid: GridMap, unknown_is_occupied: bool = True, elevation: float = 0.0
    ) -> None:
        self.client = pb.connect(pb.DIRECT)
        self.grid = grid
        self.wall_ids: set[int] = set()
        self.add_floor(grid, elevation, unknown_is_occupied)

    def add_floor(self, grid: GridMap, elevation: float, unknown_is_occupied: bool = True) -> None:
        """Extrude ``grid``'s occupied cells into wall boxes standing at ``elevation``."""
        res = grid.resolution
        ox, oy = grid.origin[0], grid.origin[1]
        for r0, c0, r1, c1 in merge_boxes(grid.occupied(unknown_is_occupied)):
            half = [(c1 - c0) * res / 2, (r1 - r0) * res / 2, WALL_HEIGHT_M / 2]
            centre = [
                ox + (c0 + c1) * res / 2,
                oy + (r0 + r1) * res / 2,
                elevation + WALL_HEIGHT_M / 2,
            ]
            shape = pb.createCollisionShape(
                pb.GEOM_BOX, halfExtents=half, physicsClientId=self.client
            )
            body = pb.createMultiBody(0, shape, basePosition=centre, physicsClientId=self.client)
            self.wall_ids.add(body)

    def close(self) -> None:
        if pb.isConnected(self.client):
            pb.disconnect(self.client)
