"""Evaluator 2 of the sampling MPC: a numba kernel, one fused pass per sample (the default).

The same arithmetic as the numpy reference (``mpc_numpy``), but each sample's noise,
clipping, rollout, cost terms and clearances are computed in one loop over its steps with
no temporaries, samples in parallel over ``threads`` (results do not depend on the count).
About ten times faster. Clearances skip a part of the footprint whose bounding circle is
far from everything (``mpc_scene.Body``). Compiled on first use and cached on disk
(``cache=True``); the cost terms' index constants come from ``mpc_costs``.
"""

from __future__ import annotations

import math
import os
import time

import numba
import numpy as np

from services.controller.mpc_costs import (
    GOAL,
    HEADING,
    OBSTACLE,
    PROGRESS,
    SMOOTH,
    SPEED_REF,
    SPEED_WINDOW,
    TRACK,
    TURN,
    WALL,
    weights,
)
from services.controller.mpc_scene import (
    EMPTY,
    FAR,
    Body,
    Field,
    Scene,
    footprint_body,
    slack,
    wall_field,
)
from shared.config import Footprint, MPCConfig

PARALLEL_MIN_SAMPLES = 64
"""Below this many samples a call runs on one thread whatever ``threads`` says: the MPC's
check of its one selected sequence took 0.44 ms on two threads (the other thread's
wake-up) against 0.035 ms on one, in the fleet bench. Results do not depend on it."""

LOAD_EVERY_S = 1.0
"""How often ``threads=0`` reads the machine's load average again (a read costs ~10 us)."""


def threads_for(asked: int, samples: int, cores: int, load: float | None) -> int:
    """Kernel threads for one call: ``asked`` (capped at ``cores``), or with ``asked`` 0 as
    many as the machine's 1-minute ``load`` average leaves free, counting the caller's own
    core as free (``cores - load + 1``, rounded, at least 1); one thread when the load is
    unknown or the call is small. On a 2-core machine the in-process demo ran faster on two
    threads when nothing else ran (load about 1.2; by up to 18%, in five of six pairs), and
    up to 17% slower with two busy loops beside it (load above 3: the other thread waits
    for a time slice)."""
    if samples < PARALLEL_MIN_SAMPLES:
        return 1  # waking the other threads costs more than the few samples
    if asked:
        return min(asked, cores)
    if load is None:
        return 1
    return int(min(max(round(cores - load + 1.0), 1), cores))


_load = {"at": -math.inf, "value": None}


def _load_average() -> float | None:
    """The 1-minute load average, read at most every ``LOAD_EVERY_S`` (None where the
    system has none)."""
    now = time.monotonic()
    if now - _load["at"] >= LOAD_EVERY_S:
        try:
            _load["value"] = os.getloadavg()[0]
        except OSError:
            _load["value"] = None
        _load["at"] = now
    return _load["value"]


def evaluate(
    body: Body,
    scene: Scene,
    noise: np.ndarray,
    nominal: np.ndarray,
    groups: np.ndarray,
    offsets: np.ndarray | None,
    u_out: np.ndarray,
    cost: np.ndarray,
    col: np.ndarray,
    threads: int,
) -> None:
    """Fill ``u_out``, ``cost`` and ``col`` as ``mpc_numpy.evaluate`` does, on ``threads``
    kernel threads (0 = as many as the machine's load leaves free: :func:`threads_for`)."""
    wall, obs = scene.wall or EMPTY, scene.obs or EMPTY
    load = _load_average() if threads == 0 else None
    numba.set_num_threads(threads_for(threads, len(noise), numba.config.NUMBA_NUM_THREADS, load))
    _kernel(
        noise,
        nominal,
        groups,
        offsets if offsets is not None else _NO_OFFSETS,
        offsets is not None,
        u_out,
        scene.state,
        scene.limits,
        scene.sigma,
        body.points,
        body.parts,
        body.part_r,
        body.part_idx,
        wall.data,
        _geometry(wall),
        scene.wall is not None,
        obs.data,
        _geometry(obs),
        scene.obs is not None,
        scene.path_xy,
        scene.path_s,
        scene.path_len,
        scene.path_cos,
        scene.path_sin,
        scene.vtab,
        scene.vtab_ds,
        scene.goal,
        scene.goal_on,
        scene.params,
        scene.s_exp,
        scene.s_wt,
        scene.weights,
        cost,
        col,
    )


_NO_OFFSETS = np.zeros((1, 1, 2), dtype=np.float32)


