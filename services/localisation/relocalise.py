"""Global relocalisation: the pose one scan fits best within a region of the floor map.

When the tracked pose is lost (or a floor change leaves only a prior, such as the lift's
exit), the chair stands still and one scan is matched against the whole region around a
prior pose instead of from one predicted pose. The method is correlative scan matching by
branch and bound (Olson 2009; Hess et al. 2016, Cartographer's global search):

* The floor map's signed distance field (``matcher.DistanceField``) is sampled on a search
  grid (``step_m``, 10 cm by default) into a score per cell, ``exp(-d^2 / 2 step^2)``, so a
  point on a wall scores 1 and one far from any wall (or in a door leaf's sweep, off a wall)
  0. A pose's score is the mean score of its points, each looked up in its nearest cell.
* Poses are the search cells' centres within ``radius_m`` of the prior that are free (at
  least ``clearance_m`` from a wall, inside the grid, and in ``allowed`` if given: cells
  inside walls or outside the map are never candidates), at headings within
  ``heading_tol_rad`` of the prior's, one step apart where the scan's far points
  (90th percentile of range) move by one cell.
* Per heading, square blocks of 2^h x 2^h cells are bounded from above by a max-pooled
  score map of the same size (exact: no pose in the block scores more), refined into four
  children best first from one priority queue over all headings. A leaf popped from the
  queue is therefore the best remaining pose of the grid: the first is the global best,
  then each next one far from those already taken (``separation_m`` or
  ``separation_rad``) is a rival hypothesis. The search stops at ``top_k`` of them, when no
  block can reach ``rival_floor`` of the best, or when the budget is spent.
* Those hypotheses are refined by ``match_scan`` (Gauss-Newton, no prior) and judged by
  their inlier ratio: the best is unambiguous if no refined rival far from it comes within
  ``margin`` of it, so symmetric corridors and rooms come back ambiguous, not guessed.

``Relocaliser.relocalise`` widens: regions doubling in radius and heading from the prior
(``widening_bounds``: 1 m and 45 deg, then 2 m and 90 deg, then any heading, up to the
whole map) until one matches (``min_score``), then one more (``confirm_steps``), so a
symmetric room's twin pose just outside the region that matched first is seen as a rival.
Ambiguity is judged within the region searched: a twin farther off is not looked for.

Bounds: one *evaluation* is one block's bound or one pose's score, ``max_points`` (256)
look-ups. A search does at most its budget of evaluations (``max_evaluations``; refused
outright if the top-level blocks alone need more; a widening shares one budget), pushes at
most that many entries on its queue, then refines at most ``top_k`` hypotheses
(``match_scan``: at most 15 iterations over at most ``refine_points`` points). An
evaluation costs about 3-4 us on the 2-core development machine under load, so the default
budget caps a search near 2 s. A best-first search stopped by its budget still holds the
best pose of the grid if it got that far, but not whether a rival matches as well: it is
reported unsettled, never ok. Building a ``Relocaliser`` samples the field and max-pools it
(about 40 ms and 6 MB for a 32 x 28 m floor). Deterministic: no randomness; equal bounds
are taken in the order they were queued.
"""

from __future__ import annotations

import heapq
import math
from dataclasses import dataclass, replace

import numba
import numpy as np

from services.localisation.matcher import DistanceField, Match, match_scan
from shared.geometry import angle_between, wrap_angle
from shared.site import GridMap

MAX_LEVEL = 7  # the largest block: 2^7 search cells a side (12.8 m at 10 cm)
MIN_ANGLE_STEP_RAD = math.radians(0.2)
MAX_ANGLE_STEP_RAD = math.radians(2.0)
MIN_POINTS = 20  # fewer points than this say nothing about where the chair is

Pose = tuple[float, float, float]


@dataclass(frozen=True)
class SearchBounds:
    """Where to look: within ``radius_m`` of the prior's position and ``heading_tol_rad``
    of its heading (pi or more: any heading)."""

    radius_m: float
    heading_tol_rad: float


