"""Manoeuvres for tight rooms: turns on the spot and straight drives, forwards or back.

Docking goes from one pose to another by turning to face the target, driving to it and
turning to the goal heading. In the room between two doors in series that often does not
fit: campaign b4.m07 has a 2.0 x 2.0 m room where neither the first door's exit pose nor
the second door's approach pose leaves room to turn on the spot (the footprint's corners
reach 0.83 m from the rear axle), so the chair stood held by its own safety checks. A
person would drive to the middle of the room, turn there, and drive on.

:func:`plan_manoeuvre` finds such a sequence: a hybrid A* search over (x, y, heading),
whose moves are a turn on the spot by one heading step and a straight step forwards or
backwards, every pose checked against the walls and points grown by a margin; each
expanded pose also tries the plain turn-drive-turn to the goal, which ends the search
as soon as it fits. The answer is the list of poses where the motion changes (turn,
forwards, backwards), each reachable from the one before by one straight drive or one
turn on the spot, so a docking controller can take them one by one. Pure computation.
"""

from __future__ import annotations

import heapq
import math
from dataclasses import dataclass

import numba
import numpy as np

HEADINGS = 72  # heading steps in a full turn (5 degrees each)
ESCAPE_STEPS = 8  # a start that does not fit is left by at most this many straight steps
POINT_CELL_M = 0.02  # points are merged on cells this size before a room is stamped
TURN, FORWARD, BACK = 0, 1, 2


@dataclass(frozen=True)
class ManoeuvreBody:
    """The chair as the search checks it: its rectangle around the rear axle, grown by
    ``margin_m`` on every side."""

    front: float
    rear: float
    width: float
    margin_m: float


@dataclass(frozen=True)
class ManoeuvreCosts:
    """What the search minimises: metres driven (backwards costs ``reverse_factor`` times
    more), ``turn_m_per_rad`` per radian turned on the spot, and ``switch_m`` for each
    change between turning, driving forwards and driving backwards (each is a stop)."""

    reverse_factor: float = 1.5
    turn_m_per_rad: float = 0.3
    switch_m: float = 0.5
    max_expansions: int = 200_000  # per search; campaign b6005.m00's corner took 97k
    goal_slack_m: float = 0.15  # a goal that does not fit: any pose this near it ends the search


@dataclass
class Budget:
    """Expansions left to the searches of one manoeuvre (several margins share it): a
    search that finds nothing explores every pose it can reach, and in lockstep the
    controller's tick waits for it (the simulator gives up after 5 s)."""

    left: int