def warm_up() -> None:
    """Compile (or load) the kernel now, not in the first control cycle: 4 samples of 3
    steps on a two-point path beside a 4 x 4 wall field, built as ``SamplingMPC`` builds
    them (float32 inputs and fields, float64 scene arrays, int64 groups, bool flags). A
    cycle with or without walls, LiDAR points or offsets passes these same types."""
    samples, steps = 4, 3
    scene = Scene(
        state=np.zeros(5),
        limits=np.array([0.2, -0.3, 1.0, 1.0, 0.1, 0.2]),
        sigma=np.array([0.1, 0.1, 0.5]),
        wall=wall_field(np.ones((4, 4)), 0.5, (-1.0, -1.0)),
        obs=None,
        path_xy=np.array([[0.0, 0.0], [1.0, 0.0]]),
        path_s=np.array([0.0, 1.0]),
        path_len=np.array([1.0]),
        path_cos=np.array([1.0]),
        path_sin=np.array([0.0]),
        vtab=np.array([0.3, 0.3, 0.0]),
        vtab_ds=0.5,
        goal=np.array([1.0, 0.0]),
        goal_on=True,
        params=np.zeros(10),
        s_exp=np.zeros(steps),
        s_wt=np.array([0.5, 1.5]),
        weights=weights(MPCConfig()),
    )
    u = np.zeros((samples, steps, 2), dtype=np.float32)
    evaluate(
        footprint_body(Footprint(), 0.2, 0.1),
        scene,
        np.zeros_like(u),
        np.zeros((1, steps, 2), dtype=np.float32),
        np.zeros(samples, dtype=np.int64),
        None,
        u,
        np.empty(samples),
        np.empty(samples, dtype=np.bool_),
        0,
    )


def _geometry(f: Field) -> np.ndarray:
    """What the kernel's lookups read of a field: origin x, origin y, 1 / res, off-grid, slack."""
    return np.array([f.ox, f.oy, 1.0 / f.res, f.outside, slack(f)])


@numba.njit(cache=True, fastmath=True, inline="always")
def _lookup(d, geo, x, y):
    """Value of the cell (x, y) falls in; geo = (origin x, origin y, 1 / res, off-grid, slack)."""
    c = math.floor((x - geo[0]) * geo[2])
    r = math.floor((y - geo[1]) * geo[2])
    if c < 0 or r < 0 or c >= d.shape[1] or r >= d.shape[0]:
        return geo[3]
    return d[int(r), int(c)]


@numba.njit(cache=True, fastmath=True, inline="always")
def _clearances(wall, wgeo, use_w, obs, ogeo, use_o, x, y, c, s, fp, parts, part_r, pidx, cuts):
    """Smallest wall and obstacle readings over the footprint check points.

    A part of the footprint (see ``mpc_scene.Body``) whose bounding-circle centre reads more
    than radius + slack + cutoff cannot hold a point below the cutoff and is skipped; FAR
    then stands for "at least the cutoff". Each check point is transformed once for both
    fields.
    """
    cw, co = FAR, FAR
    for h in range(parts.shape[0]):
        hx = x + c * parts[h, 0] - s * parts[h, 1]
        hy = y + s * parts[h, 0] + c * parts[h, 1]
        need_w = use_w and _lookup(wall, wgeo, hx, hy) - part_r - wgeo[4] < cuts[0]
        need_o = use_o and _lookup(obs, ogeo, hx, hy) - part_r - ogeo[4] < cuts[1]
        if not (need_w or need_o):
            continue
        for p in range(pidx[h], pidx[h + 1]):
            qx = x + c * fp[p, 0] - s * fp[p, 1]
            qy = y + s * fp[p, 0] + c * fp[p, 1]
            if need_w:
                cw = min(cw, _lookup(wall, wgeo, qx, qy))
            if need_o:
                co = min(co, _lookup(obs, ogeo, qx, qy))
    return cw, co


