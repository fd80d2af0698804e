"""Where to stand before a door and where the pass through it ends, from the space there.

The seed used fixed distances (2.5 m before, 2.2 m through); in a small room, a corridor
or between two doors in series those poses land inside a wall's or a cupboard's stop
zone and the chair stands still. Here both come from the free depth along the door's
normal, measured on the map in a strip as wide as the chair's clearance (other doors
counted as closed):

- approach: ``preferred_m`` before the door plane if the chair's rear (plus ``margin_m``)
  fits, never so close that its front reaches the plane;
- exit: ``preferred_m`` past the plane if the chair's front plus the controller's stop
  distance (plus ``margin_m``) still fits, never so short that its rear is still in the
  doorway.

Pure: a bool occupancy grid in, distances out.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# a chair whose front waits nearer than a leaf's length and this to the door plane is in
# the leaf's sweep: the pose's tolerance (0.15 m), the leaf's thickness and a clearance
# (campaign b1005.m00: a leaf passed 3 cm from a chair whose front was 2.5 cm outside it)
LEAF_CLEAR_M = 0.25


@dataclass(frozen=True)
class PoseRoom:
    """What the chair needs around a door pose (metres from the rear-axle pose point)."""

    front_m: float
    rear_m: float
    half_width_m: float  # the chair's clearance half width
    stop_m: float  # the controller's stop distance ahead of the front
    margin_m: float = 0.05


def free_depth(
    occ: np.ndarray,
    resolution: float,
    origin: tuple[float, float],
    centre: np.ndarray,
    direction: np.ndarray,
    half_width_m: float,
    max_m: float,
    doorway: tuple[float, float] = (0.0, 0.0),
) -> float:
    """How far from ``centre`` along unit ``direction`` a strip ``half_width_m`` each side
    stays free on ``occ`` (row 0 at ``origin``'s y); ``max_m`` if it does all the way.

    ``doorway`` (half width, depth): for its first ``depth`` metres the strip is at most
    that half width, so a doorway narrower than the strip, or whose jambs the map draws a
    cell or two into the opening, is not a wall."""
    step = resolution / 2
    along = np.arange(step, max_m + step, step)
    edge = half_width_m - 1e-6  # a strip that touches a cell's edge does not enter it
    across = np.append(np.arange(-edge, edge, step), edge)
    side = np.array([-direction[1], direction[0]])
    pts = (
        centre[None, None, :]
        + along[:, None, None] * direction[None, None, :]
        + across[None, :, None] * side[None, None, :]
    )
    cols = np.floor((pts[..., 0] - origin[0]) / resolution).astype(int)
    rows = np.floor((pts[..., 1] - origin[1]) / resolution).astype(int)
    outside = (rows < 0) | (cols < 0) | (rows >= occ.shape[0]) | (cols >= occ.shape[1])
    hit = outside | occ[np.clip(rows, 0, occ.shape[0] - 1), np.clip(cols, 0, occ.shape[1] - 1)]
    inner_half, inner_depth = doorway
    hit &= ~((along[:, None] <= inner_depth) & (np.abs(across)[None, :] > inner_half))
    blocked = np.flatnonzero(hit.any(axis=1))
    return float(along[blocked[0]] - step) if len(blocked) else float(max_m)


def approach_distance(
    depth_before_m: float, preferred_m: float, room: PoseRoom, leaf_m: float = 0.0
) -> float:
    """How far before the door plane the pose point stands: ``preferred_m`` if the rear
    fits, else as far back as it fits, but never with the front past the plane, nor
    within the sweep of a hinged leaf ``leaf_m`` long that opens towards the chair (nor
    within ``LEAF_CLEAR_M`` of it) when the rear still fits behind it."""
    least = room.front_m + room.margin_m
    behind_leaf = room.front_m + leaf_m + LEAF_CLEAR_M
    if leaf_m > 0 and behind_leaf + room.rear_m + room.margin_m <= depth_before_m:
        least = behind_leaf
    most = depth_before_m - room.rear_m - room.margin_m
    return max(least, min(preferred_m, most))


def exit_distance(depth_after_m: float, preferred_m: float, room: PoseRoom) -> float:
    """How far past the door plane the pass ends: ``preferred_m`` if the front and the stop
    zone fit, else as far as they fit, but never with the rear still in the doorway."""
    least = room.rear_m + room.margin_m
    most = depth_after_m - room.front_m - room.stop_m - room.margin_m
    return max(least, min(preferred_m, most))
