"""Passages on an occupancy grid: rays, the narrowest chord, the jambs and the door test.

Room segmentation (:mod:`services.planner.room_segmentation`, at the cuts between basins)
and door detection along a path (:mod:`services.planner.path_doors`, at samples of the
path) ask the same question of a point of the map: is the passage there a door? The
door test, :func:`measure`, answers it for many points at once. It is pure (no I/O, no
clock) and vectorised with numpy/scipy: rays are cast on the grid in batches, and Python
loops run over passages, never over cells.

Measuring a passage, with rays on the grid:

- the narrowest chord within ``NEAR_M`` of the point (rays every 5 degrees) gives the
  passage and its door line;
- a walk along the door line's normal gives the passage depth (how far the cross-section
  stays that narrow) and the space on each side;
- the closest pair of obstacle cells across the passage gives the jambs, and the free
  width between them.

A passage is a **door** if

- its free width (between the jambs) is within ``[min_door_m, max_door_m]``;
- the passage is at most ``DOOR_DEPTH_MAX_M`` deep and the space opens up by ``WIDEN_M``
  within ``PROBE_M`` on both sides, beyond the same jamb at least;
- it is an opening in a wall: beyond one jamb at least, the wall runs on along the door
  line (not at a slant) for ``WALL_MIN_M`` and twice its thickness;
- the door line is clear of other obstacles, and neither jamb is furniture: an obstacle
  not joined to the outer walls and smaller than ``FREE_STANDING_M`` (a table, a pillar),
  unless it is a partition at most ``THIN_WALL_M`` thick running on along the door line
  (the wall between two doors).

So a corridor (a long passage of constant width) is no door, and corners, tables and
pillars make none.

The grid is read through :func:`obstacle_grid`: obstacle specks up to ``SPECK_M2`` are
ignored and a frame of obstacles is added around it (outside the grid counts as
obstacle). Cell coordinates are (row, col) in that padded grid, a cell's centre at
integer coordinates; :func:`cell_to_world` turns them into world (x, y). The grid is
taken axis-aligned (the origin's yaw is ignored).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

DOOR_DEPTH_MAX_M = 1.0  # deepest passage (wall plus frame) still a door; deeper = corridor
PROBE_M = 0.6  # how far beyond the passage the space on each side is examined
WIDEN_M = 0.3  # the space on each side must be this much wider than the opening
FREE_STANDING_M = 3.0  # obstacles apart from the outer walls and smaller than this: furniture
SPECK_M2 = 0.01  # obstacle specks up to this area (sensor noise, table legs) are ignored
WALL_MIN_M = 0.5  # a door's wall runs on this far (and 2x its thickness) beyond a jamb
THIN_WALL_M = 0.35  # a free-standing obstacle this thin, running on, is a wall (not furniture)
NEAR_M = 0.2  # how far from a cut's saddle (or a path sample) its passage is looked for

_N_DIRS = 36  # directions tried for the narrowest chord (every 5 degrees)
_COARSE = 0.5  # ray step (cells) of the searches
_NARROW_TOL = 2.0  # cells: a cross-section this much wider than the opening still counts
_BATCH = 1 << 22  # ray samples per batch (bounds the memory of the ray casts)


@dataclass
class Measurement:
    """The passages measured at M points (cells, padded grid) and the door test's verdicts."""

    door: np.ndarray  # (M,) bool: the passage passes the door test
    width: np.ndarray  # (M,) free width between the jambs (inf: no jambs found)
    centre: np.ndarray  # (M, 2) the middle of the door line
    t: np.ndarray  # (M, 2) unit vector along the door line
    n: np.ndarray  # (M, 2) unit normal of the door line
    depth: np.ndarray  # (M,) depth of the passage