@numba.njit(cache=True, fastmath=True, parallel=True)
def _kernel(
    noise,
    nominal,
    groups,
    offsets,
    use_offsets,
    u_out,
    state,
    limits,
    sigma,
    fp,
    parts,
    part_r,
    part_idx,
    wall,
    wall_geo,
    has_wall,
    obs,
    obs_geo,
    has_obs,
    pxy,
    ps,
    plen,
    pcos,
    psin,
    vtab,
    vtab_ds,
    goal,
    goal_on,
    params,
    s_exp,
    s_wt,
    wt,
    cost,
    col,
):
    """Same arithmetic as ``mpc_numpy.evaluate``, one sample per iteration, no temporaries."""
    k_n, t_n = noise.shape[0], noise.shape[1]
    x0, y0, th0, v0, w0 = state[0], state[1], state[2], state[3], state[4]
    dt, vmin, vmax, wmax, dvmax, dwmax = (
        limits[0],
        limits[1],
        limits[2],
        limits[3],
        limits[4],
        limits[5],
    )
    sv, sw, rho = sigma[0], sigma[1], sigma[2]
    beta = math.sqrt(1.0 - rho * rho)
    s_now, huber, thr = params[0], params[2], params[3]
    inf_w, inf_o, win_lo, win_hi = params[4], params[5], params[6], params[7]
    thr_w, thr_o = params[8], params[9]
    cuts = np.array([max(inf_w, thr), max(inf_o, thr)])
    n_seg = plen.shape[0]
    n_tab = vtab.shape[0]
    for i in numba.prange(k_n):
        g = groups[i]
        x, y, th, vp, wp = x0, y0, th0, v0, w0
        ev, ew = 0.0, 0.0
        # one sum over the steps per cost term (mpc_costs.TERMS)
        a_track = a_head = a_ref = a_win = a_turn = a_smooth = 0.0
        a_wall = a_obs = a_goal = a_prog = 0.0
        hit = False
        for k in range(t_n):
            if k == 0:
                ev, ew = noise[i, 0, 0], noise[i, 0, 1]
            else:
                ev = rho * ev + beta * noise[i, k, 0]
                ew = rho * ew + beta * noise[i, k, 1]
            v = nominal[g, k, 0] + sv * ev
            w = nominal[g, k, 1] + sw * ew
            if use_offsets:
                v += offsets[i, k, 0]
                w += offsets[i, k, 1]
            v = min(max(min(max(v, vp - dvmax), vp + dvmax), vmin), vmax)
            w = min(max(min(max(w, wp - dwmax), wp + dwmax), -wmax), wmax)
            u_out[i, k, 0] = v
            u_out[i, k, 1] = w
            mid = th + 0.5 * w * dt
            x += v * dt * math.cos(mid)
            y += v * dt * math.sin(mid)
            th += w * dt
            c, s = math.cos(th), math.sin(th)

            best_d2, best_s, best_j = 1e30, 0.0, 0
            for j in range(n_seg):
                ax, ay = pxy[j, 0], pxy[j, 1]
                dx, dy = pxy[j + 1, 0] - ax, pxy[j + 1, 1] - ay
                l2 = max(dx * dx + dy * dy, 1e-12)
                tt = min(max(((x - ax) * dx + (y - ay) * dy) / l2, 0.0), 1.0)
                ex, ey = ax + tt * dx - x, ay + tt * dy - y
                d2 = ex * ex + ey * ey
                if d2 < best_d2:
                    best_d2, best_s, best_j = d2, ps[j] + tt * plen[j], j
            if best_d2 <= huber * huber:
                a_track += best_d2
            else:
                a_track += huber * (2.0 * math.sqrt(best_d2) - huber)
            a_head += 1.0 - (c * pcos[best_j] + s * psin[best_j])
            fi = best_s / vtab_ds
            i0 = min(max(int(fi), 0), n_tab - 2)
            fa = min(max(fi - i0, 0.0), 1.0)
            vref = vtab[i0] * (1.0 - fa) + vtab[i0 + 1] * fa
            a_ref += (v - vref) * (v - vref)
            hi_ex, lo_ex = max(v - win_hi, 0.0), max(win_lo - v, 0.0)
            a_win += hi_ex * hi_ex + lo_ex * lo_ex
            a_turn += w * w
            a_smooth += (v - vp) * (v - vp) + (w - wp) * (w - wp)
            vp, wp = v, w
            if s_exp[k] > 1e-3:
                short = max(1.0 - (best_s - s_now) / s_exp[k], 0.0)
                a_prog += short * (s_wt[0] + (s_wt[1] if k == t_n - 1 else 0.0))

            if has_wall or has_obs:
                cw, co = _clearances(
                    wall, wall_geo, has_wall, obs, obs_geo, has_obs,
                    x, y, c, s, fp, parts, part_r, part_idx, cuts,
                )  # fmt: skip
                if cw < inf_w:
                    a_wall += (1.0 - cw / inf_w) ** 2
                if co < inf_o:
                    a_obs += (1.0 - co / inf_o) ** 2
                if cw < thr_w or co < thr_o:
                    hit = True
            if goal_on:
                a_goal += math.sqrt((x - goal[0]) ** 2 + (y - goal[1]) ** 2)

        total = (
            wt[TRACK] * a_track
            + wt[HEADING] * a_head
            + wt[SPEED_REF] * a_ref
            + wt[SPEED_WINDOW] * a_win
            + wt[TURN] * a_turn
            + wt[SMOOTH] * a_smooth
            + wt[WALL] * a_wall
            + wt[OBSTACLE] * a_obs
            + wt[GOAL] * a_goal
            + wt[PROGRESS] * a_prog
        )
        cost[i] = total / t_n
        col[i] = hit
