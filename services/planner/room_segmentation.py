"""Rooms and doorways from an occupancy grid: a room graph for multi-room routing.

:func:`segment_rooms` splits the free space of a floor map into rooms joined by doorways
and returns the label grid, the doorways and the room graph (:class:`RoomMap`). The route
planner uses it to tell corridors from rooms along a route (:mod:`services.planner.routes`)
and :mod:`services.planner.room_graph` names its doorways after a site's declared doors
and lifts. It is pure (no I/O, no clock) and vectorised with numpy/scipy (Python loops
run over cuts and doors, never over cells).

Method: a distance-transform segmentation in the spirit of Bormann et al., "Room
segmentation: survey, implementation, and analysis" (ICRA 2016), whose candidate cuts are
then checked by the geometric door test of :mod:`services.planner.passages`.

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
   the door test (:func:`~services.planner.passages.measure`: the narrowest chord gives
   the door line, a walk along its normal the passage depth and the space on each side,
   the closest pair of obstacle cells across the passage the jambs). A cut that passes
   it is a **doorway**; a cut narrower than ``min_door_m`` is **blocked** (no edge); any
   other cut is **open**. Only cuts spanned by a chord of at most ``max_door_m +
   WIDEN_M`` within ``NEAR_M`` of their saddle are measured (the others are open space):
   near it, not only through it, since the saddle can be the free cell beside a wall a
   cell thick (a wide door flush with a thick wall ties the clearance), from where
   slanted rays slip past the jambs.
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

from services.planner.passages import (
    NEAR_M,
    WIDEN_M,
    Measurement,
    as_point,
    cell_to_world,
    check_inputs,
    door_test_grids,
    measure,
    narrowest_chord,
    narrowest_nearby,
    obstacle_grid,
)

_MIN_SEED_M2 = 0.05  # smallest area of a seed (a disc of about 0.25 m)
_OPEN, _DOOR, _BLOCKED = 0, 1, 2  # kinds of cut


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
    check_inputs(occupied, resolution, min_door_m, max_door_m)
    org = (float(origin[0]), float(origin[1]))
    occ = obstacle_grid(occupied, resolution)
    free = ~occ
    clear = ndimage.distance_transform_edt(free)
    basins = _watershed(free, clear, _seeds(clear, resolution, min_door_m, max_door_m))
    cuts = _cuts(basins, clear)
    n_cuts = len(cuts.a)
    kind = np.full(n_cuts, _OPEN)
    nan2 = np.full((n_cuts, 2), np.nan)
    geom = Measurement(
        kind == _DOOR, np.full(n_cuts, np.inf), nan2, nan2.copy(), nan2.copy(), np.zeros(n_cuts)
    )
    if n_cuts:
        cap = (max_door_m + WIDEN_M) / resolution + 2.0
        # The cut's width is taken next to its saddle, as measure() does: on a clearance tie
        # (a wide door flush with a thick wall, in a wall a cell thick) the saddle can be
        # the cell beside the wall, and from there every slanted ray slips past a jamb's
        # end, so the saddle itself has no chord within reach.
        reach = max(2, int(np.ceil(NEAR_M / resolution)))
        near = narrowest_nearby(occ, cuts.saddle, reach, min_door_m / resolution - 1.0, cap)
        _, geom.width = narrowest_chord(occ, near, cap)
        # Blocked: even the widest point of the cut is narrower than a door.
        kind[(2 * cuts.height - 1) < min_door_m / resolution - 1.0] = _BLOCKED
        cand = np.flatnonzero((kind == _OPEN) & np.isfinite(geom.width))
        if len(cand):
            grid = door_test_grids(occ, resolution, clear)
            meas = measure(grid, cuts.saddle[cand], resolution, min_door_m, max_door_m)
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


def _roots(parent: np.ndarray) -> np.ndarray:
    """Root of every element of a union-find parent array."""
    p = parent.copy()
    while True:
        q = p[p]
        if np.array_equal(q, p):
            return p
        p = q


def _doorways(
    labels: np.ndarray,
    free: np.ndarray,
    cuts: _Cuts,
    kind: np.ndarray,
    room_of_basin: np.ndarray,
    geom: Measurement,
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
        xy = cell_to_world(np.stack([ctr, p1, p2]), res, origin)
        doorways.append(
            Doorway(
                centre=as_point(xy[0]),
                width=w * res,
                normal=as_point(n[::-1]),
                p1=as_point(xy[1]),
                p2=as_point(xy[2]),
                room_a=ra,
                room_b=rb,
            )
        )
    return sorted(doorways, key=lambda d: (d.room_a, d.room_b, d.centre))


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
        cxy, dxy = cell_to_world(com, res, origin), cell_to_world(deep, res, origin)
        for i, room in enumerate(ids):
            graph.add_node(
                int(room),
                area_m2=float(area[i]),
                centroid=as_point(cxy[i]),
                inside=as_point(dxy[i]),
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
