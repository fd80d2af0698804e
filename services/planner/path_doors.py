"""Doors along a path: the doors a path crosses, on a map without door annotations.

The route planner (:mod:`services.planner.routes`) makes a checkpoint of every declared
door its path crosses; on a floor whose site declares no doors, it takes the doors that
:func:`detect_doors_along_path` finds along its raw A* path instead. Only the part of the
map near the path is read and only the narrow stretches of the path are measured, with
the door test of :mod:`services.planner.passages` (the test room segmentation applies to
its cuts), so a corridor gives no detection. Pure (no I/O, no clock) and vectorised with
numpy/scipy. The grid is taken axis-aligned (the origin's yaw is ignored).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from services.planner.passages import (
    DOOR_DEPTH_MAX_M,
    FREE_STANDING_M,
    PROBE_M,
    WIDEN_M,
    as_point,
    cell_to_world,
    check_inputs,
    door_test_grids,
    measure,
    narrowest_chord,
    obstacle_grid,
)


@dataclass(frozen=True)
class PathDoor:
    """A narrow passage a path crosses; ``normal`` points the way the path goes through.

    ``index`` is the path segment (``path_xy[index]`` to ``path_xy[index + 1]``) where the
    path crosses the door line and ``distance`` the path length up to there, in metres.
    """

    centre: tuple[float, float]
    width: float
    normal: tuple[float, float]
    p1: tuple[float, float]
    p2: tuple[float, float]
    index: int
    distance: float


def detect_doors_along_path(
    occupied: np.ndarray,
    resolution: float,
    origin: tuple[float, ...],
    path_xy: np.ndarray,
    min_door_m: float = 0.7,
    max_door_m: float = 1.8,
) -> list[PathDoor]:
    """The doors a path crosses on a map without door annotations, in path order.

    ``path_xy`` is an (N, 2) array of world points (a raw A* path will do); ``occupied`` a
    bool grid, row 0 at the bottom (unknown cells should count as occupied), and
    ``origin`` the world (x, y[, yaw]) of its lower-left corner. The path is sampled every
    cell; where it runs close to walls, the narrowest chord through each sample (rays in
    36 directions) marks the narrow stretches, and the samples where that chord is least
    or changes are measured with the door test (:func:`services.planner.passages.measure`:
    an opening of ``[min_door_m, max_door_m]`` in a wall, short, opening up on both sides,
    no furniture), so a corridor gives no detection. Returns one record per crossing of a
    door line between its jambs; detections of one passage from several samples are
    merged, and a path that wiggles through a door line counts once (or not at all if it
    turns back).
    """
    occupied = np.asarray(occupied, dtype=bool)
    check_inputs(occupied, resolution, min_door_m, max_door_m)
    path = np.asarray(path_xy, dtype=float).reshape(-1, 2)
    if len(path) < 2:
        return []
    res = resolution
    # Work on the part of the map the rays can reach from the path (plus room to tell
    # furniture from walls), padded with a frame of obstacles.
    cells = np.stack(
        [(path[:, 1] - origin[1]) / res - 0.5, (path[:, 0] - origin[0]) / res - 0.5], axis=1
    )
    reach = DOOR_DEPTH_MAX_M + PROBE_M + 2 * (max_door_m + WIDEN_M) + FREE_STANDING_M + 1.0
    margin = int(np.ceil(reach / res))
    lo = np.maximum(np.floor(cells.min(axis=0)).astype(int) - margin, 0)
    hi = np.minimum(np.ceil(cells.max(axis=0)).astype(int) + margin + 1, occupied.shape)
    if np.any(lo >= hi):
        return []
    occ = obstacle_grid(occupied[lo[0] : hi[0], lo[1] : hi[1]], res)
    org = (float(origin[0]) + lo[1] * res, float(origin[1]) + lo[0] * res)
    rc = cells - lo + 1

    seg_len = np.hypot(*np.diff(rc, axis=0).T)
    cum = np.r_[0.0, np.cumsum(seg_len)]
    s = np.r_[np.arange(0.0, cum[-1], 1.0), cum[-1]]
    pts = np.stack([np.interp(s, cum, rc[:, 0]), np.interp(s, cum, rc[:, 1])], axis=1)
    seg = np.clip(np.searchsorted(cum, s, side="right") - 1, 0, len(path) - 2)

    cap = (max_door_m + WIDEN_M) / res + 2.0
    clear = ndimage.distance_transform_edt(~occ)
    r = np.clip(np.floor(pts + 0.5).astype(np.intp), 0, np.array(occ.shape) - 1)
    near = np.flatnonzero(clear[r[:, 0], r[:, 1]] <= (max_door_m / res + 1) / 2 + 1)
    if not len(near):
        return []
    _, chord = narrowest_chord(occ, pts[near], cap)
    is_narrow = chord <= max_door_m / res + 1.0
    narrow, chord = near[is_narrow], chord[is_narrow]
    if not len(narrow):
        return []
    # Seeds: the samples where the chord is narrowest within half a door depth (the first
    # of each run of equal minima, as along a corridor narrower than a door), and where
    # it changes (a door off such a corridor is wider than the corridor itself).
    full = np.full(len(pts), 4 * cap)
    full[narrow] = chord
    window = 2 * int(DOOR_DEPTH_MAX_M / 2 / res) + 1
    lowest = np.flatnonzero(full <= np.minimum(ndimage.minimum_filter1d(full, window), cap))
    lowest = lowest[np.r_[True, np.diff(lowest) > 1]]
    steps = np.flatnonzero(np.abs(np.diff(full)) >= 2.0)
    changes = np.r_[steps, steps + 1]
    seeds = np.union1d(lowest, changes[full[changes] <= cap])
    meas = measure(door_test_grids(occ, res, clear), pts[seeds], res, min_door_m, max_door_m)

    found: list[PathDoor] = []
    kept: list[tuple[np.ndarray, float]] = []
    doors = np.flatnonzero(meas.door)
    for k in doors[np.argsort(meas.width[doors], kind="stable")]:  # the narrowest first
        ctr, t, n, w = meas.centre[k], meas.t[k], meas.n[k], float(meas.width[k])
        if any(np.hypot(*(c - ctr)) < max(cw, w) / 2 for c, cw in kept):
            continue  # the same passage, found from another seed
        kept.append((ctr, w))
        f = (pts - ctr) @ n
        side = f >= 0
        between = np.minimum(np.abs((pts[:-1] - ctr) @ t), np.abs((pts[1:] - ctr) @ t))
        cross = np.flatnonzero((side[:-1] != side[1:]) & (between <= w / 2 + 1.0))
        # Crossings closer than a door's depth along the path are one wiggle through the
        # passage: an odd number of them is one passage (the way of the first), even none.
        wiggles = np.split(cross, np.flatnonzero(np.diff(s[cross]) * res > DOOR_DEPTH_MAX_M) + 1)
        xy = cell_to_world(np.stack([ctr, ctr - t * w / 2, ctr + t * w / 2]), res, org)
        for group in wiggles:
            if len(group) % 2 == 0:
                continue
            i = group[0]
            frac = f[i] / (f[i] - f[i + 1])
            found.append(
                PathDoor(
                    centre=as_point(xy[0]),
                    width=w * res,
                    normal=as_point((n if f[i + 1] > f[i] else -n)[::-1]),
                    p1=as_point(xy[1]),
                    p2=as_point(xy[2]),
                    index=int(seg[i]),
                    distance=float(s[i] + frac * (s[i + 1] - s[i])) * res,
                )
            )
    found.sort(key=lambda door: door.distance)
    return found