@dataclass
class RelocaliseSettings:
    """The search's resolution, its budget and the rules that judge its result."""

    step_m: float = 0.1  # search grid cell
    max_points: int = 256  # the scan is thinned (evenly in azimuth) to this many to search
    refine_points: int = 1000  # ... and to this many to refine
    clearance_m: float = 0.2  # a candidate pose is at least this far from any wall
    top_k: int = 8  # hypotheses refined at most: the best and its rivals
    separation_m: float = 0.5  # a rival is this far from the best ...
    separation_rad: float = math.radians(20.0)  # ... or turned this much from it
    rival_floor: float = 0.6  # rivals scoring below this share of the best are not sought
    margin: float = 0.1  # the best's inlier ratio must beat every rival's by this much
    min_score: float = 0.75  # the least inlier ratio of a relocalised pose
    confirm_steps: int = 1  # a widening goes on this many steps past its first match
    max_evaluations: int = 500_000  # the budget of one search (or one widening)


@dataclass(frozen=True)
class Relocalisation:
    """A relocalisation's outcome: ``ok`` when ``pose`` matches well and unambiguously,
    else ``reason`` says why (the pose, if any, is the best found)."""

    ok: bool
    pose: Pose | None
    score: float  # inlier ratio of the best pose after refinement (0 if none)
    unambiguous: bool
    rival_pose: Pose | None  # the best hypothesis far from the best, refined
    rival_score: float  # its inlier ratio (0 if none)
    match: Match | None  # the best's refinement (covariance, rms)
    evaluations: int  # bounds and scores computed (a widening: summed over its steps)
    settled: bool  # the search ended by its own rules, not on the budget
    bounds: SearchBounds  # the (last) region searched
    reason: str  # "" when ok


@numba.njit(cache=True)
def _bound(level: np.ndarray, pad: int, off: np.ndarray, r: int, c: int) -> float:
    """Mean of ``level`` at the points ``off`` (cells, x then y) moved to cell (r, c)."""
    rows, cols = level.shape
    total = 0.0
    for i in range(off.shape[0]):
        a = r + off[i, 1] + pad
        b = c + off[i, 0] + pad
        if 0 <= a < rows and 0 <= b < cols:
            total += level[a, b]
    return total / off.shape[0]


@numba.njit(cache=True)
def _near_taken(h, r, c, k, taken, n, angles, sep_cells, sep_rad) -> bool:
    """Every pose of block (h, r, c) at heading k is near one already taken."""
    w = (1 << h) - 1
    for j in range(n):
        d = abs((angles[k] - angles[taken[j, 2]] + math.pi) % (2 * math.pi) - math.pi)
        if d > sep_rad:
            continue
        dr = max(abs(r - taken[j, 0]), abs(r + w - taken[j, 0]))
        dc = max(abs(c - taken[j, 1]), abs(c + w - taken[j, 1]))
        if dr * dr + dc * dc <= sep_cells * sep_cells:
            return True
    return False


@numba.njit(cache=True)
def _branch_and_bound(
    pyramid, valid, pad, offsets, top, roots, angles, sep_cells, sep_rad, top_k, floor, budget
):
    """Best-first branch and bound; returns the hypotheses taken (row, col, heading), their
    scores, the evaluations spent and whether the search settled within ``budget``."""
    heap = [(0.0, 0, 0, 0, 0, 0)]
    heap.pop()
    seq = 0
    evals = 0
    for k in range(offsets.shape[0]):
        for j in range(roots.shape[0]):
            b = _bound(pyramid[top], pad, offsets[k], roots[j, 0], roots[j, 1])
            evals += 1
            heapq.heappush(heap, (-b, seq, top, roots[j, 0], roots[j, 1], k))
            seq += 1
    taken = np.zeros((top_k, 3), dtype=np.int64)
    scores = np.zeros(top_k)
    n = 0
    settled = True
    while len(heap) > 0:
        nb, _, h, r, c, k = heapq.heappop(heap)
        if n > 0 and -nb < floor * scores[0]:
            break  # no rival left worth refining
        if n > 0 and _near_taken(h, r, c, k, taken, n, angles, sep_cells, sep_rad):
            continue
        if h == 0:
            taken[n, 0], taken[n, 1], taken[n, 2] = r, c, k
            scores[n] = -nb
            n += 1
            if n == top_k:
                break
            continue
        if evals + 4 > budget:
            settled = False
            break
        half = 1 << (h - 1)
        for rr in (r, r + half):
            for cc in (c, c + half):
                inside = rr + pad < valid.shape[1] and cc + pad < valid.shape[2]
                if inside and valid[h - 1, rr + pad, cc + pad]:
                    b = _bound(pyramid[h - 1], pad, offsets[k], rr, cc)
                    evals += 1
                    heapq.heappush(heap, (-b, seq, h - 1, rr, cc, k))
                    seq += 1
    return taken[:n].copy(), scores[:n].copy(), evals, settled


