"""Exact 8-connected A* on an occupancy grid, compiled with numba.

Step costs are 1 (orthogonal) and sqrt(2) (diagonal) cells, each multiplied by
``1 + cell_cost[target]`` when a cost grid is given; the octile heuristic is admissible
for that model, so the path is optimal. A diagonal step is forbidden when either of the
two orthogonal cells it passes between is blocked (no corner cutting). The open list is
a binary heap on flat arrays with lazy deletion; ties on f are broken towards larger g
(deeper nodes), which cuts expansions on open floors.

The per-cell arrays (g, parent, open/closed marks) are kept between calls for a grid
size and tagged with a search number, so a plan on a 3.2 M-cell map does not first
spend ~20 ms clearing 60 MB of memory. Calls are therefore not thread-safe; the planner
node answers one request at a time.
"""

from __future__ import annotations

import math

import numba
import numpy as np

SQRT2 = math.sqrt(2.0)


class NoPathError(Exception):
    """No path: start or goal outside the grid or blocked, or the goal unreachable."""


@numba.njit(cache=True, inline="always")
def _octile(r: int, c: int, gr: int, gc: int) -> float:
    dr = abs(r - gr)
    dc = abs(c - gc)
    return (dr + dc) + (SQRT2 - 2.0) * min(dr, dc)


@numba.njit(cache=True, inline="always")
def _less(fa: float, ga: float, fb: float, gb: float) -> bool:
    return fa < fb or (fa == fb and ga > gb)


