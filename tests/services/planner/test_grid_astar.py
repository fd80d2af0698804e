"""A*: optimal against an independent Dijkstra (scipy csgraph), no corner cutting."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra

from services.planner.grid_astar import Landmarks, NoPathError, astar, distances_from, path_cost


def reference_cost(blocked: np.ndarray, start, goal, cell_cost=None) -> float:
    """Optimal cost by Dijkstra over an explicit 8-connected graph with the same rules."""
    rows, cols = blocked.shape
    src, dst, w = [], [], []
    for r in range(rows):
        for c in range(cols):
            if blocked[r, c]:
                continue
            for dr in (-1, 0, 1):
                for dc in (-1, 0, 1):
                    nr, nc = r + dr, c + dc
                    if (dr, dc) == (0, 0) or not (0 <= nr < rows and 0 <= nc < cols):
                        continue
                    if blocked[nr, nc] or (dr and dc and (blocked[r, nc] or blocked[nr, c])):
                        continue
                    step = math.sqrt(2) if dr and dc else 1.0
                    if cell_cost is not None:
                        step *= 1.0 + cell_cost[nr, nc]
                    src.append(r * cols + c)
                    dst.append(nr * cols + nc)
                    w.append(step)
    graph = coo_matrix((w, (src, dst)), shape=(rows * cols, rows * cols)).tocsr()
    return float(dijkstra(graph, indices=start[0] * cols + start[1])[goal[0] * cols + goal[1]])


@st.composite
def grids(draw):
    rows, cols = draw(st.integers(2, 24)), draw(st.integers(2, 24))
    density = draw(st.floats(0.0, 0.45))
    seed = draw(st.integers(0, 2**31 - 1))
    rng = np.random.default_rng(seed)
    blocked = rng.random((rows, cols)) < density
    free = np.argwhere(~blocked)
    if len(free) < 1:
        blocked[0, 0] = False
        free = np.argwhere(~blocked)
    start = tuple(int(v) for v in free[rng.integers(len(free))])
    goal = tuple(int(v) for v in free[rng.integers(len(free))])
    cost = rng.random((rows, cols)) * 2 if draw(st.booleans()) else None
    landmarks = Landmarks(blocked, draw(st.integers(1, 3))) if draw(st.booleans()) else None
    return blocked, start, goal, cost, landmarks


def check_path(blocked: np.ndarray, path: np.ndarray, start, goal) -> None:
    assert tuple(path[0]) == start and tuple(path[-1]) == goal
    assert not blocked[path[:, 0], path[:, 1]].any()
    steps = np.diff(path, axis=0)
    assert np.abs(steps).max(initial=0) <= 1 and (np.abs(steps).sum(axis=1) > 0).all()
    for (r, c), (dr, dc) in zip(path[:-1], steps, strict=True):
        if dr and dc:
            assert not blocked[r + dr, c] and not blocked[r, c + dc], "corner cut"


@settings(max_examples=150, deadline=None)
@given(grids())
def test_optimal_against_independent_dijkstra(case) -> None:
    blocked, start, goal, cost, landmarks = case
    expected = reference_cost(blocked, start, goal, cost)
    if not math.isfinite(expected):
        with pytest.raises(NoPathError):
            astar(blocked, start, goal, cost, landmarks)
        return
    path = astar(blocked, start, goal, cost, landmarks)
    check_path(blocked, path, start, goal)
    assert path_cost(path, cost) == pytest.approx(expected, abs=1e-6)


def test_refusals() -> None:
    blocked = np.zeros((5, 5), bool)
    blocked[2, :] = True
    with pytest.raises(NoPathError, match="unreachable"):
        astar(blocked, (0, 0), (4, 4))
    with pytest.raises(NoPathError, match="start cell .* is blocked"):
        astar(blocked, (2, 2), (4, 4))
    with pytest.raises(NoPathError, match="goal cell .* outside"):
        astar(blocked, (0, 0), (9, 9))
    assert astar(blocked, (1, 1), (1, 1)).tolist() == [[1, 1]]


def test_no_squeezing_between_diagonal_blocks() -> None:
    blocked = np.zeros((2, 2), bool)
    blocked[0, 1] = blocked[1, 0] = True
    with pytest.raises(NoPathError):
        astar(blocked, (0, 0), (1, 1))


def test_corridor_cost_and_repeated_calls_reuse_buffers() -> None:
    blocked = np.ones((5, 40), bool)
    blocked[2, :] = False
    for _ in range(3):  # buffers are reused between calls: results must not leak
        path = astar(blocked, (2, 0), (2, 39))
        assert path_cost(path) == 39.0
    other = np.zeros((7, 9), bool)
    assert path_cost(astar(other, (0, 0), (6, 8))) == pytest.approx(6 * math.sqrt(2) + 2)


def test_landmark_distances_match_dijkstra() -> None:
    rng = np.random.default_rng(5)
    blocked = rng.random((15, 20)) < 0.25
    blocked[0, 0] = False
    d = distances_from(blocked, (0, 0))
    for cell in np.argwhere(~blocked)[:25]:
        expected = reference_cost(blocked, (0, 0), tuple(cell))
        assert d[tuple(cell)] == pytest.approx(expected) or (
            math.isinf(expected) and math.isinf(d[tuple(cell)])
        )
    assert np.isinf(d[blocked]).all()


def test_landmarks_shrink_the_search_not_the_path() -> None:
    blocked = np.zeros((60, 200), bool)
    blocked[30, 10:] = True  # a long wall: the straight line to the goal is misleading
    lm = Landmarks(blocked, 3)
    a = astar(blocked, (35, 190), (25, 190), landmarks=lm)
    b = astar(blocked, (35, 190), (25, 190))
    assert path_cost(a) == pytest.approx(path_cost(b))
    with pytest.raises(ValueError, match="landmarks built for"):
        astar(np.zeros((5, 5), bool), (0, 0), (4, 4), landmarks=lm)