def _max_pyramid(grid: np.ndarray, levels: int) -> np.ndarray:
    """Level h holds, at each cell, the max of ``grid`` over the 2^h x 2^h block from it;
    padded by 2^levels cells on the low sides so blocks may start left of or below the map."""
    pad = 1 << levels
    rows, cols = grid.shape
    out = np.zeros((levels + 1, rows + pad, cols + pad), dtype=grid.dtype)
    out[0, pad:, pad:] = grid
    for h in range(1, levels + 1):
        half = 1 << (h - 1)
        cur = out[h - 1].copy()
        cur[:-half, :] = np.maximum(cur[:-half, :], cur[half:, :])
        cur[:, :-half] = np.maximum(cur[:, :-half], cur[:, half:])
        out[h] = cur
    return out


def _thin(points: np.ndarray, count: int) -> np.ndarray:
    """At most ``count`` of the scan's (x, y), evenly spread in azimuth."""
    pts = np.asarray(points, dtype=np.float64)[:, :2]
    pts = pts[np.isfinite(pts).all(axis=1)]
    pts = pts[np.argsort(np.arctan2(pts[:, 1], pts[:, 0]), kind="stable")]
    if len(pts) > count:
        pts = pts[np.linspace(0, len(pts) - 1, count).astype(int)]
    return pts


def _angle_step(pts: np.ndarray, step_m: float) -> float:
    """The heading step that moves the scan's far points (90th percentile) one cell."""
    far = max(float(np.percentile(np.hypot(pts[:, 0], pts[:, 1]), 90)), 1e-3)
    return min(max(step_m / far, MIN_ANGLE_STEP_RAD), MAX_ANGLE_STEP_RAD)