class _Buffers:
    """Per-cell search state reused across calls; ``mark`` tells which search wrote a cell."""

    def __init__(self) -> None:
        self.n = 0
        self.search = 0

    def get(self, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
        if n != self.n or self.search >= 2**31 - 3:
            self.g = np.empty(n)
            self.parent = np.empty(n, dtype=np.int32)
            self.mark = np.zeros(n, dtype=np.int32)
            self.n, self.search = n, 0
        self.search += 2  # mark == search: open (g valid); mark == search + 1: closed
        return self.g, self.parent, self.mark, self.search


_BUFFERS = _Buffers()


@numba.njit(cache=True)
def _search(
    blocked: np.ndarray,
    cost: np.ndarray,
    use_cost: bool,
    sr: int,
    sc: int,
    gr: int,
    gc: int,
    g: np.ndarray,
    parent: np.ndarray,
    mark: np.ndarray,
    search: int,
    lm_dist: np.ndarray,
    lm_goal: np.ndarray,
) -> np.ndarray:
    rows, cols = blocked.shape
    closed_mark = search + 1
    dijkstra = gr < 0  # no goal: expand everything, h = 0 (landmark distances)
    n_lm = lm_goal.shape[0]
    cap = 1024
    heap_f = np.empty(cap)
    heap_g = np.empty(cap)
    heap_i = np.empty(cap, dtype=np.int64)
    size = 0
    dr8 = np.array([-1, 1, 0, 0, -1, -1, 1, 1])
    dc8 = np.array([0, 0, -1, 1, -1, 1, -1, 1])
    start = sr * cols + sc
    goal = gr * cols + gc if not dijkstra else -1
    g[start] = 0.0
    mark[start] = search
    parent[start] = -1
    heap_f[0] = 0.0 if dijkstra else _octile(sr, sc, gr, gc)
    heap_g[0] = 0.0
    heap_i[0] = start
    size = 1
    while size > 0:
        # pop the root
        g0, cur = heap_g[0], heap_i[0]
        size -= 1
        if size > 0:
            lf, lg, li = heap_f[size], heap_g[size], heap_i[size]
            pos = 0
            while True:
                child = 2 * pos + 1
                if child >= size:
                    break
                if child + 1 < size and _less(
                    heap_f[child + 1], heap_g[child + 1], heap_f[child], heap_g[child]
                ):
                    child += 1
                if _less(heap_f[child], heap_g[child], lf, lg):
                    heap_f[pos], heap_g[pos], heap_i[pos] = (
                        heap_f[child],
                        heap_g[child],
                        heap_i[child],
                    )
                    pos = child
                else:
                    break
            heap_f[pos], heap_g[pos], heap_i[pos] = lf, lg, li
        if mark[cur] == closed_mark or g0 > g[cur]:
            continue
        mark[cur] = closed_mark
        if cur == goal:
            break
        r = cur // cols
        c = cur - r * cols
        for k in range(8):
            nr = r + dr8[k]
            nc = c + dc8[k]
            if nr < 0 or nr >= rows or nc < 0 or nc >= cols or blocked[nr, nc]:
                continue
            diagonal = k >= 4
            if diagonal and (blocked[r, nc] or blocked[nr, c]):
                continue
            nxt = nr * cols + nc
            seen = mark[nxt]
            if seen == closed_mark:
                continue
            step = SQRT2 if diagonal else 1.0
            if use_cost:
                step *= 1.0 + cost[nr, nc]
            ng = g0 + step
            if seen != search or ng < g[nxt]:
                mark[nxt] = search
                g[nxt] = ng
                parent[nxt] = cur
                h = 0.0
                if not dijkstra:
                    h = _octile(nr, nc, gr, gc)
                    for k in range(n_lm):  # ALT: |d(L, n) - d(L, goal)| <= d(n, goal)
                        if lm_goal[k] == np.inf:
                            continue
                        d = abs(lm_dist[k, nxt] - lm_goal[k]) - 1e-9
                        if d > h:
                            h = d
                nf = ng + h
                if size == cap:
                    cap *= 2
                    heap_f = np.resize(heap_f, cap)
                    heap_g = np.resize(heap_g, cap)
                    heap_i = np.resize(heap_i, cap)
                pos = size
                size += 1
                while pos > 0:
                    up = (pos - 1) // 2
                    if _less(nf, ng, heap_f[up], heap_g[up]):
                        heap_f[pos], heap_g[pos], heap_i[pos] = heap_f[up], heap_g[up], heap_i[up]
                        pos = up
                    else:
                        break
                heap_f[pos], heap_g[pos], heap_i[pos] = nf, ng, nxt
    if dijkstra or mark[goal] != closed_mark:
        return np.empty((0, 2), dtype=np.int64)
    length = 1
    node = goal
    while node != start:
        node = parent[node]
        length += 1
    out = np.empty((length, 2), dtype=np.int64)
    node = goal
    for i in range(length - 1, -1, -1):
        out[i, 0] = node // cols
        out[i, 1] = node - (node // cols) * cols
        node = parent[node]
    return out


def distances_from(blocked: np.ndarray, source: tuple[int, int]) -> np.ndarray:
    """Shortest 8-connected distance (cells, unit costs) from ``source`` to every cell (inf if
    unreachable or blocked), by Dijkstra with the same moves as :func:`astar`."""
    blocked = np.ascontiguousarray(blocked, dtype=np.bool_)
    g, parent, mark, search = _BUFFERS.get(blocked.size)
    _search(
        blocked,
        np.zeros((1, 1)),
        False,
        int(source[0]),
        int(source[1]),
        -1,
        -1,
        g,
        parent,
        mark,
        search,
        _NO_LANDMARKS,
        _NO_GOAL,
    )
    return np.where(mark >= search, g, np.inf).reshape(blocked.shape)


_NO_LANDMARKS = np.zeros((0, 1))
_NO_GOAL = np.zeros(0)  # C-contiguous, like a real goal row: one compiled signature


class Landmarks:
    """Exact distances from a few far-apart cells, for the ALT heuristic (Goldberg & Harrelson).

    For any landmark L, |d(L, n) - d(L, goal)| <= d(n, goal) (triangle inequality), so the
    heuristic stays admissible and consistent while it sees walls that the octile distance
    does not: in a building, where the straight line crosses walls and the route must
    follow corridors, A* expands a fraction of the cells. Built once per map (one Dijkstra
    per landmark plus one); valid for any cell costs >= the unit costs (``cell_cost >= 0``).
    Landmarks are picked by farthest-point selection over the free space.
    """

    def __init__(self, blocked: np.ndarray, count: int = 4) -> None:
        if count < 1:
            raise ValueError(f"landmark count must be >= 1, got {count}")
        self.shape = blocked.shape
        free = np.flatnonzero(~np.asarray(blocked, dtype=bool).ravel())
        if len(free) == 0:
            raise ValueError("no free cell to put a landmark on")
        cols = blocked.shape[1]
        seed = divmod(int(free[len(free) // 2]), cols)
        far = distances_from(blocked, seed).ravel()
        dists: list[np.ndarray] = []
        nearest = np.full(far.shape, np.inf)
        score = np.where(np.isfinite(far), far, -1.0)
        self.cells: list[tuple[int, int]] = []
        for _ in range(count):
            cell = divmod(int(np.argmax(score)), cols)
            self.cells.append(cell)
            d = distances_from(blocked, cell).ravel()
            dists.append(d)
            nearest = np.minimum(nearest, d)
            score = np.where(np.isfinite(nearest), nearest, -1.0)
        self.dist = np.stack(dists)


def astar(
    blocked: np.ndarray,
    start: tuple[int, int],
    goal: tuple[int, int],
    cell_cost: np.ndarray | None = None,
    landmarks: Landmarks | None = None,
) -> np.ndarray:
    """The optimal 8-connected path of (row, col) cells from ``start`` to ``goal`` inclusive.

    ``landmarks`` (built once for this grid) sharpens the heuristic; the path is the same.

    Raises:
        NoPathError: start or goal outside the grid or blocked, or no path between them.
    """
    blocked = np.ascontiguousarray(blocked, dtype=np.bool_)
    rows, cols = blocked.shape
    for name, (r, c) in (("start", start), ("goal", goal)):
        if not (0 <= r < rows and 0 <= c < cols):
            raise NoPathError(f"{name} cell ({r}, {c}) is outside the {rows} x {cols} grid")
        if blocked[r, c]:
            raise NoPathError(f"{name} cell ({r}, {c}) is blocked")
    if cell_cost is None:
        cost = np.zeros((1, 1))
    else:
        cost = np.ascontiguousarray(cell_cost, dtype=np.float64)
        if cost.shape != blocked.shape:
            raise ValueError(f"cell_cost shape {cost.shape} differs from grid {blocked.shape}")
    if blocked.size >= 2**31:
        raise ValueError(f"grid of {blocked.size} cells is too large (max 2**31 - 1)")
    lm_dist, lm_goal = _NO_LANDMARKS, _NO_GOAL
    if landmarks is not None:
        if landmarks.shape != blocked.shape:
            raise ValueError(f"landmarks built for {landmarks.shape}, grid is {blocked.shape}")
        lm_dist = landmarks.dist
        lm_goal = lm_dist[:, int(goal[0]) * cols + int(goal[1])].copy()  # inf: other component
    g, parent, mark, search = _BUFFERS.get(blocked.size)
    path = _search(
        blocked,
        cost,
        cell_cost is not None,
        int(start[0]),
        int(start[1]),
        int(goal[0]),
        int(goal[1]),
        g,
        parent,
        mark,
        search,
        lm_dist,
        lm_goal,
    )
    if len(path) == 0:
        raise NoPathError(f"goal cell {tuple(goal)} is unreachable from start cell {tuple(start)}")
    return path


def warm_up() -> None:
    """Compile (or load) the search kernel now, not in the first plan: one plan on a 3 x 3
    grid. Every call (plans with or without costs and landmarks, the landmarks' Dijkstra)
    passes the same argument types, so this one signature is the planner's."""
    astar(np.zeros((3, 3), dtype=bool), (0, 0), (2, 2))


def path_cost(path: np.ndarray, cell_cost: np.ndarray | None = None) -> float:
    """The cost of a cell path under the same model (in cells)."""
    path = np.asarray(path)
    if len(path) < 2:
        return 0.0
    steps = np.abs(np.diff(path, axis=0)).sum(axis=1)
    base = np.where(steps == 2, SQRT2, 1.0)
    if cell_cost is not None:
        base = base * (1.0 + cell_cost[path[1:, 0], path[1:, 1]])
    return float(base.sum())