class Room:
    """Where the chair may stand in a window of the floor: one grid of free rear-axle
    cells per heading step. A cell is blocked where the footprint, grown by the margin
    and by half a cell diagonal (a pose may lie anywhere in its cell), covers a point.

    Built from an occupancy grid (each occupied cell's centre, grown by half a cell
    diagonal more, as a point may lie anywhere in it) or, with :meth:`from_points`,
    from the points themselves: a scan's range noise scatters a wall's points a few
    centimetres, and on 5 cm cells one of them fills a whole cell nearer the chair."""

    def __init__(
        self,
        occupied: np.ndarray,
        resolution: float,
        origin: tuple[float, float],
        body: ManoeuvreBody,
    ) -> None:
        occ_r, occ_c = np.nonzero(np.asarray(occupied, dtype=bool))
        centres = np.column_stack(
            (origin[0] + (occ_c + 0.5) * resolution, origin[1] + (occ_r + 0.5) * resolution)
        )
        self._build(centres, resolution * math.sqrt(0.5), resolution, origin, occupied.shape, body)

    @classmethod
    def from_points(
        cls,
        points: np.ndarray,
        resolution: float,
        origin: tuple[float, float],
        shape: tuple[int, int],
        body: ManoeuvreBody,
    ) -> Room:
        """The room a window of ``shape`` (rows, columns) from ``origin`` leaves among
        ``points`` (N, 2); the points are first merged on ``POINT_CELL_M`` cells (a
        3-D scan has thousands on a few metres of wall), each taken as anywhere in its
        cell."""
        pts = np.asarray(points, dtype=float).reshape(-1, 2)
        cells = np.unique(np.floor(pts / POINT_CELL_M).astype(np.int64), axis=0)
        room = cls.__new__(cls)
        room._build(
            (cells + 0.5) * POINT_CELL_M,
            POINT_CELL_M * math.sqrt(0.5),
            resolution,
            origin,
            shape,
            body,
        )
        return room

    def _build(
        self,
        points: np.ndarray,
        point_slack_m: float,
        resolution: float,
        origin: tuple[float, float],
        shape: tuple[int, int],
        body: ManoeuvreBody,
    ) -> None:
        self.res = float(resolution)
        self.ox, self.oy = float(origin[0]), float(origin[1])
        self.shape = (int(shape[0]), int(shape[1]))
        grow = body.margin_m + self.res * math.sqrt(0.5) + point_slack_m
        pts = np.asarray(points, dtype=float).reshape(-1, 2)
        self.free = ~_blocked(
            pts[:, 0].copy(),
            pts[:, 1].copy(),
            body.front + grow,
            body.rear + grow,
            body.width / 2 + grow,
            self.res,
            self.ox,
            self.oy,
            self.shape[0],
            self.shape[1],
        )
        self.free[:, 0, :] = self.free[:, -1, :] = False  # beyond the window is unknown
        self.free[:, :, 0] = self.free[:, :, -1] = False

    def cell(self, x: float, y: float) -> tuple[int, int]:
        return int(math.floor((y - self.oy) / self.res)), int(math.floor((x - self.ox) / self.res))

    def fits(self, x: float, y: float, k: int) -> bool:
        """Whether the chair at (x, y) with heading step ``k`` is clear."""
        return bool(_fits(self.free, self.res, self.ox, self.oy, x, y, k))

    def turn_fits(self, x: float, y: float, k0: int, k1: int) -> bool:
        """Whether turning on the spot from step ``k0`` to ``k1`` (the short way) is clear."""
        return bool(_turn_fits(self.free, self.res, self.ox, self.oy, x, y, k0, k1))

    def drive_fits(self, x0: float, y0: float, x1: float, y1: float, k: int) -> bool:
        """Whether driving straight from (x0, y0) to (x1, y1) with heading step ``k`` is clear."""
        return _line_free(self.free[k % HEADINGS], self.res, self.ox, self.oy, x0, y0, x1, y1)


@numba.njit(cache=True)
def _line_free(
    free: np.ndarray, res: float, ox: float, oy: float, x0: float, y0: float, x1: float, y1: float
) -> bool:
    """Whether every cell on the straight line from (x0, y0) to (x1, y1), sampled every
    half cell, is free in ``free`` (one heading step's grid): the search tries a drive to
    the goal from every pose it expands, so this is its inner loop."""
    h, w = free.shape
    n = max(1, math.ceil(math.hypot(x1 - x0, y1 - y0) / (res / 2)))
    for i in range(n + 1):
        r = math.floor((y0 + (y1 - y0) * i / n - oy) / res)
        c = math.floor((x0 + (x1 - x0) * i / n - ox) / res)
        if not (0 <= r < h and 0 <= c < w and free[r, c]):
            return False
    return True


