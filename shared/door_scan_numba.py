"""The doorway finder's steps 2 and 3 compiled: segment a planar scan, then find doorways.

The same rules, in the same order, as the reference in ``shared/door_scan.py``
(``find_doorways_numpy``): the Adaptive Breakpoint Detector, Iterative End-Point Fit,
total-least-squares stretches, candidate gaps between stretches of one wall or beside a
leaf's face, and each gap's checks. About a dozen stretches and a few dozen gaps a scan
made it mostly interpreter work (3.8 ms a scan in the fleet, a tenth of the demo's tick
while the chair passes a door); here it is one call. Floating-point sums are written out
where numpy called BLAS (a product of two 2-vectors may or may not be fused there), and a
stretch's direction comes from its 2 x 2 scatter matrix in closed form instead of an SVD,
so values agree with the reference to about 1e-12 m, not bit for bit (the test compares
them on scans of generated rooms).

A doorway is returned as one row of :data:`COLUMNS`; a stretch as one row of ``(ax, ay,
bx, by, dx, dy, nx, ny, rms, count, length)``.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from shared.config import DoorScanConfig

COLUMNS = ("left_x", "left_y", "right_x", "right_y", "width", "dir_x", "dir_y")
COLUMNS += ("normal_x", "normal_y", "depth", "open")  # depth NaN: no reveal seen
_N_COLUMNS = len(COLUMNS)
# stretch rows
_AX, _AY, _BX, _BY, _DX, _DY, _NX, _NY, _RMS, _COUNT, _LEN = range(11)
# the parameter vector (params)
(
    P_BIN,
    P_BREAK,
    P_SIGMA,
    P_SPLIT,
    P_MIN_POINTS,
    P_MIN_LENGTH,
    P_MIN_WIDTH,
    P_MAX_WIDTH,
    P_ON_LINE,
    P_PARALLEL,
    P_JAMB,
    P_REVEAL,
    P_STEP,
    P_MAX_DEPTH,
    P_LEAF_MIN,
    P_LEAF_DEG,
    P_LEAF_REACH,
    P_LEAF_THICK,
    P_LEAF_SIDE,
    P_SHADOW,
    P_DISTINCT,
) = range(21)


def params(cfg: DoorScanConfig) -> np.ndarray:
    """The finder's settings as the kernels read them."""
    return np.array(
        [
            cfg.bin_deg,
            cfg.breakpoint_angle_deg,
            cfg.range_sigma_m,
            cfg.split_m,
            cfg.min_points,
            cfg.min_length_m,
            cfg.min_width_m,
            cfg.max_width_m,
            cfg.on_line_m,
            cfg.parallel_deg,
            cfg.jamb_m,
            cfg.reveal_m,
            cfg.step_m,
            cfg.max_depth_m,
            cfg.leaf_min_m,
            cfg.leaf_deg,
            cfg.leaf_reach_m,
            cfg.leaf_thickness_m,
            cfg.leaf_side_m,
            cfg.shadow_m,
            cfg.distinct_m,
        ],
        dtype=np.float64,
    )


def warm_up() -> None:
    """Compile (or load) the kernels now: a wall with a 0.9 m doorway and a room behind."""
    xs = np.concatenate([np.linspace(-2.0, -0.45, 40), np.linspace(0.45, 2.0, 40)])
    wall = np.stack([xs, np.full_like(xs, 1.5)], axis=1)
    back = np.stack([np.linspace(-0.4, 0.4, 20), np.full(20, 4.0)], axis=1)
    xy = np.concatenate([wall, back])
    order = np.argsort(np.arctan2(xy[:, 1], xy[:, 0]))
    doorways(np.ascontiguousarray(xy[order]), params(DoorScanConfig()))


@numba.njit(cache=True)
def _dot(ax: float, ay: float, bx: float, by: float) -> float:
    return ax * bx + ay * by


# --------------------------------------------------------------------------------------
# Step 2: stretches
# --------------------------------------------------------------------------------------


