"""Rooms and doorways from an occupancy grid: a room graph for multi-room routing.

:func:`segment_rooms` splits the free space of a floor map into rooms joined by doorways
and returns the label grid, the doorways and the room graph; :func:`detect_doors_along_path`
finds the doors a raw path crosses on a map without door annotations. Both are pure (no
I/O, no clock) and vectorised with numpy/scipy (Python loops run over cuts and doors,
never over cells).

Method: a distance-transform segmentation in the spirit of Bormann et al., "Room
segmentation: survey, implementation, and analysis" (ICRA 2016), whose candidate cuts are
then checked by a geometric door test.

1. Clearance: the Euclidean distance transform of the free space (obstacle specks up to
   ``SPECK_M2`` are ignored; outside the grid counts as obstacle).
2. Seeds: the components of ``clearance > (max_door + 1 cell) / 2`` are the cores of the
   spaces wider than any door, so every opening of at most ``max_door_m`` separates
   them. Lowering the threshold one cell at a time down to the ``min_door_m`` level adds
   every component that holds no seed yet (the maxima of narrower spaces, such as a
   corridor narrower than the widest door).
3. Basins: the watershed of the clearance from those seeds, computed as the minimum
   spanning forest of the 4-connected free cells (edge weight: minus the lower
   clearance of its two cells, ties broken by the distance to the nearest seed). Two
   basins meet at the narrowest cut between them.
4. Cuts: each connected boundary between two basins is measured where it is widest, with
   rays on the grid (:func:`_measure`): the narrowest chord gives the door line, a walk
   along its normal the passage depth and the space on each side, the closest pair of
   obstacle cells across the passage the jambs. A cut is a **doorway** if
   - its free width (between the jambs) is within ``[min_door_m, max_door_m]``;
   - the passage is at most ``DOOR_DEPTH_MAX_M`` deep and the space opens up by
     ``WIDEN_M`` within ``PROBE_M`` on both sides, beyond the same jamb at least;
   - it is an opening in a wall: beyond one jamb at least, the wall runs on along the
     door line (not at a slant) for ``WALL_MIN_M`` and twice its thickness;
   - the door line is clear of other obstacles, and neither jamb is furniture: an
     obstacle not joined to the outer walls and smaller than ``FREE_STANDING_M`` (a
     table, a pillar), unless it is a partition at most ``THIN_WALL_M`` thick running on
     along the door line (the wall between two doors).
   A cut narrower than ``min_door_m`` is **blocked** (no edge); any other cut is **open**.
   Only cuts spanned by a chord of at most ``max_door_m + WIDEN_M`` within ``_NEAR_M`` of
   their saddle are measured (the others are open space): near it, not only through it,
   since the saddle can be the free cell beside a wall a cell thick (a wide door flush
   with a thick wall ties the clearance), from where slanted rays slip past the jambs.
5. Rooms: open cuts join their basins, from the highest saddle down, except where that
   would join two basins a doorway separates (the door test is the stronger evidence); a
   room under ``min_room_m2`` joins the neighbour across its widest passable cut (or is
   dropped if it has none); doorway passages are labelled 0.

Consequences, by design: a corridor is one room however long (its cross-sections are long
passages of constant width, or open towards opposite sides between staggered doors);
corners, tables and pillars make no doorway; an opening wider than ``max_door_m`` is not a
doorway and the spaces it joins become one room (unless a doorway separates them too);
gaps narrower than ``min_door_m`` separate rooms without a doorway (the chair cannot
pass). Known limit: a doorway must be the narrowest passage between the spaces it joins,
so a door wider than the corridor it opens on, or narrowed further by furniture standing
right in front of it, is not found and its room joins the neighbouring space. A doorway's
``room_a < room_b`` and its normal points from ``room_a`` to ``room_b``. The grid is taken
axis-aligned (the origin's yaw is ignored).
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import networkx as nx
import numpy as np
from scipy import ndimage
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components, minimum_spanning_tree

DOOR_DEPTH_MAX_M = 1.0  # deepest passage (wall plus frame) still a door; deeper = corridor
PROBE_M = 0.6  # how far beyond the passage the space on each side is examined
WIDEN_M = 0.3  # the space on each side must be this much wider than the opening
FREE_STANDING_M = 3.0  # obstacles apart from the outer walls and smaller than this: furniture
SPECK_M2 = 0.01  # obstacle specks up to this area (sensor noise, table legs) are ignored
WALL_MIN_M = 0.5  # a door's wall runs on this far (and 2x its thickness) beyond a jamb
THIN_WALL_M = 0.35  # a free-standing obstacle this thin, running on, is a wall (not furniture)

_N_DIRS = 36  # directions tried for the narrowest chord (every 5 degrees)
_COARSE = 0.5  # ray step (cells) of the searches
_FINE = 0.25  # ray step (cells) of the final measurement
_MIN_SEED_M2 = 0.05  # smallest area of a seed (a disc of about 0.25 m)
_NEAR_M = 0.2  # how far from a cut's saddle (or a path sample) its passage is looked for
_NARROW_TOL = 2.0  # cells: a cross-section this much wider than the opening still counts
_BATCH = 1 << 22  # ray samples per batch (bounds the memory of the ray casts)
_OPEN, _DOOR, _BLOCKED = 0, 1, 2


@dataclass(frozen=True)
class Doorway:
    """A doorway between two rooms: the free opening between its jambs ``p1`` and ``p2``."""

    centre: tuple[float, float]
    width: float
    normal: tuple[float, float]
    p1: tuple[float, float]
    p2: tuple[float, float]
    room_a: int
    room_b: int


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


@dataclass
class RoomMap:
    """Rooms of a floor map: the label grid (0 = no room), the doorways and the room graph.

    Graph nodes are room ids with ``area_m2``, ``centroid`` and ``inside`` (the point of
    the room farthest from any obstacle, always in the room); an edge joins two rooms
    with at least one doorway: ``doorway`` (index of the widest into ``doorways``),
    ``doorways`` (all of them) and ``width`` (the widest opening, metres).
    """

    labels: np.ndarray
    doorways: list[Doorway]
    graph: nx.Graph
    resolution: float = 0.05
    origin: tuple[float, float] = (0.0, 0.0)

    def room_at(self, x: float, y: float) -> int:
        """The room holding world point (x, y); 0 outside the grid, in obstacles and doorways."""
        col = int(np.floor((x - self.origin[0]) / self.resolution))
        row = int(np.floor((y - self.origin[1]) / self.resolution))
        rows, cols = self.labels.shape
        if 0 <= row < rows and 0 <= col < cols:
            return int(self.labels[row, col])
        return 0


# --------------------------------------------------------------------------------------
# Rays and the door test (shared by both public functions); cell coordinates are (row,
# col) in the padded grid, a cell's centre at integer coordinates.
# --------------------------------------------------------------------------------------


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


def _chord(
    occ: np.ndarray, pts: np.ndarray, t: np.ndarray, max_len: float, step: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Free run through each point along +t and -t: (ahead, behind, cell ahead, cell behind)."""
    a, ca = _cast(occ, pts, t, max_len, step)
    b, cb = _cast(occ, pts, -t, max_len, step)
    return a, b, ca, cb