@numba.njit(cache=True)
def _blocked(
    px: np.ndarray,
    py: np.ndarray,
    front: float,
    rear: float,
    half_width: float,
    res: float,
    ox: float,
    oy: float,
    h: int,
    w: int,
) -> np.ndarray:
    """(HEADINGS, h, w): True where the rectangle ``rear`` behind to ``front`` ahead of
    the cell's centre, ``half_width`` to each side, at that heading step covers a point.
    The centres it covers for one point are the rectangle turned half round about the
    point: each row of cells inside that quadrilateral is filled from its two edges."""
    out = np.zeros((HEADINGS, h, w), dtype=np.bool_)
    bx = np.array([-rear, front, front, -rear])
    by = np.array([-half_width, -half_width, half_width, half_width])
    cx, cy = np.empty(4), np.empty(4)
    for k in range(HEADINGS):
        c, s = math.cos(2 * math.pi * k / HEADINGS), math.sin(2 * math.pi * k / HEADINGS)
        for i in range(len(px)):
            for j in range(4):  # the covering centres' corners, in cells from cell (0, 0)
                cx[j] = (px[i] - (c * bx[j] - s * by[j]) - ox) / res - 0.5
                cy[j] = (py[i] - (s * bx[j] + c * by[j]) - oy) / res - 0.5
            for r in range(max(0, math.ceil(cy.min())), min(h - 1, math.floor(cy.max())) + 1):
                lo, hi = math.inf, -math.inf
                for j in range(4):
                    ya, yb = cy[j], cy[(j + 1) % 4]
                    if ya == yb:
                        if ya == r:
                            lo = min(lo, cx[j], cx[(j + 1) % 4])
                            hi = max(hi, cx[j], cx[(j + 1) % 4])
                    elif min(ya, yb) <= r <= max(ya, yb):
                        xr = cx[j] + (r - ya) * (cx[(j + 1) % 4] - cx[j]) / (yb - ya)
                        lo, hi = min(lo, xr), max(hi, xr)
                for col in range(max(0, math.ceil(lo)), min(w - 1, math.floor(hi)) + 1):
                    out[k, r, col] = True
    return out


@numba.njit(cache=True)
def _wrap(a: float) -> float:
    """``shared.geometry.wrap_angle`` for the kernels (numba caches a kernel beside the
    module that defines it, so the shared one is not compiled from here)."""
    return math.atan2(math.sin(a), math.cos(a))


@numba.njit(cache=True)
def _step_of(theta: float) -> int:
    """The heading step nearest ``theta`` (halves to even, as Python's round)."""
    return int(np.rint(_wrap(theta) / (2 * math.pi) * HEADINGS)) % HEADINGS


@numba.njit(cache=True)
def _heading_of(k: int) -> float:
    """The heading (radians, [-pi, pi]) of heading step ``k``."""
    return _wrap(2 * math.pi * (k % HEADINGS) / HEADINGS)