@numba.njit(cache=True)
def _run_ends(xy: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Adaptive Breakpoint Detector: where each run starts (and the last ends), (R + 1,)."""
    n = xy.shape[0]
    lam = math.radians(p[P_BREAK])
    lo_phi, hi_phi = math.radians(p[P_BIN]) * 0.5, lam * 0.9
    cuts = [0]
    for i in range(n - 1):
        dd = math.atan2(xy[i + 1, 1], xy[i + 1, 0]) - math.atan2(xy[i, 1], xy[i, 0])
        if abs(dd) >= math.pi:  # np.unwrap: the step taken the short way round
            m = (dd + math.pi) % (2.0 * math.pi) - math.pi
            if m == -math.pi and dd > 0:
                m = math.pi
            dd = m
        dphi = min(max(abs(dd), lo_phi), hi_phi)
        r = math.hypot(xy[i, 0], xy[i, 1])
        d_max = r * math.sin(dphi) / math.sin(lam - dphi) + 3 * p[P_SIGMA]
        if math.hypot(xy[i + 1, 0] - xy[i, 0], xy[i + 1, 1] - xy[i, 1]) > d_max:
            cuts.append(i + 1)
    cuts.append(n)
    return np.array(cuts, dtype=np.int64)


@numba.njit(cache=True)
def _pieces(xy: np.ndarray, lo: int, hi: int, split_m: float) -> list[tuple[int, int]]:
    """Iterative End-Point Fit over xy[lo:hi]: the straight pieces (start, end exclusive),
    in order; neighbours share the return they were split at."""
    out = []
    stack = [(lo, hi)]
    while len(stack) > 0:
        a, b = stack.pop()
        if b - a < 3:
            out.append((a, b))
            continue
        ax, ay = xy[a, 0], xy[a, 1]
        cx, cy = xy[b - 1, 0] - ax, xy[b - 1, 1] - ay
        n = math.hypot(cx, cy)
        best, at = -1.0, a
        for k in range(a, b):
            if n < 1e-9:
                d = math.hypot(xy[k, 0] - ax, xy[k, 1] - ay)
            else:
                d = abs(cx * (xy[k, 1] - ay) - cy * (xy[k, 0] - ax)) / n
            if d > best:
                best, at = d, k
        if best <= split_m or at == a or at == b - 1:
            out.append((a, b))
            continue
        stack.append((at, b))  # the right piece waits: pieces come out in order
        stack.append((a, at + 1))
    return out


@numba.njit(cache=True)
def _fit(xy: np.ndarray, a: int, b: int, out: np.ndarray) -> None:
    """Total least squares line through xy[a:b] (the principal axis of its scatter) into
    a stretch row: ends at the extreme projections, normal towards the origin."""
    n = b - a
    mx = my = 0.0
    for k in range(a, b):
        mx += xy[k, 0]
        my += xy[k, 1]
    mx /= n
    my /= n
    sxx = sxy = syy = 0.0
    for k in range(a, b):
        ex, ey = xy[k, 0] - mx, xy[k, 1] - my
        sxx += ex * ex
        sxy += ex * ey
        syy += ey * ey
    angle = 0.5 * math.atan2(2.0 * sxy, sxx - syy)
    dx, dy = math.cos(angle), math.sin(angle)
    if _dot(dx, dy, xy[b - 1, 0] - xy[a, 0], xy[b - 1, 1] - xy[a, 1]) < 0:
        dx, dy = -dx, -dy
    nx, ny = -dy, dx
    if _dot(nx, ny, mx, my) > 0:  # towards the sensor (the origin)
        nx, ny = -nx, -ny
    lo, hi, sq = math.inf, -math.inf, 0.0
    for k in range(a, b):
        ex, ey = xy[k, 0] - mx, xy[k, 1] - my
        along = _dot(ex, ey, dx, dy)
        off = _dot(ex, ey, nx, ny)
        lo, hi = min(lo, along), max(hi, along)
        sq += off * off
    out[_AX], out[_AY] = mx + lo * dx, my + lo * dy
    out[_BX], out[_BY] = mx + hi * dx, my + hi * dy
    out[_DX], out[_DY], out[_NX], out[_NY] = dx, dy, nx, ny
    out[_RMS], out[_COUNT] = math.sqrt(sq / n), n
    out[_LEN] = math.hypot(out[_BX] - out[_AX], out[_BY] - out[_AY])


@numba.njit(cache=True)
def stretches(xy: np.ndarray, p: np.ndarray) -> np.ndarray:
    """The straight stretches of a planar scan (M, 2; ordered by azimuth) long enough for
    walls, one row each, in scan order."""
    rows = []
    if xy.shape[0] == 0:
        return np.empty((0, 11))
    ends = _run_ends(xy, p)
    row = np.empty(11)
    for r in range(len(ends) - 1):
        for a, b in _pieces(xy, ends[r], ends[r + 1], p[P_SPLIT]):
            if b - a >= p[P_MIN_POINTS]:
                _fit(xy, a, b, row)
                if row[_LEN] >= p[P_MIN_LENGTH]:
                    rows.append(row.copy())
    out = np.empty((len(rows), 11))
    for i in range(len(rows)):
        out[i] = rows[i]
    return out


# --------------------------------------------------------------------------------------
# Step 3: doorways
# --------------------------------------------------------------------------------------


@numba.njit(cache=True)
def _from_a(s: np.ndarray, x: float, y: float, ux: float, uy: float) -> float:
    """(x, y) - the stretch's end a, along (ux, uy)."""
    return _dot(x - s[_AX], y - s[_AY], ux, uy)


@numba.njit(cache=True)
def _along(wall: np.ndarray, u: np.ndarray) -> float:
    """Where stretch ``u``'s middle lies along ``wall`` (from its end a)."""
    mx, my = (u[_AX] + u[_BX]) / 2, (u[_AY] + u[_BY]) / 2
    return _from_a(wall, mx, my, wall[_DX], wall[_DY])


@numba.njit(cache=True)
def _is_leaf(st: np.ndarray, w: int, u: int, reach: float, p: np.ndarray) -> bool:
    """Stretch ``u`` may be the face of a leaf standing across wall ``w``'s line."""
    wall, s = st[w], st[u]
    if u == w or s[_LEN] < p[P_LEAF_MIN]:
        return False
    if abs(_dot(s[_DX], s[_DY], wall[_NX], wall[_NY])) < math.cos(math.radians(p[P_LEAF_DEG])):
        return False
    o1 = _from_a(wall, s[_AX], s[_AY], wall[_NX], wall[_NY])
    o2 = _from_a(wall, s[_BX], s[_BY], wall[_NX], wall[_NY])
    return min(o1, o2) <= reach and max(o1, o2) >= p[P_LEAF_MIN]


@numba.njit(cache=True)
def _gaps(st: np.ndarray, p: np.ndarray) -> list[tuple[int, float, float]]:
    """Candidate gaps (wall's stretch, lo, hi along it from its end a), as the reference's
    ``_gaps`` lists them."""
    gaps = []
    cos_par = math.cos(math.radians(p[P_PARALLEL]))
    k_n = st.shape[0]
    for i in range(k_n):
        for j in range(i + 1, k_n):
            f, g = st[i], st[j]
            if abs(_dot(f[_DX], f[_DY], g[_DX], g[_DY])) < cos_par:
                continue
            si, ti = (i, j) if f[_LEN] >= g[_LEN] else (j, i)
            s, t = st[si], st[ti]
            dx, dy = s[_DX], s[_DY]
            s0 = 0.0
            s1 = _from_a(s, s[_BX], s[_BY], dx, dy)
            s_lo, s_hi = min(s0, s1), max(s0, s1)
            ta = _from_a(s, t[_AX], t[_AY], dx, dy)
            tb = _from_a(s, t[_BX], t[_BY], dx, dy)
            # the reference sorts (value, end) pairs: ties go to end a (k = 0)
            (t_lo, k_lo), (t_hi, k_hi) = ((ta, 0), (tb, 1)) if ta <= tb else ((tb, 1), (ta, 0))
            if t_lo >= s_hi:
                lo, hi, k = s_hi, t_lo, k_lo
            elif s_lo >= t_hi:
                lo, hi, k = t_hi, s_lo, k_hi
            else:
                continue  # overlapping: one wall, no gap
            ex, ey = (t[_AX], t[_AY]) if k == 0 else (t[_BX], t[_BY])
            if abs(_from_a(s, ex, ey, s[_NX], s[_NY])) > p[P_ON_LINE]:
                continue
            gaps.append((si, lo, hi))
    for w in range(k_n):  # a leaf's face as the far jamb
        s = st[w]
        e1 = _from_a(s, s[_BX], s[_BY], s[_DX], s[_DY])
        e_lo, e_hi = min(0.0, e1), max(0.0, e1)
        for u in range(k_n):
            if not _is_leaf(st, w, u, p[P_ON_LINE], p):
                continue
            at = _along(s, st[u])
            if at > e_hi:
                gaps.append((w, e_hi, at))
            elif at < e_lo:
                gaps.append((w, at, e_lo))
    return gaps


@numba.njit(cache=True)
def _leaf_face(st: np.ndarray, w: int, lo: float, hi: float, p: np.ndarray) -> float:
    """Along wall ``w``, the face of the longest leaf standing across it in [lo, hi]
    (the first of equals); NaN: none."""
    best, face = -1.0, math.nan
    for u in range(st.shape[0]):
        if not _is_leaf(st, w, u, p[P_LEAF_REACH], p):
            continue
        at = _along(st[w], st[u])
        if lo - p[P_JAMB] < at < hi + p[P_JAMB] and st[u, _LEN] > best:
            best, face = st[u, _LEN], at
    return face


@numba.njit(cache=True)
def _follow(wall: np.ndarray, end: float, step: int, step_m: float) -> float:
    """From ``end`` along sorted ``wall`` positions in direction ``step`` while consecutive
    returns are less than ``step_m`` apart."""
    n = wall.shape[0]
    for i in range(n):
        v = wall[i] if step > 0 else wall[n - 1 - i]
        if (v - end) * step <= 0:
            continue
        if (v - end) * step > step_m:
            break
        end = v
    return end


@numba.njit(cache=True, error_model="numpy")
def _hidden(
    xy: np.ndarray, off: np.ndarray, s: np.ndarray, c: float, end: float, inward: int, p
) -> bool:
    """Beams crossing the wall's line just inside the gap from ``end`` end on something
    nearer than the wall: the end is the edge of a shadow."""
    for i in range(xy.shape[0]):
        if not off[i] > p[P_ON_LINE]:
            continue
        dots = _dot(xy[i, 0], xy[i, 1], s[_NX], s[_NY])
        scale = c / dots if abs(dots) > 1e-9 else 0.0
        if not scale > 1.0:
            continue
        at = _from_a(s, xy[i, 0] * scale, xy[i, 1] * scale, s[_DX], s[_DY])
        inside = (at - end) * inward
        if p[P_REVEAL] < inside < p[P_SHADOW]:
            return True
    return False


@numba.njit(cache=True, error_model="numpy")
def _doorway(xy: np.ndarray, st: np.ndarray, w: int, lo: float, hi: float, p, out) -> bool:
    """The doorway in wall ``w`` between ``lo`` and ``hi``, if the returns show one, into
    ``out`` (a row of COLUMNS); the reference's ``_doorway`` step for step."""
    if not p[P_MIN_WIDTH] <= hi - lo <= p[P_MAX_WIDTH]:
        return False
    s = st[w]
    dx, dy, nx, ny = s[_DX], s[_DY], s[_NX], s[_NY]
    n = xy.shape[0]
    along, off = np.empty(n), np.empty(n)
    for i in range(n):
        along[i] = _from_a(s, xy[i, 0], xy[i, 1], dx, dy)
        off[i] = _from_a(s, xy[i, 0], xy[i, 1], nx, ny)
    on_line = np.abs(off) < p[P_ON_LINE]
    wall = np.sort(along[on_line & (along > lo - p[P_JAMB]) & (along < hi + p[P_JAMB])])
    lo, hi = _follow(wall, lo, 1, p[P_STEP]), _follow(wall, hi, -1, p[P_STEP])
    leaf = _leaf_face(st, w, lo, hi, p)
    has_leaf = not math.isnan(leaf)
    near_leaf = np.zeros(n, dtype=np.bool_)
    if has_leaf:
        near_leaf = np.abs(along - leaf) < p[P_LEAF_THICK]
        sensor = _dot(-s[_AX], -s[_AY], dx, dy)  # the sensor's place along the wall
        if leaf - lo < hi - leaf:  # seen from the hinge's side, the face is the outer one
            leaf = leaf + (p[P_LEAF_SIDE] if sensor < leaf else 0.0)
            lo = leaf
        else:
            leaf = leaf - (p[P_LEAF_SIDE] if sensor > leaf else 0.0)
            hi = leaf
    width = hi - lo
    if not p[P_MIN_WIDTH] <= width <= p[P_MAX_WIDTH]:
        return False
    rev = p[P_REVEAL]
    for i in range(n):
        if on_line[i] and not near_leaf[i] and lo + rev < along[i] < hi - rev:
            return False  # something on the wall's line in the gap: a leaf, a post
    c = _dot(nx, ny, s[_AX], s[_AY])
    if (not has_leaf or lo != leaf) and _hidden(xy, off, s, c, lo, 1, p):
        return False
    if (not has_leaf or hi != leaf) and _hidden(xy, off, s, c, hi, -1, p):
        return False
    # beams to returns beyond the wall cross its line: some in the gap, most of those
    # through its middle half reaching past a wall's thickness when it is open
    beyond = middle = deep = 0
    through_gap = False
    for i in range(n):
        if not off[i] < -p[P_ON_LINE]:
            continue
        beyond += 1
        scale = c / _dot(xy[i, 0], xy[i, 1], nx, ny)
        through = _from_a(s, xy[i, 0] * scale, xy[i, 1] * scale, dx, dy)
        if lo + rev < through < hi - rev:
            through_gap = True
        if lo + width / 4 < through < hi - width / 4:
            middle += 1
            if -off[i] > p[P_MAX_DEPTH]:
                deep += 1
    if beyond == 0 or not through_gap:
        return False
    is_open = deep / middle >= 0.5 if middle > 0 else True
    # the wall's thickness from a jamb's reveal: the deepest return beyond the face
    depth, seen = -math.inf, 0
    for i in range(n):
        at_jamb = abs(along[i] - lo) < rev or abs(along[i] - hi) < rev
        if at_jamb and -p[P_MAX_DEPTH] < off[i] < -p[P_ON_LINE]:
            depth = max(depth, -off[i])
            seen += 1
    out[0], out[1] = s[_AX] + lo * dx, s[_AY] + lo * dy
    out[2], out[3] = s[_AX] + hi * dx, s[_AY] + hi * dy
    out[4], out[5], out[6] = width, dx, dy
    out[7], out[8] = -nx, -ny
    out[9] = depth if seen >= p[P_MIN_POINTS] else math.nan
    out[10] = 1.0 if is_open else 0.0
    return True


@numba.njit(cache=True)
def doorways(xy: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Every doorway in a planar scan (M, 2; ordered by azimuth), nearest first, one per
    ``distinct_m``: rows of :data:`COLUMNS`."""
    st = stretches(xy, p)
    found = []
    row = np.empty(_N_COLUMNS)
    for w, lo, hi in _gaps(st, p):
        if _doorway(xy, st, w, lo, hi, p, row):
            found.append(row.copy())
    k = len(found)
    dist = np.empty(k)
    for i in range(k):
        dist[i] = math.hypot((found[i][0] + found[i][2]) / 2, (found[i][1] + found[i][3]) / 2)
    order = np.argsort(dist, kind="mergesort")  # stable, as the reference's sort
    kept = []
    for i in order:
        ci = found[i]
        cx, cy = (ci[0] + ci[2]) / 2, (ci[1] + ci[3]) / 2
        alone = True
        for j in kept:
            cj = found[j]
            ox, oy = (cj[0] + cj[2]) / 2, (cj[1] + cj[3]) / 2
            if not math.hypot(cx - ox, cy - oy) > p[P_DISTINCT]:
                alone = False
                break
        if alone:
            kept.append(i)
    out = np.empty((len(kept), _N_COLUMNS))
    for r in range(len(kept)):
        out[r] = found[kept[r]]
    return out