def _narrowest(occ: np.ndarray, pts: np.ndarray, max_len: float) -> tuple[np.ndarray, np.ndarray]:
    """Direction (unit, (row, col)) and length (cells) of the shortest chord through each point."""
    ang = np.arange(_N_DIRS) * np.pi / _N_DIRS
    u = np.round(np.stack([np.sin(ang), np.cos(ang)], axis=1), 12)
    m = len(pts)
    a, b, _, _ = _chord(occ, np.repeat(pts, _N_DIRS, axis=0), np.tile(u, (m, 1)), max_len, _COARSE)
    chord = (a + b).reshape(m, _N_DIRS)
    j = chord.argmin(axis=1)
    return u[j], chord[np.arange(m), j]


def _perp(t: np.ndarray) -> np.ndarray:
    return np.stack([-t[:, 1], t[:, 0]], axis=1)


def _is_occ(occ: np.ndarray, pts: np.ndarray) -> np.ndarray:
    r = np.clip(np.floor(pts[..., 0] + 0.5).astype(np.intp), 0, occ.shape[0] - 1)
    c = np.clip(np.floor(pts[..., 1] + 0.5).astype(np.intp), 0, occ.shape[1] - 1)
    return occ[r, c]


def _despeckle(occupied: np.ndarray, res: float) -> np.ndarray:
    """The grid padded with a frame of obstacles, without specks of ``SPECK_M2`` or less."""
    occ = np.pad(occupied, 1, constant_values=True)
    comp, n = ndimage.label(occ, structure=np.ones((3, 3), dtype=bool))
    speck = np.bincount(comp.ravel(), minlength=n + 1) <= SPECK_M2 / res**2 + 1e-9
    speck[0] = False
    return occ & ~speck[comp]