@numba.njit(cache=True)
def _steps_apart(a: int, b: int) -> int:
    """How many heading steps from ``a`` to ``b`` the short way (unsigned)."""
    return abs((b - a + HEADINGS // 2) % HEADINGS - HEADINGS // 2)


@numba.njit(cache=True)
def _to_go(x: float, y: float, k: int, gx: float, gy: float, kg: int, turn_cost: float, off: int):
    """A lower bound of the cost to go: the distance, and the turn still to make to the
    goal heading (only turns on the spot change it; ``off`` steps are the tolerance)."""
    return math.hypot(gx - x, gy - y) + turn_cost * max(0, _steps_apart(k, kg) - off)


@numba.njit(cache=True)
def _fits(free: np.ndarray, res: float, ox: float, oy: float, x: float, y: float, k: int) -> bool:
    r = math.floor((y - oy) / res)
    c = math.floor((x - ox) / res)
    return 0 <= r < free.shape[1] and 0 <= c < free.shape[2] and free[k % HEADINGS, r, c]


@numba.njit(cache=True)
def _turn_fits(
    free: np.ndarray, res: float, ox: float, oy: float, x: float, y: float, k0: int, k1: int
) -> bool:
    d = (k1 - k0 + HEADINGS // 2) % HEADINGS - HEADINGS // 2
    r = math.floor((y - oy) / res)
    c = math.floor((x - ox) / res)
    if not (0 <= r < free.shape[1] and 0 <= c < free.shape[2]):
        return False
    step = 1 if d >= 0 else -1
    for i in range(abs(d) + 1):  # noqa: SIM110 (numba compiles no generator in all())
        if not free[(k0 + i * step) % HEADINGS, r, c]:
            return False
    return True


@numba.njit(cache=True)
def _simple(
    free: np.ndarray,
    res: float,
    ox: float,
    oy: float,
    x0: float,
    y0: float,
    t0: float,
    x1: float,
    y1: float,
    t1: float,
    goal_turns: np.ndarray,
) -> tuple[int, float]:
    """:func:`simple_manoeuvre` compiled: (0, 0) if neither fits, (1, 0) for a turn on
    the spot to the goal heading, (2, drive) for turn, drive along ``drive``, turn.
    ``goal_turns`` caches per heading step whether the last turn fits (-1: not known)."""
    k0, kg = _step_of(t0), _step_of(t1)
    dist = math.hypot(x1 - x0, y1 - y0)
    if dist < res:
        return (1, 0.0) if _turn_fits(free, res, ox, oy, x0, y0, k0, kg) else (0, 0.0)
    face = math.atan2(y1 - y0, x1 - x0)
    for i in range(2):
        drive = face if i == 0 else _wrap(face + math.pi)
        k = _step_of(drive)
        if goal_turns[k] < 0:
            goal_turns[k] = 1 if _turn_fits(free, res, ox, oy, x1, y1, k, kg) else 0
        if (
            goal_turns[k] == 1
            and _line_free(free[k % HEADINGS], res, ox, oy, x0, y0, x1, y1)
            and _turn_fits(free, res, ox, oy, x0, y0, k0, k)
        ):
            return 2, drive
    return 0, 0.0


@numba.njit(cache=True)
def _search(
    free: np.ndarray,
    res: float,
    ox: float,
    oy: float,
    sx: float,
    sy: float,
    k0: int,
    gx: float,
    gy: float,
    gt: float,
    reach: float,
    steps_off: int,
    turn_cost: float,
    reverse_factor: float,
    switch_m: float,
    limit: int,
):
    """The hybrid A* of :func:`plan_manoeuvre`, compiled: in Python its loop took 50 us a
    pose on a loaded machine, and in lockstep the controller's tick waits for it (campaign
    b6005.m00: a search outran the simulator's 5 s). Nodes live in slots; the
    answer is (how it ended: 0 nothing, 1 at the goal, 2 with a tail to it; poses
    expanded; the last node's slot; the tail's kind and drive heading as :func:`_simple`
    gives them; the slots' x, y, heading step, mode and parent)."""
    kg = _step_of(gt)
    cap = 4 * limit + 1  # each expansion adds at most four nodes
    xs, ys = np.empty(cap), np.empty(cap)
    ks, modes = np.empty(cap, np.int64), np.empty(cap, np.int64)
    best, parent, escape = np.empty(cap), np.empty(cap, np.int64), np.empty(cap, np.int64)
    h, w = free.shape[1], free.shape[2]
    slot_of = np.full(h * w * HEADINGS * 3, -1, np.int32)  # per (row, col, step, mode)
    goal_turns = np.full(HEADINGS, -1, np.int8)
    step = res

    r0, c0 = math.floor((sy - oy) / res), math.floor((sx - ox) / res)
    xs[0], ys[0], ks[0], modes[0] = sx, sy, k0, TURN
    best[0], parent[0] = 0.0, -1
    escape[0] = 0 if _fits(free, res, ox, oy, sx, sy, k0) else 1
    slot_of[((r0 * w + c0) * HEADINGS + k0) * 3 + TURN] = 0
    used = 1
    queue = [(_to_go(sx, sy, k0, gx, gy, kg, turn_cost, steps_off), 0.0, r0, c0, k0, TURN)]
    expanded = 0
    while len(queue) > 0 and expanded < limit:
        _, g, r, c, k, mode = heapq.heappop(queue)
        s = slot_of[((r * w + c) * HEADINGS + k) * 3 + mode]
        if g > best[s]:
            continue
        expanded += 1
        x, y = xs[s], ys[s]
        near = math.hypot(gx - x, gy - y) < reach
        if near and _steps_apart(k, kg) <= steps_off:
            return 1, expanded, s, 0, 0.0, xs, ys, ks, modes, parent
        th = _heading_of(k)
        kind, drive = _simple(free, res, ox, oy, x, y, th, gx, gy, gt, goal_turns)
        if kind != 0:
            return 2, expanded, s, kind, drive, xs, ys, ks, modes, parent
        out = escape[s]
        for i in range(4):
            nx, ny, nk, nmode, cost = x, y, (k + 1) % HEADINGS, TURN, turn_cost
            if i == 1:
                nk = (k - 1) % HEADINGS
            elif i == 2:
                nx, ny = x + step * math.cos(th), y + step * math.sin(th)
                nk, nmode, cost = k, FORWARD, step
            elif i == 3:
                nx, ny = x + -step * math.cos(th), y + -step * math.sin(th)
                nk, nmode, cost = k, BACK, step * reverse_factor
            fits = _fits(free, res, ox, oy, nx, ny, nk)
            if not fits and (out == 0 or nmode == TURN or out >= ESCAPE_STEPS):
                continue  # only a start that does not fit is left by straight steps
            ng = g + cost + (switch_m if nmode != mode and s != 0 else 0.0)
            nr, nc = math.floor((ny - oy) / res), math.floor((nx - ox) / res)
            if not (0 <= nr < h and 0 <= nc < w):
                continue  # an escape step out of the window: nothing out there fits
            nkey = ((nr * w + nc) * HEADINGS + nk) * 3 + nmode
            ns = slot_of[nkey]
            if ns < 0 or ng < best[ns]:
                if ns < 0:
                    ns, used = used, used + 1
                    slot_of[nkey] = ns
                best[ns], parent[ns] = ng, s
                xs[ns], ys[ns], ks[ns], modes[ns] = nx, ny, nk, nmode
                escape[ns] = 0 if fits else out + 1
                to_go = _to_go(nx, ny, nk, gx, gy, kg, turn_cost, steps_off)
                heapq.heappush(queue, (ng + to_go, ng, nr, nc, nk, nmode))
    return 0, expanded, -1, 0, 0.0, xs, ys, ks, modes, parent


def warm_up() -> None:
    """Compile (or load) the room's and the search's kernels now, not in the first
    manoeuvre of a mission: in lockstep the compile would hold a tick past the
    simulator's timeout."""
    occupied = np.zeros((4, 4), dtype=bool)
    occupied[1, 1] = True
    room = Room(occupied, 0.05, (0.0, 0.0), ManoeuvreBody(0.2, 0.1, 0.2, 0.0))
    room.drive_fits(0.0, 0.0, 0.1, 0.1, 0)
    room.fits(0.1, 0.1, 0)
    simple_manoeuvre(room, (0.1, 0.1, 0.0), (0.15, 0.1, 1.0))
    _search(
        room.free,
        room.res,
        room.ox,
        room.oy,
        0.1,
        0.1,
        0,
        0.15,
        0.1,
        1.0,
        0.05,
        0,
        0.03,
        1.5,
        0.5,
        2,
    )


def heading_step(theta: float) -> int:
    """The heading step nearest ``theta``."""
    return int(_step_of(theta))


def step_heading(k: int) -> float:
    return float(_heading_of(k))


def simple_manoeuvre(
    room: Room,
    start: tuple[float, float, float],
    goal: tuple[float, float, float],
) -> list[tuple[float, float, float]] | None:
    """Turn to face the goal's position (or turn away from it to back up to it), drive
    there, turn to the goal heading: the poses after each part, or None if neither fits."""
    kind, drive = _simple(
        room.free, room.res, room.ox, room.oy, *start, *goal, np.full(HEADINGS, -1, np.int8)
    )
    return _tail(kind, drive, start, goal)


def _tail(
    kind: int, drive: float, start: tuple[float, float, float], goal: tuple[float, float, float]
) -> list[tuple[float, float, float]] | None:
    """The poses of :func:`_simple`'s answer."""
    if kind == 1:
        return [(float(start[0]), float(start[1]), goal[2])]
    if kind == 2:
        return [
            (float(start[0]), float(start[1]), float(drive)),
            (goal[0], goal[1], float(drive)),
            (goal[0], goal[1], goal[2]),
        ]
    return None


def plan_manoeuvre(
    room: Room,
    start: tuple[float, float, float],
    goal: tuple[float, float, float],
    costs: ManoeuvreCosts | None = None,
    budget: Budget | None = None,
) -> list[tuple[float, float, float]] | None:
    """The poses (x, y, theta) where the motion changes, from ``start`` to ``goal``: each
    reached from the one before by one turn on the spot or one straight drive, the last
    at the goal heading within one cell of its position (a docking controller's final
    stage takes out the rest). Where the goal itself does not fit (an approach pose a few
    centimetres inside the margin), the search goes to the nearest pose on the goal's line
    (its heading through it) within ``costs.goal_slack_m`` that fits, a little short of a
    door or beyond it, so docking ends on the door's centre line; where none does, any
    pose within ``costs.goal_slack_m`` and one heading step of it ends the search. A start
    that does not fit (the safety checks hold the chair there, a corner inside the margin)
    is left by up to ``ESCAPE_STEPS`` straight steps forwards or back that need not fit
    either, then by moves that do.
    None if no way is found within ``costs.max_expansions`` (and what is ``left`` of a
    shared ``budget``, which the search uses up)."""
    costs = costs or ManoeuvreCosts()
    k0, kg = heading_step(start[2]), heading_step(goal[2])
    fits = room.fits(goal[0], goal[1], kg)
    if not fits:  # a pose on the goal's line instead: what is left is driven along it
        on_line = _on_line(room, goal, kg, costs.goal_slack_m)
        if on_line is not None:
            goal, fits = on_line, True
    reach = room.res if fits else costs.goal_slack_m  # how near the goal ends the search
    steps_off = 0 if fits else 1  # and how many heading steps off it
    direct = simple_manoeuvre(room, start, goal)
    if direct is not None:
        return direct
    limit = costs.max_expansions if budget is None else min(costs.max_expansions, budget.left)
    turn_cost = costs.turn_m_per_rad * 2 * math.pi / HEADINGS
    found, expanded, last, kind, drive, xs, ys, ks, modes, parent = _search(
        room.free,
        room.res,
        room.ox,
        room.oy,
        float(start[0]),
        float(start[1]),
        k0,
        float(goal[0]),
        float(goal[1]),
        float(goal[2]),
        reach,
        steps_off,
        turn_cost,
        costs.reverse_factor,
        costs.switch_m,
        max(0, limit),
    )
    if budget is not None:
        budget.left -= expanded
    if not found:
        return None
    chain = []
    while last >= 0:
        chain.append((float(xs[last]), float(ys[last]), int(ks[last]), int(modes[last])))
        last = parent[last]
    nodes = chain[::-1]
    if found == 1:
        return _poses(nodes)  # there, within the reach
    x, y, k, _ = nodes[-1]
    return _poses(nodes) + _tail(kind, drive, (x, y, step_heading(k)), goal)


def _on_line(
    room: Room, goal: tuple[float, float, float], kg: int, slack_m: float
) -> tuple[float, float, float] | None:
    """The pose nearest ``goal`` along its heading, within ``slack_m``, that fits (short
    of it first on a tie), or None."""
    c, s = math.cos(goal[2]), math.sin(goal[2])
    for i in range(1, int(slack_m / room.res) + 1):
        for d in (-i * room.res, i * room.res):
            x, y = goal[0] + d * c, goal[1] + d * s
            if room.fits(x, y, kg):
                return (x, y, goal[2])
    return None


def _poses(nodes: list[tuple]) -> list[tuple[float, float, float]]:
    """The poses where the mode changes along a chain of nodes, and its last one."""
    out = []
    for a, b in zip(nodes[:-1], nodes[1:], strict=True):
        if a[3] != b[3] and a is not nodes[0]:
            out.append((a[0], a[1], step_heading(a[2])))
    last = nodes[-1]
    out.append((last[0], last[1], step_heading(last[2])))
    return out