def _headings(theta: float, tol: float, step: float) -> np.ndarray:
    """The headings searched: ``theta`` and every ``step`` or so within ``tol`` of it."""
    if tol >= math.pi:
        n = math.ceil(2 * math.pi / step)
        return theta + (np.arange(n) - n // 2) * (2 * math.pi / n)
    k = math.ceil(tol / step)
    return theta + np.linspace(-tol, tol, 2 * k + 1)


def _offsets(pts: np.ndarray, angles: np.ndarray, step: float) -> np.ndarray:
    """Each point's cell offset (x, y) from the pose's cell at each heading: (H, N, 2)."""
    c, s = np.cos(angles)[:, None], np.sin(angles)[:, None]
    x = (c * pts[None, :, 0] - s * pts[None, :, 1]) / step
    y = (s * pts[None, :, 0] + c * pts[None, :, 1]) / step
    return np.stack([np.rint(x), np.rint(y)], axis=2).astype(np.int64)


def _far(a: Pose, b: Pose, s: RelocaliseSettings) -> bool:
    """Poses this far apart are different hypotheses, not one a little off."""
    return math.hypot(a[0] - b[0], a[1] - b[1]) > s.separation_m or (
        angle_between(a[2], b[2]) > s.separation_rad
    )


class Relocaliser:
    """Global search for the pose of one scan on one floor's map (build one per floor)."""

    def __init__(self, field: DistanceField, settings: RelocaliseSettings | None = None) -> None:
        self.field = field
        self.settings = settings or RelocaliseSettings()
        step = self.settings.step_m
        frows, fcols = field.field.shape
        rows = math.ceil(frows * field.res / step - 1e-9)
        cols = math.ceil(fcols * field.res / step - 1e-9)
        self.xs = field.ox + (np.arange(cols) + 0.5) * step
        self.ys = field.oy + (np.arange(rows) + 0.5) * step
        # the field cell under each search cell's centre: its clearance and ``allowed``
        self._frow = np.clip(((self.ys - field.oy) / field.res).astype(int), 0, frows - 1)
        self._fcol = np.clip(((self.xs - field.ox) / field.res).astype(int), 0, fcols - 1)
        self.clearance = field.field[np.ix_(self._frow, self._fcol)]
        gx, gy = np.meshgrid(self.xs, self.ys)
        d, _gx, _gy = field.sample(np.stack([gx.ravel(), gy.ravel()], axis=1))
        score = np.exp(-0.5 * (d.reshape(rows, cols) / step) ** 2).astype(np.float32)
        self.pyramid = _max_pyramid(score, MAX_LEVEL)

    def search(
        self,
        points: np.ndarray,
        prior: Pose,
        bounds: SearchBounds,
        budget: int | None = None,
        allowed: np.ndarray | None = None,
    ) -> Relocalisation:
        """The pose of ``points`` (N, 2+, sensor frame) within ``bounds`` of ``prior``, in at
        most ``budget`` evaluations (default: the settings'). ``allowed`` (bool, the map's
        shape) narrows the candidate cells further, e.g. to the floor reachable from the
        prior, or to known cells."""
        s = self.settings
        budget = s.max_evaluations if budget is None else budget
        pts = _thin(points, s.max_points)
        if len(pts) < MIN_POINTS:
            return self._failed(bounds, 0, f"too few scan points ({len(pts)})")
        valid = self.candidates(prior, bounds.radius_m, allowed)
        if not valid.any():
            return self._failed(bounds, 0, f"no free cell within {bounds.radius_m:g} m")
        angles = _headings(prior[2], bounds.heading_tol_rad, _angle_step(pts, s.step_m))
        top, roots = self._roots(valid)
        if len(roots) * len(angles) > budget:
            why = f"budget {budget} below the {len(roots) * len(angles)} first bounds"
            return self._failed(bounds, 0, why, settled=False)
        taken, scores, evals, settled = _branch_and_bound(
            self.pyramid,
            _max_pyramid(valid, MAX_LEVEL),
            1 << MAX_LEVEL,
            _offsets(pts, angles, s.step_m),
            top,
            roots,
            angles,
            s.separation_m / s.step_m,
            s.separation_rad,
            s.top_k,
            s.rival_floor,
            budget,
        )
        guesses = [(self.xs[c], self.ys[r], wrap_angle(angles[k])) for r, c, k in taken]
        return self._judge(self._refine(points, guesses), int(evals), settled, bounds)

    def warm_up(self, prior: Pose) -> None:
        """One small search around ``prior`` (a ring of points 3 m off, within 0.2 m and
        0.1 rad), so that numba compiles (or loads) the search's kernels now: a first
        search in a mission would otherwise hold a lockstep tick (or the wall-time step)
        for the compile. A prior with no free cell within 0.2 m compiles nothing."""
        ring = np.linspace(0.0, 2 * math.pi, 64, endpoint=False)
        pts = np.column_stack([3 * np.cos(ring), 3 * np.sin(ring)])
        self.search(pts, prior, SearchBounds(0.2, 0.1))

    def relocalise(
        self,
        points: np.ndarray,
        prior: Pose,
        steps: list[SearchBounds] | None = None,
        allowed: np.ndarray | None = None,
    ) -> Relocalisation:
        """Search ``steps`` (default: ``widening_bounds``) in turn, sharing one budget,
        until one finds a pose that matches (``min_score``), then ``confirm_steps`` more so
        that a rival just outside the region that matched first is seen (a symmetric room's
        twin pose nearer the prior than the true one); the last search's result is returned,
        ambiguous or not."""
        s = self.settings
        steps = steps if steps is not None else widening_bounds(self.field, prior)
        if not steps:
            raise ValueError("relocalise needs at least one search step")
        spent = 0
        matched_at = None
        for i, bounds in enumerate(steps):
            result = self.search(points, prior, bounds, s.max_evaluations - spent, allowed)
            spent += result.evaluations
            if matched_at is None and result.pose is not None and result.score >= s.min_score:
                matched_at = i
            if matched_at is not None and i >= matched_at + s.confirm_steps:
                break
            if not result.settled or spent >= s.max_evaluations:
                break
        return replace(result, evaluations=spent)

    def candidates(self, prior: Pose, radius: float, allowed: np.ndarray | None) -> np.ndarray:
        """Search cells a pose may be on: free, within ``radius`` of the prior, allowed."""
        near = (self.xs[None, :] - prior[0]) ** 2 + (self.ys[:, None] - prior[1]) ** 2
        valid = (self.clearance >= self.settings.clearance_m) & (near <= radius**2)
        if allowed is not None:
            allowed = np.asarray(allowed, dtype=bool)
            if allowed.shape != self.field.field.shape:
                raise ValueError(f"allowed is {allowed.shape}, the map {self.field.field.shape}")
            valid &= allowed[np.ix_(self._frow, self._fcol)]
        return valid

    def _roots(self, valid: np.ndarray) -> tuple[int, np.ndarray]:
        """The top level and its blocks (row, col) that hold a candidate: one block spans
        the whole window where the window fits in ``MAX_LEVEL``'s block."""
        rows = np.flatnonzero(valid.any(axis=1))
        cols = np.flatnonzero(valid.any(axis=0))
        r0, r1, c0, c1 = rows[0], rows[-1], cols[0], cols[-1]
        span = max(r1 - r0 + 1, c1 - c0 + 1)
        top = min(MAX_LEVEL, max(0, math.ceil(math.log2(span))))
        size = 1 << top
        roots = [
            (r, c)
            for r in range(r0, r1 + 1, size)
            for c in range(c0, c1 + 1, size)
            if valid[r : r + size, c : c + size].any()
        ]
        return top, np.array(roots, dtype=np.int64).reshape(-1, 2)

    def _refine(self, points: np.ndarray, guesses: list[Pose]) -> list[Match]:
        """Each hypothesis refined by Gauss-Newton; those that end in a wall are dropped."""
        pts = _thin(points, self.settings.refine_points)
        f = self.field
        rows, cols = f.field.shape
        out = []
        for guess in guesses:
            m = match_scan(f, pts, guess)
            r, c = math.floor((m.y - f.oy) / f.res), math.floor((m.x - f.ox) / f.res)
            if 0 <= r < rows and 0 <= c < cols and f.field[r, c] > 0:
                out.append(m)
        return out

    def _judge(
        self, matches: list[Match], evals: int, settled: bool, bounds: SearchBounds
    ) -> Relocalisation:
        """The best refined hypothesis and whether a rival far from it comes close."""
        s = self.settings
        if not matches:
            why = "no hypothesis before the budget ran out" if not settled else "no hypothesis"
            return self._failed(bounds, evals, why, settled)
        ranked = sorted(matches, key=lambda m: -m.inlier_ratio)
        best = ranked[0]
        pose = (best.x, best.y, best.theta)
        rival = next((m for m in ranked[1:] if _far((m.x, m.y, m.theta), pose, s)), None)
        rival_score = rival.inlier_ratio if rival else 0.0
        clear = rival is None or best.inlier_ratio - rival_score >= s.margin
        unambiguous = settled and clear
        reason = ""
        if not settled:
            reason = "the budget ran out before rivals were ruled out"
        elif not clear:
            reason = (
                f"ambiguous: a pose {math.hypot(rival.x - best.x, rival.y - best.y):.2f} m "
                f"and {math.degrees(angle_between(rival.theta, best.theta)):.0f} deg away "
                f"matches {rival_score:.2f} against {best.inlier_ratio:.2f}"
            )
        elif best.inlier_ratio < s.min_score:
            reason = f"the best pose matches {best.inlier_ratio:.2f} < {s.min_score:g}"
        return Relocalisation(
            not reason,
            pose,
            best.inlier_ratio,
            unambiguous,
            (rival.x, rival.y, rival.theta) if rival else None,
            rival_score,
            best,
            evals,
            settled,
            bounds,
            reason,
        )

    @staticmethod
    def _failed(
        bounds: SearchBounds, evals: int, reason: str, settled: bool = True
    ) -> Relocalisation:
        return Relocalisation(
            False, None, 0.0, False, None, 0.0, None, evals, settled, bounds, reason
        )


def widening_bounds(
    field: DistanceField,
    prior: Pose,
    first_radius_m: float = 1.0,
    first_heading_rad: float = math.pi / 4,
) -> list[SearchBounds]:
    """Search regions doubling in radius and heading from the first, the last covering the
    whole map (every cell of it within its radius, any heading)."""
    rows, cols = field.field.shape
    corners_x = (field.ox, field.ox + cols * field.res)
    corners_y = (field.oy, field.oy + rows * field.res)
    whole = max(math.hypot(x - prior[0], y - prior[1]) for x in corners_x for y in corners_y)
    steps = []
    radius, heading = first_radius_m, first_heading_rad
    while True:
        steps.append(SearchBounds(min(radius, whole), min(heading, math.pi)))
        if radius >= whole:
            return steps
        radius, heading = radius * 2, heading * 2


def warm_up() -> None:
    """Compile (or load) the search's kernels ahead of the localisation (``wheelnav warm``):
    :meth:`Relocaliser.warm_up`, the localisation's own warm-up, in the middle of a 6.2 m
    square room (its ring of points then lies on the walls, and the refinement is sound)."""
    cells = np.zeros((62, 62), dtype=np.int8)
    cells[[0, -1], :] = cells[:, [0, -1]] = 100
    field = DistanceField(GridMap(cells, 0.1, (0.0, 0.0, 0.0)))
    Relocaliser(field).warm_up((3.1, 3.1, 0.0))
