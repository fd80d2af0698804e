"""Inflate an occupancy grid by the robot radius and add a soft cost band around obstacles.

Pure functions: no I/O, no clock. Distances come from ``scipy.ndimage.distance_transform_edt``
and are measured in metres from cell centre to cell centre.
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import distance_transform_edt


def obstacle_distance(occupied: np.ndarray, resolution: float) -> np.ndarray:
    """Euclidean distance in metres from each cell to the nearest occupied cell (0 on obstacles).

    Cells of a grid with no obstacle at all get ``inf``.
    """
    occ = np.asarray(occupied, dtype=bool)
    if occ.ndim != 2:
        raise ValueError(f"occupied must be a 2-D array, got shape {occ.shape}")
    if not resolution > 0:
        raise ValueError(f"resolution must be > 0, got {resolution}")
    if not occ.any():
        return np.full(occ.shape, np.inf)
    return distance_transform_edt(~occ, sampling=float(resolution))


def inflate(
    occupied: np.ndarray,
    resolution: float,
    radius_m: float,
    cost_band_m: float = 0.0,
    cost_scaling: float = 10.0,
) -> tuple[np.ndarray, np.ndarray]:
    """Return ``(lethal, cost)`` for a boolean occupancy grid.

    ``lethal`` is True where the distance to the nearest occupied cell is < ``radius_m``
    (occupied cells are always lethal), so a disc robot of that radius centred on any other
    cell is collision-free. ``cost`` (float32, >= 0) is the extra traversal cost per cell:
    ``exp(-cost_scaling * (d - radius_m))`` for ``radius_m <= d < radius_m + cost_band_m``
    (a Nav2-style band that keeps paths away from walls), 0 elsewhere and on lethal cells.
    """
    occ = np.asarray(occupied, dtype=bool)
    dist = obstacle_distance(occ, resolution)
    lethal = (dist < radius_m) | occ
    cost = np.zeros(occ.shape, dtype=np.float32)
    if cost_band_m > 0:
        band = ~lethal & (dist < radius_m + cost_band_m)
        cost[band] = np.exp(-cost_scaling * (dist[band] - radius_m))
    return lethal, cost