def measure(
    grid: DoorTestGrids,
    pts: np.ndarray,
    res: float,
    min_door_m: float,
    max_door_m: float,
) -> Measurement:
    """Measure the passage at (or next to) each point and apply the door test (module doc).

    ``grid`` comes from :func:`door_test_grids`, ``pts`` are (M, 2) cell coordinates of
    the padded grid; ``res`` is the cell size and the door widths are in metres.

    The narrowest cross-section within ``NEAR_M`` of the point gives the passage and the
    door line; a walk along its normal finds the stretch where the
    cross-section stays that narrow (the passage, at most ``DOOR_DEPTH_MAX_M``) and checks
    that the space opens up by ``WIDEN_M`` within ``PROBE_M`` on both sides, beyond the
    same jamb at least; the jambs are then found exactly (:func:`_jambs`), and the door
    line between them must be clear of other obstacles.
    """
    occ = grid.occ
    m = len(pts)
    if m == 0:
        empty = np.zeros((0, 2))
        return Measurement(np.zeros(0, dtype=bool), np.zeros(0), empty, empty, empty, np.zeros(0))
    cap = (max_door_m + WIDEN_M) / res + 2.0
    depth_cells = DOOR_DEPTH_MAX_M / res
    reach = max(2, int(np.ceil(NEAR_M / res)))
    start = narrowest_nearby(occ, pts, reach, min_door_m / res - 1.0, cap)
    t, c0 = narrowest_chord(occ, start, cap)
    half = int(np.ceil((depth_cells + PROBE_M / res) / _COARSE))
    ahead, behind, n = _walk(occ, start, t, half, 2 * cap)
    chord = ahead + behind
    narrow = (chord > 0) & (chord <= c0[:, None] + _NARROW_TOL)
    left, right = ~narrow[:, half::-1], ~narrow[:, half:]
    ends = left.any(axis=1) & right.any(axis=1) & narrow[:, half]
    lo = half - left.argmax(axis=1) + 1
    hi = half + right.argmax(axis=1) - 1
    depth = (hi - lo + 1) * _COARSE
    idx = np.arange(chord.shape[1])[None, :]
    run = (idx >= lo[:, None]) & (idx <= hi[:, None])
    need = np.where(run, chord, np.inf).min(axis=1) + WIDEN_M / res
    # The space opens up on both sides, and beyond the same jamb on both sides at least
    # (a corridor between two staggered side doors opens beyond opposite jambs).
    # Only the free stretch next to the passage counts, not the space behind a wall.
    probe = int(np.ceil(PROBE_M / res / _COARSE))
    blocked = chord == 0
    wall_before = np.where(blocked & (idx < lo[:, None]), idx, -1).max(axis=1)
    wall_after = np.where(blocked & (idx > hi[:, None]), idx, chord.shape[1]).min(axis=1)
    sides = (
        (idx >= np.maximum(lo - probe, wall_before + 1)[:, None]) & (idx < lo[:, None]),
        (idx > hi[:, None]) & (idx <= np.minimum(hi + probe, wall_after - 1)[:, None]),
    )
    wide = chord >= need[:, None]
    beyond = [
        run_on - run_on[:, half : half + 1] >= WIDEN_M / 2 / res for run_on in (ahead, behind)
    ]
    opens = np.ones(m, dtype=bool)
    for side in sides:
        opens &= (wide & side).any(axis=1)
    same_end = np.zeros(m, dtype=bool)
    for end in beyond:
        same_end |= (end & sides[0]).any(axis=1) & (end & sides[1]).any(axis=1)
    mid = start + ((lo + hi) // 2 - half)[:, None] * _COARSE * n  # a sample in the passage
    a, b, _, _ = _chord(occ, mid, t, cap, _COARSE)
    mid = mid + np.where(np.isfinite(a + b), (a - b) / 2, 0.0)[:, None] * t
    reach_t = np.minimum(c0, cap) / 2 + 3
    width, jamb_a, jamb_b, cell_a, cell_b = _jambs(grid.edge, mid, t, reach_t, depth / 2 + 2)
    centre = np.where(np.isfinite(width)[:, None], (jamb_a + jamb_b) / 2, mid)
    span = jamb_a - jamb_b
    length = np.linalg.norm(span, axis=1, keepdims=True)
    t1 = np.where(length > 0.5, span / np.maximum(length, 0.5), t)
    # Walls on both sides: a jamb is furniture if its obstacle is free-standing, unless it
    # is a thin wall running on along the door line (the wall between two doors). And the
    # door is an opening in a wall: beyond one jamb at least, the wall runs on along the
    # door line, for WALL_MIN_M and twice its thickness there (a thick wall met across,
    # as between two staggered side doors of a corridor, does not). The runs are taken
    # on the obstacles grown by a cell, to follow a wall a degree or two off.
    grown_free, furniture = grid.grown_free, grid.furniture
    n1 = _perp(t1)
    wall = np.ones(m, dtype=bool)
    in_wall = np.zeros(m, dtype=bool)
    for jamb, cell, sign in ((jamb_a, cell_a, 1.0), (jamb_b, cell_b, -1.0)):
        inner = jamb + sign * 0.5 * t1
        run_on, _ = _cast(grown_free, inner, sign * t1, FREE_STANDING_M / res, _COARSE)
        # The thickness is taken a little way into the wall, clear of the jamb's corner.
        into = np.clip(np.where(np.isfinite(run_on), run_on / 2, np.inf), 0.5, WALL_MIN_M / 2 / res)
        deep = inner + (sign * into)[:, None] * t1
        across = [_cast(~occ, deep, way * n1, FREE_STANDING_M / res, _COARSE)[0] for way in (1, -1)]
        thick = across[0] + across[1]
        runs_on = run_on + _COARSE / 2 >= np.maximum(WALL_MIN_M / res, 2 * thick)
        # ... and along the door line, not across it at a slant (a room's corner).
        for angle in np.deg2rad([-30, -20, 20, 30]):
            c, s = np.cos(angle), np.sin(angle)
            turned = np.stack([t1[:, 0] * c - t1[:, 1] * s, t1[:, 0] * s + t1[:, 1] * c], axis=1)
            slant, _ = _cast(grown_free, inner, sign * turned, FREE_STANDING_M / res, _COARSE)
            runs_on &= run_on >= 0.8 * slant
        in_wall |= runs_on
        wall &= ~furniture[cell[:, 0], cell[:, 1]] | ((thick <= THIN_WALL_M / res) & runs_on)
    wall &= in_wall
    # The door line itself is clear: along it, the nearest obstacle is a jamb (a line that
    # slips past another wall's end, as across a room's corner, is no door).
    along = np.linspace(0.2, 0.8, 7)
    on_line = jamb_b[:, None, :] + along[None, :, None] * span[:, None, :]
    r = np.clip(np.floor(on_line + 0.5).astype(np.intp), 0, np.array(occ.shape) - 1)
    expect = np.minimum(along, 1 - along)[None, :] * width[:, None]
    clean = (grid.clear[r[..., 0], r[..., 1]] >= expect - 2.0).all(axis=1)
    door = (
        clean
        & ends
        & (depth <= depth_cells)
        & opens
        & same_end
        & (np.abs((t1 * t).sum(axis=1)) > 0.9)
        & np.isfinite(width)
        & (width >= min_door_m / res - 0.5)
        & (width <= max_door_m / res + 0.5)
        & wall
    )
    return Measurement(door, width, centre, t1, _perp(t1), depth)


@dataclass
class DoorTestGrids:
    """The padded obstacle grid and what the door test reads from it."""

    occ: np.ndarray
    clear: np.ndarray  # distance (cells) from each free cell to the nearest obstacle
    edge: np.ndarray  # obstacle cells next to free space
    furniture: np.ndarray  # cells of free-standing obstacles (see door_test_grids)
    grown_free: np.ndarray  # free space with the obstacles grown by a cell


def door_test_grids(occ: np.ndarray, res: float, clear: np.ndarray | None = None) -> DoorTestGrids:
    """The grids of the door test. Furniture is a free-standing obstacle (a table, a
    pillar): not joined to the outer walls and smaller than ``FREE_STANDING_M``."""
    if clear is None:
        clear = ndimage.distance_transform_edt(~occ)
    edge = occ & ~ndimage.binary_erosion(occ)
    comp, n = ndimage.label(occ, structure=np.ones((3, 3), dtype=bool))
    small = np.zeros(n + 1, dtype=bool)
    for i, sl in enumerate(ndimage.find_objects(comp), start=1):
        extent = max(sl[0].stop - sl[0].start, sl[1].stop - sl[1].start) * res
        small[i] = extent < FREE_STANDING_M
    small[comp[0, 0]] = False  # the padding frame holds every obstacle joined to the map edge
    small[0] = False
    grown_free = ~ndimage.binary_dilation(occ, structure=np.ones((3, 3), dtype=bool))
    return DoorTestGrids(occ, clear, edge, small[comp], grown_free)


def obstacle_grid(occupied: np.ndarray, res: float) -> np.ndarray:
    """The obstacle grid the door test reads: ``occupied`` padded with a frame of
    obstacles, without specks of ``SPECK_M2`` or less."""
    occ = np.pad(occupied, 1, constant_values=True)
    comp, n = ndimage.label(occ, structure=np.ones((3, 3), dtype=bool))
    speck = np.bincount(comp.ravel(), minlength=n + 1) <= SPECK_M2 / res**2 + 1e-9
    speck[0] = False
    return occ & ~speck[comp]


def _walk(
    occ: np.ndarray, pts: np.ndarray, t: np.ndarray, half: int, cap: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Free runs along +t and -t at ``2 * half + 1`` points stepped along the normal.

    Returns (ahead, behind, normal); both runs are 0 where the point is occupied.
    """
    n = _perp(t)
    s = np.arange(-half, half + 1) * _COARSE
    q = pts[:, None, :] + s[None, :, None] * n[:, None, :]
    a, b, _, _ = _chord(occ, q.reshape(-1, 2), np.repeat(t, len(s), axis=0), cap, _COARSE)
    inside = _is_occ(occ, q)
    ahead, behind = a.reshape(inside.shape), b.reshape(inside.shape)
    ahead[inside] = 0.0
    behind[inside] = 0.0
    return ahead, behind, n


def _jambs(
    edge: np.ndarray, mid: np.ndarray, t: np.ndarray, half_len: np.ndarray, half_depth: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The jambs of each passage: the closest pair of obstacle cells across it.

    Obstacle boundary cells within ``half_len`` of ``mid`` along the door line ``t`` and
    ``half_depth`` across it are split by the passage axis into two sides; the free width
    is the least distance between a cell of each side (cells taken as unit squares) and
    the jambs are the facing points of such a pair (averaged over ties, so a thick wall
    gives its mid-depth). Returns the width (cells; inf if a side has no cell), the jamb
    points on the +t and -t sides, and one cell of each.
    """
    m = len(mid)
    width = np.full(m, np.inf)
    jamb_a, jamb_b = mid.copy(), mid.copy()
    cell_a, cell_b = np.zeros((m, 2), dtype=np.intp), np.zeros((m, 2), dtype=np.intp)
    n = _perp(t)
    h, w = edge.shape
    for i in range(m):  # one small window per passage
        r = int(np.ceil(max(half_len[i], half_depth[i]))) + 1
        r0, c0 = int(round(mid[i, 0])), int(round(mid[i, 1]))
        rows = slice(max(r0 - r, 0), min(r0 + r + 1, h))
        cols = slice(max(c0 - r, 0), min(c0 + r + 1, w))
        cells = np.argwhere(edge[rows, cols]) + (rows.start, cols.start)
        along, across = (cells - mid[i]) @ t[i], (cells - mid[i]) @ n[i]
        near = (np.abs(along) <= half_len[i]) & (np.abs(across) <= half_depth[i])
        side_a, side_b = cells[near & (along > 0)], cells[near & (along < 0)]
        if not len(side_a) or not len(side_b):
            continue
        diff = (side_b[None, :, :] - side_a[:, None, :]).astype(float)
        gap = np.hypot(*np.moveaxis(np.maximum(np.abs(diff) - 1.0, 0.0), -1, 0))
        ia, ib = np.nonzero(gap <= gap.min() + 1e-9)
        face = 0.5 * np.sign(diff[ia, ib]) * (np.abs(diff[ia, ib]) >= 1)
        width[i] = gap.min()
        jamb_a[i] = (side_a[ia] + face).mean(axis=0)
        jamb_b[i] = (side_b[ib] - face).mean(axis=0)
        cell_a[i], cell_b[i] = side_a[ia[0]], side_b[ib[0]]
    return width, jamb_a, jamb_b, cell_a, cell_b


def narrowest_nearby(
    occ: np.ndarray, pts: np.ndarray, reach: int, shortest: float, cap: float
) -> np.ndarray:
    """The point within ``reach`` cells of each point with the shortest chord through it.

    Chords in 18 directions, at points stepped along each direction's normal: a watershed
    boundary can pass beside a thin wall rather than through its door, and from there no
    short chord exists. A chord is charged a cell per cell away from the point, so that a
    narrower passage nearby (a corridor beside its door) does not win; chords under
    ``shortest`` cells (notches in ragged walls) are skipped.
    """
    m, k = len(pts), 2 * reach + 1
    ang = np.arange(18) * np.pi / 18
    u = np.round(np.stack([np.sin(ang), np.cos(ang)], axis=1), 12)
    off = np.arange(-reach, reach + 1, dtype=float)
    q = pts[:, None, None, :] + off[None, None, :, None] * _perp(u)[None, :, None, :]
    dirs = np.broadcast_to(u[None, :, None, :], q.shape).reshape(-1, 2)
    a, b, _, _ = _chord(occ, q.reshape(-1, 2), dirs, cap, _COARSE)
    chord = (a + b).reshape(m, 18, k)
    chord[_is_occ(occ, q) | (chord < shortest)] = np.inf
    chord += np.abs(off)  # a cell of chord per cell away
    best = chord.reshape(m, -1).argmin(axis=1)
    found = np.isfinite(chord.reshape(m, -1)[np.arange(m), best])
    start = q.reshape(m, -1, 2)[np.arange(m), best]
    return np.where(found[:, None], start, pts)


def narrowest_chord(
    occ: np.ndarray, pts: np.ndarray, max_len: float
) -> tuple[np.ndarray, np.ndarray]:
    """Direction (unit, (row, col)) and length (cells) of the shortest chord through each point."""
    ang = np.arange(_N_DIRS) * np.pi / _N_DIRS
    u = np.round(np.stack([np.sin(ang), np.cos(ang)], axis=1), 12)
    m = len(pts)
    a, b, _, _ = _chord(occ, np.repeat(pts, _N_DIRS, axis=0), np.tile(u, (m, 1)), max_len, _COARSE)
    chord = (a + b).reshape(m, _N_DIRS)
    j = chord.argmin(axis=1)
    return u[j], chord[np.arange(m), j]


def _chord(
    occ: np.ndarray, pts: np.ndarray, t: np.ndarray, max_len: float, step: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Free run through each point along +t and -t: (ahead, behind, cell ahead, cell behind)."""
    a, ca = _cast(occ, pts, t, max_len, step)
    b, cb = _cast(occ, pts, -t, max_len, step)
    return a, b, ca, cb


def _cast(
    occ: np.ndarray, origins: np.ndarray, dirs: np.ndarray, max_len: float, step: float
) -> tuple[np.ndarray, np.ndarray]:
    """Distance from each origin along its unit direction to the first occupied cell.

    Returns the distance in cells (inf if nothing within ``max_len``; the estimate sits
    half a step before the first occupied sample) and that cell's (row, col).
    """
    m = len(origins)
    k = np.arange(1, int(np.ceil(max_len / step)) + 1) * step
    dist = np.full(m, np.inf)
    cell = np.zeros((m, 2), dtype=np.intp)
    per = max(1, _BATCH // len(k))
    h, w = occ.shape
    for s in range(0, m, per):
        o, d = origins[s : s + per], dirs[s : s + per]
        r = np.floor(o[:, None, 0] + d[:, None, 0] * k + 0.5).astype(np.intp)
        c = np.floor(o[:, None, 1] + d[:, None, 1] * k + 0.5).astype(np.intp)
        np.clip(r, 0, h - 1, out=r)
        np.clip(c, 0, w - 1, out=c)
        hit = occ[r, c]
        first = hit.argmax(axis=1)
        rows = np.arange(len(o))
        dist[s : s + per] = np.where(hit[rows, first], k[first] - step / 2, np.inf)
        cell[s : s + per, 0] = r[rows, first]
        cell[s : s + per, 1] = c[rows, first]
    return dist, cell


def _perp(t: np.ndarray) -> np.ndarray:
    return np.stack([-t[:, 1], t[:, 0]], axis=1)


def _is_occ(occ: np.ndarray, pts: np.ndarray) -> np.ndarray:
    r = np.clip(np.floor(pts[..., 0] + 0.5).astype(np.intp), 0, occ.shape[0] - 1)
    c = np.clip(np.floor(pts[..., 1] + 0.5).astype(np.intp), 0, occ.shape[1] - 1)
    return occ[r, c]


def cell_to_world(rc: np.ndarray, res: float, origin: tuple[float, float]) -> np.ndarray:
    """World (x, y) of padded-grid cell coordinates (row, col)."""
    return np.stack(
        [origin[0] + (rc[..., 1] - 0.5) * res, origin[1] + (rc[..., 0] - 0.5) * res], axis=-1
    )


def as_point(v: np.ndarray) -> tuple[float, float]:
    """A 2-vector as a tuple of Python floats."""
    return float(v[0]) + 0.0, float(v[1]) + 0.0  # + 0.0 turns -0.0 into 0.0


def check_inputs(
    occupied: np.ndarray, resolution: float, min_door_m: float, max_door_m: float
) -> None:
    """ValueError unless the grid is 2-D, the resolution positive and the door widths ordered."""
    if occupied.ndim != 2:
        raise ValueError(f"occupied must be a 2-D grid, got shape {occupied.shape}")
    if not resolution > 0:
        raise ValueError(f"resolution must be > 0, got {resolution}")
    if not 0 < min_door_m < max_door_m:
        raise ValueError(f"need 0 < min_door_m < max_door_m, got {min_door_m}, {max_door_m}")