@dataclass
class _Grid:
    """The padded obstacle grid and what the door test reads from it."""

    occ: np.ndarray
    clear: np.ndarray  # distance (cells) from each free cell to the nearest obstacle
    edge: np.ndarray  # obstacle cells next to free space
    furniture: np.ndarray  # cells of free-standing obstacles (see _grid)
    grown_free: np.ndarray  # free space with the obstacles grown by a cell


def _grid(occ: np.ndarray, res: float, clear: np.ndarray | None = None) -> _Grid:
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
    return _Grid(occ, clear, edge, small[comp], grown_free)


@dataclass
class _Measure:
    """Geometry of candidate doors (cells, padded grid) and whether each passes the door test."""

    door: np.ndarray
    width: np.ndarray
    centre: np.ndarray
    t: np.ndarray
    n: np.ndarray
    depth: np.ndarray


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


def _nearby_narrowest(
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


def _measure(
    grid: _Grid,
    pts: np.ndarray,
    res: float,
    min_door_m: float,
    max_door_m: float,
) -> _Measure:
    """Measure the passage at (or next to) each point and apply the door test (module doc).

    The narrowest cross-section within ``_NEAR_M`` of the point gives the passage and the
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
        return _Measure(np.zeros(0, dtype=bool), np.zeros(0), empty, empty, empty, np.zeros(0))
    cap = (max_door_m + WIDEN_M) / res + 2.0
    depth_cells = DOOR_DEPTH_MAX_M / res
    reach = max(2, int(np.ceil(_NEAR_M / res)))
    start = _nearby_narrowest(occ, pts, reach, min_door_m / res - 1.0, cap)
    t, c0 = _narrowest(occ, start, cap)
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
    return _Measure(door, width, centre, t1, _perp(t1), depth)


# --------------------------------------------------------------------------------------
# Segmentation
# --------------------------------------------------------------------------------------


def _seeds(clear: np.ndarray, res: float, min_door_m: float, max_door_m: float) -> np.ndarray:
    """Seed labels (1..M): cores wider than any door, then the maxima of narrower spaces.

    Going down one cell of clearance at a time, every component of ``clearance > level``
    that holds no seed yet and covers at least ``_MIN_SEED_M2`` becomes a seed; smaller
    ones wait for a lower level, which drops the one-cell maxima that the pixel staircase
    of slanted or ragged walls leaves inside passages.
    """
    level = (max_door_m / res + 1) / 2
    bottom = (min_door_m / res + 1) / 2
    min_cells = max(1, int(np.ceil(_MIN_SEED_M2 / res**2)))
    seeds = np.zeros(clear.shape, dtype=np.int32)
    count = 0
    while level >= bottom:
        comp, n = ndimage.label(clear > level)
        fresh = np.bincount(comp.ravel(), minlength=n + 1) >= min_cells
        fresh[comp[seeds > 0]] = False
        fresh[0] = False
        if fresh.any():
            ids = np.zeros(n + 1, dtype=np.int32)
            ids[fresh] = count + np.arange(1, int(fresh.sum()) + 1)
            new = ids[comp]
            seeds = np.where(new > 0, new, seeds)
            count += int(fresh.sum())
        level -= 1
    return seeds


def _pairs(grid: np.ndarray) -> Iterator[tuple[np.ndarray, np.ndarray]]:
    """The two views of every 4-neighbour pair of cells (right and up neighbours)."""
    yield grid[:, :-1], grid[:, 1:]
    yield grid[:-1, :], grid[1:, :]


def _watershed(free: np.ndarray, clear: np.ndarray, seeds: np.ndarray) -> np.ndarray:
    """Basin label of every free cell: the seeded watershed of the clearance (0 = no seed).

    Computed as a minimum spanning forest rooted in the seeds (each seed collapsed into
    one node and tied to a virtual root): Kruskal adds the edges from the highest
    clearance down, which is the flooding order of the watershed.
    """
    n_seeds = int(seeds.max())
    if n_seeds == 0:
        return np.zeros(free.shape, dtype=np.int32)
    node = np.full(free.shape, -1, dtype=np.int64)
    seeded = seeds > 0
    node[seeded] = seeds[seeded] - 1
    other = free & ~seeded
    node[other] = n_seeds + np.arange(int(other.sum()))
    n_nodes = n_seeds + int(other.sum())
    to_seed = ndimage.distance_transform_edt(~seeded)
    top = float(clear.max())
    eps = 0.25 / (2 * top + 2) / (float(to_seed[free].max()) + 1)
    us, vs, ws = [], [], []
    for (na, nb), (ca, cb), (da, db) in zip(
        _pairs(node), _pairs(clear), _pairs(to_seed), strict=True
    ):
        ok = (na >= 0) & (nb >= 0) & (na != nb)
        u, v = na[ok], nb[ok]
        us.append(np.minimum(u, v))
        vs.append(np.maximum(u, v))
        ws.append(1.0 + top - np.minimum(ca[ok], cb[ok]) + eps * np.maximum(da[ok], db[ok]))
    u, v, w = np.concatenate(us), np.concatenate(vs), np.concatenate(ws)
    _, first = np.unique(u * (n_nodes + 1) + v, return_index=True)
    u = np.concatenate([u[first], np.arange(n_seeds)])
    v = np.concatenate([v[first], np.full(n_seeds, n_nodes)])
    w = np.concatenate([w[first], np.full(n_seeds, 0.5)])
    size = n_nodes + 1
    tree = minimum_spanning_tree(coo_matrix((w, (u, v)), shape=(size, size)).tocsr()).tocoo()
    keep = (tree.row < n_nodes) & (tree.col < n_nodes)
    forest = coo_matrix(
        (np.ones(int(keep.sum())), (tree.row[keep], tree.col[keep])), shape=(n_nodes, n_nodes)
    )
    n_comp, comp = connected_components(forest, directed=False)
    owner = np.zeros(n_comp, dtype=np.int32)
    owner[comp[:n_seeds]] = np.arange(1, n_seeds + 1)
    basins = np.zeros(free.shape, dtype=np.int32)
    basins[free] = owner[comp[node[free]]]
    return basins


@dataclass
class _Cuts:
    """Connected boundaries between two basins: the pair, the saddle (point and clearance)
    and the mean position of the cut's cells on each side."""

    a: np.ndarray
    b: np.ndarray
    saddle: np.ndarray
    height: np.ndarray
    side_a: np.ndarray
    side_b: np.ndarray


def _cuts(basins: np.ndarray, clear: np.ndarray) -> _Cuts:
    """Split the basin boundaries into connected cuts, one per passage between two basins."""
    nb = int(basins.max()) + 1
    pair = np.zeros(basins.shape, dtype=np.int64)
    across = np.zeros(basins.shape)  # clearance of the boundary edge: the lower of its cells
    for (pa, pb), (ba, bb), (ea, eb), (ca, cb) in zip(
        _pairs(pair), _pairs(basins), _pairs(across), _pairs(clear), strict=True
    ):
        ok = (ba > 0) & (bb > 0) & (ba != bb)
        key = np.minimum(ba, bb).astype(np.int64) * nb + np.maximum(ba, bb)
        low = np.minimum(ca, cb)
        pa[ok] = key[ok]
        pb[ok] = key[ok]
        ea[ok] = np.maximum(ea[ok], low[ok])
        eb[ok] = np.maximum(eb[ok], low[ok])
    cells = np.flatnonzero(pair)
    empty = np.zeros(0, dtype=np.intp)
    if len(cells) == 0:
        return _Cuts(
            empty, empty, np.zeros((0, 2)), np.zeros(0), np.zeros((0, 2)), np.zeros((0, 2))
        )
    index = np.full(pair.shape, -1, dtype=np.int64)
    index.flat[cells] = np.arange(len(cells))
    us, vs = [], []
    for dr, dc in ((0, 1), (1, -1), (1, 0), (1, 1)):
        h, w = pair.shape
        r0, r1 = slice(0, h - dr), slice(dr, h)
        c0, c1 = (slice(0, w - dc), slice(dc, w)) if dc >= 0 else (slice(-dc, w), slice(0, w + dc))
        p, q = pair[r0, c0], pair[r1, c1]
        ok = (p > 0) & (p == q)
        us.append(index[r0, c0][ok])
        vs.append(index[r1, c1][ok])
    u, v = np.concatenate(us), np.concatenate(vs)
    graph = coo_matrix((np.ones(len(u)), (u, v)), shape=(len(cells), len(cells)))
    n_cut, comp = connected_components(graph, directed=False)
    key = pair.flat[cells]
    rc = np.stack(np.unravel_index(cells, pair.shape), axis=1).astype(float)
    # The saddle: the cut cell on the highest boundary edge, the lower cell of that edge
    # (inside the passage rather than just outside a thin wall).
    order = np.lexsort((-clear.flat[cells], across.flat[cells], comp))
    last = np.r_[np.flatnonzero(np.diff(comp[order])), len(order) - 1]
    saddle = rc[order[last]]
    ckey = key[order[last]]
    a, b = ckey // nb, ckey % nb
    on_a = basins.flat[cells] == a[comp]
    side = []
    for mask in (on_a, ~on_a):
        cnt = np.maximum(np.bincount(comp[mask], minlength=n_cut), 1)
        side.append(
            np.stack(
                [np.bincount(comp[mask], rc[mask, i], minlength=n_cut) / cnt for i in (0, 1)], 1
            )
        )
    height = across.flat[cells[order[last]]]
    return _Cuts(a.astype(np.intp), b.astype(np.intp), saddle, height, side[0], side[1])


def _world(rc: np.ndarray, res: float, origin: tuple[float, float]) -> np.ndarray:
    """World (x, y) of padded-grid cell coordinates (row, col)."""
    return np.stack(
        [origin[0] + (rc[..., 1] - 0.5) * res, origin[1] + (rc[..., 0] - 0.5) * res], axis=-1
    )


def _check(occupied: np.ndarray, resolution: float, min_door_m: float, max_door_m: float) -> None:
    if occupied.ndim != 2:
        raise ValueError(f"occupied must be a 2-D grid, got shape {occupied.shape}")
    if not resolution > 0:
        raise ValueError(f"resolution must be > 0, got {resolution}")
    if not 0 < min_door_m < max_door_m:
        raise ValueError(f"need 0 < min_door_m < max_door_m, got {min_door_m}, {max_door_m}")


def segment_rooms(
    occupied: np.ndarray,
    resolution: float,
    origin: tuple[float, ...],
    min_door_m: float = 0.7,
    max_door_m: float = 1.8,
    min_room_m2: float = 2.0,
) -> RoomMap:
    """Split a floor's free space into rooms joined by doorways (method: module doc).

    ``occupied`` is a bool grid, row 0 at the bottom (unknown cells should count as
    occupied); ``origin`` the world (x, y[, yaw]) of the grid's lower-left corner.
    Openings with a free width in ``[min_door_m, max_door_m]`` in a short passage with
    walls on both sides are doorways; rooms smaller than ``min_room_m2`` are merged into a
    neighbour.
    """
    occupied = np.asarray(occupied, dtype=bool)
    _check(occupied, resolution, min_door_m, max_door_m)
    org = (float(origin[0]), float(origin[1]))
    occ = _despeckle(occupied, resolution)
    free = ~occ
    clear = ndimage.distance_transform_edt(free)
    basins = _watershed(free, clear, _seeds(clear, resolution, min_door_m, max_door_m))
    cuts = _cuts(basins, clear)
    n_cuts = len(cuts.a)
    kind = np.full(n_cuts, _OPEN)
    nan2 = np.full((n_cuts, 2), np.nan)
    geom = _Measure(
        kind == _DOOR, np.full(n_cuts, np.inf), nan2, nan2.copy(), nan2.copy(), np.zeros(n_cuts)
    )
    if n_cuts:
        cap = (max_door_m + WIDEN_M) / resolution + 2.0
        # The cut's width is taken next to its saddle, as in _measure: on a clearance tie
        # (a wide door flush with a thick wall, in a wall a cell thick) the saddle can be
        # the cell beside the wall, and from there every slanted ray slips past a jamb's
        # end, so the saddle itself has no chord within reach.
        reach = max(2, int(np.ceil(_NEAR_M / resolution)))
        near = _nearby_narrowest(occ, cuts.saddle, reach, min_door_m / resolution - 1.0, cap)
        _, geom.width = _narrowest(occ, near, cap)
        # Blocked: even the widest point of the cut is narrower than a door.
        kind[(2 * cuts.height - 1) < min_door_m / resolution - 1.0] = _BLOCKED
        cand = np.flatnonzero((kind == _OPEN) & np.isfinite(geom.width))
        if len(cand):
            grid = _grid(occ, resolution, clear)
            meas = _measure(grid, cuts.saddle[cand], resolution, min_door_m, max_door_m)
            for name in ("width", "centre", "t", "n", "depth"):
                getattr(geom, name)[cand] = getattr(meas, name)
            kind[cand[meas.door]] = _DOOR
            kind[cand[~meas.door & (meas.width < min_door_m / resolution - 0.5)]] = _BLOCKED
    room_of_basin = _merge(basins, free, cuts, kind, geom.width, resolution, min_room_m2)
    labels = room_of_basin[basins]
    doorways = _doorways(labels, free, cuts, kind, room_of_basin, geom, resolution, org)
    labels[1:-1, 1:-1][occupied] = 0
    graph = _graph(labels, clear, doorways, resolution, org)
    return RoomMap(labels[1:-1, 1:-1].copy(), doorways, graph, resolution, org)


def _roots(parent: np.ndarray) -> np.ndarray:
    """Root of every element of a union-find parent array."""
    p = parent.copy()
    while True:
        q = p[p]
        if np.array_equal(q, p):
            return p
        p = q


def _merge(
    basins: np.ndarray,
    free: np.ndarray,
    cuts: _Cuts,
    kind: np.ndarray,
    width: np.ndarray,
    res: float,
    min_room_m2: float,
) -> np.ndarray:
    """Room id (1..N, 0 = none) of every basin id: open cuts joined, small rooms merged.

    Open cuts join their basins from the highest saddle down (the watershed's own merge
    order), but never two basins a doorway separates: the door test is the stronger
    evidence, and a cut that failed it may have measured a neighbouring passage. Then
    each room under ``min_room_m2`` joins the neighbour across its widest passable cut.
    """
    n_basins = int(basins.max())
    parent = np.arange(n_basins + 1)
    apart: dict[int, set[int]] = {}
    for c in np.flatnonzero(kind == _DOOR):
        apart.setdefault(int(cuts.a[c]), set()).add(int(cuts.b[c]))
        apart.setdefault(int(cuts.b[c]), set()).add(int(cuts.a[c]))

    def find(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = int(parent[i])
        return i

    for c in sorted(np.flatnonzero(kind == _OPEN), key=lambda c: -cuts.height[c]):
        ra, rb = find(int(cuts.a[c])), find(int(cuts.b[c]))
        if ra == rb or any(find(x) == rb for x in apart.get(ra, ())):
            continue
        parent[rb] = ra
        apart.setdefault(ra, set()).update(apart.pop(rb, set()))
    group = _roots(parent)
    area = np.bincount(group[basins[free]], minlength=len(parent)) * res**2
    area[0] = 0.0
    passable = kind != _BLOCKED
    ga, gb, w = group[cuts.a[passable]], group[cuts.b[passable]], width[passable]
    for r in np.argsort(area, kind="stable"):
        if area[r] >= min_room_m2 or area[r] == 0:
            continue
        root = _roots(parent)
        ra, rb = root[ga], root[gb]
        mine = ((ra == r) | (rb == r)) & (ra != rb)
        if mine.any():
            k = np.flatnonzero(mine)[np.argmax(w[mine])]
            other = rb[k] if ra[k] == r else ra[k]
            parent[r] = other
            area[other] += area[r]
            area[r] = 0.0
    room = _roots(parent)[group]
    room[area[room] < min_room_m2] = 0
    room[0] = 0
    # Number the rooms 1..N in the order of their first cell (row-major from the bottom).
    grid = room[basins]
    ids, first = np.unique(grid, return_index=True)
    ids = ids[np.argsort(first)]
    ids = ids[ids > 0]
    renum = np.zeros(int(room.max()) + 1, dtype=np.int32)
    renum[ids] = np.arange(1, len(ids) + 1)
    return renum[room]


def _doorways(
    labels: np.ndarray,
    free: np.ndarray,
    cuts: _Cuts,
    kind: np.ndarray,
    room_of_basin: np.ndarray,
    geom: _Measure,
    res: float,
    origin: tuple[float, float],
) -> list[Doorway]:
    """Doorways from the door cuts between two rooms (one per passage); their cells set to 0."""
    doorways: list[Doorway] = []
    kept: list[tuple[int, int, np.ndarray, float]] = []
    doors = np.flatnonzero(kind == _DOOR)
    for c in doors[np.argsort(geom.width[doors], kind="stable")]:  # the narrowest first
        ra, rb = int(room_of_basin[cuts.a[c]]), int(room_of_basin[cuts.b[c]])
        if ra == 0 or rb == 0 or ra == rb:
            continue
        n, t, ctr, w = geom.n[c].copy(), geom.t[c], geom.centre[c], float(geom.width[c])
        if np.dot(cuts.side_a[c] - cuts.side_b[c], n) > 0:
            n = -n
        if ra > rb:
            ra, rb, n = rb, ra, -n
        if any(
            (ka, kb) == (ra, rb) and np.hypot(*(kc - ctr)) < max(kw, w) / 2
            for ka, kb, kc, kw in kept
        ):
            continue
        kept.append((ra, rb, ctr, w))
        _clear_passage(labels, free, ctr, t, n, w, float(geom.depth[c]))
        p1, p2 = ctr - t * w / 2, ctr + t * w / 2
        xy = _world(np.stack([ctr, p1, p2]), res, origin)
        doorways.append(
            Doorway(
                centre=_pt(xy[0]),
                width=w * res,
                normal=_pt(n[::-1]),
                p1=_pt(xy[1]),
                p2=_pt(xy[2]),
                room_a=ra,
                room_b=rb,
            )
        )
    return sorted(doorways, key=lambda d: (d.room_a, d.room_b, d.centre))


def _pt(v: np.ndarray) -> tuple[float, float]:
    return float(v[0]) + 0.0, float(v[1]) + 0.0  # + 0.0 turns -0.0 into 0.0


def _clear_passage(
    labels: np.ndarray,
    free: np.ndarray,
    ctr: np.ndarray,
    t: np.ndarray,
    n: np.ndarray,
    w: float,
    depth: float,
) -> None:
    """Label 0 the free cells of a door passage (between the jambs, through the wall)."""
    reach = int(np.ceil(w / 2 + depth / 2 + 2))
    r0, c0 = int(round(ctr[0])), int(round(ctr[1]))
    rs = slice(max(r0 - reach, 0), min(r0 + reach + 1, labels.shape[0]))
    cs = slice(max(c0 - reach, 0), min(c0 + reach + 1, labels.shape[1]))
    rr, cc = np.mgrid[rs, cs]
    dr, dc = rr - ctr[0], cc - ctr[1]
    inside = (np.abs(dr * t[0] + dc * t[1]) <= w / 2 + 0.5) & (
        np.abs(dr * n[0] + dc * n[1]) <= depth / 2 + 0.5
    )
    labels[rs, cs][inside & free[rs, cs]] = 0


def _graph(
    labels: np.ndarray,
    clear: np.ndarray,
    doorways: list[Doorway],
    res: float,
    origin: tuple[float, float],
) -> nx.Graph:
    """Room graph: rooms with area, centroid and an inside point; edges per room pair."""
    graph = nx.Graph()
    ids = np.arange(1, int(labels.max()) + 1)
    if len(ids):
        area = np.bincount(labels.ravel(), minlength=len(ids) + 1)[1:] * res**2
        com = np.array(ndimage.center_of_mass(labels > 0, labels, ids)).reshape(-1, 2)
        top = np.zeros(len(ids) + 1)
        np.maximum.at(top, labels.ravel(), clear.ravel())
        at = np.flatnonzero((labels > 0) & (clear == top[labels]))
        room, first = np.unique(labels.flat[at], return_index=True)
        deep = np.zeros((len(ids), 2))
        deep[room - 1] = np.stack(np.unravel_index(at[first], labels.shape), axis=1)
        cxy, dxy = _world(com, res, origin), _world(deep, res, origin)
        for i, room in enumerate(ids):
            graph.add_node(
                int(room), area_m2=float(area[i]), centroid=_pt(cxy[i]), inside=_pt(dxy[i])
            )
    for i, d in enumerate(doorways):
        if graph.has_edge(d.room_a, d.room_b):
            e = graph.edges[d.room_a, d.room_b]
            e["doorways"].append(i)
            if d.width > e["width"]:
                e["doorway"], e["width"] = i, d.width
        else:
            graph.add_edge(d.room_a, d.room_b, doorway=i, doorways=[i], width=d.width)
    return graph


# --------------------------------------------------------------------------------------
# Doors along a path
# --------------------------------------------------------------------------------------


def detect_doors_along_path(
    occupied: np.ndarray,
    resolution: float,
    origin: tuple[float, ...],
    path_xy: np.ndarray,
    min_door_m: float = 0.7,
    max_door_m: float = 1.8,
) -> list[PathDoor]:
    """The doors a path crosses on a map without door annotations, in path order.

    ``path_xy`` is an (N, 2) array of world points (a raw A* path will do; ``occupied``,
    ``resolution`` and ``origin`` as for :func:`segment_rooms`). The path is sampled every
    cell; where it runs close to walls, the narrowest chord through each sample (rays in
    36 directions) marks the narrow stretches, and the samples where that chord is least
    or changes are measured with the door test of :func:`segment_rooms` (an opening of
    ``[min_door_m, max_door_m]`` in a wall, short, opening up on both sides, no
    furniture), so a corridor gives no detection. Returns one record per crossing of a
    door line between its jambs; detections of one passage from several samples are
    merged, and a path that wiggles through a door line counts once (or not at all if it
    turns back).
    """
    occupied = np.asarray(occupied, dtype=bool)
    _check(occupied, resolution, min_door_m, max_door_m)
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
    occ = _despeckle(occupied[lo[0] : hi[0], lo[1] : hi[1]], res)
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
    _, chord = _narrowest(occ, pts[near], cap)
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
    meas = _measure(_grid(occ, res, clear), pts[seeds], res, min_door_m, max_door_m)

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
        xy = _world(np.stack([ctr, ctr - t * w / 2, ctr + t * w / 2]), res, org)
        for group in wiggles:
            if len(group) % 2 == 0:
                continue
            i = group[0]
            frac = f[i] / (f[i] - f[i + 1])
            found.append(
                PathDoor(
                    centre=_pt(xy[0]),
                    width=w * res,
                    normal=_pt((n if f[i + 1] > f[i] else -n)[::-1]),
                    p1=_pt(xy[1]),
                    p2=_pt(xy[2]),
                    index=int(seg[i]),
                    distance=float(s[i] + frac * (s[i + 1] - s[i])) * res,
                )
            )
    found.sort(key=lambda door: door.distance)
    return found
