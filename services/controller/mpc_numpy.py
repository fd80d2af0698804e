"""Evaluator 1 of the sampling MPC: numpy, vectorised over samples x steps (the reference).

For every sample: noise around its nominal sequence, clipping to the speed and acceleration
limits, the unicycle rollout, then the cost terms of ``mpc_costs.TERMS`` and the collision
flag. Slower than the numba kernel (``mpc_numba``), which computes the same arithmetic one
sample at a time; the tests hold the two to the same results. Pure computation.
"""

from __future__ import annotations

import math

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
)
from services.controller.mpc_scene import FAR, Body, Field, Scene


def rollout_poses(inputs: np.ndarray, x: float, y: float, theta: float, dt: float) -> np.ndarray:
    """Poses (K, T + 1, 3) of the unicycle driven by ``inputs`` (K, T, 2), midpoint heading.

    The model of the rear-axle point every evaluator rolls out: each step turns by w dt and
    moves v dt along the heading halfway through the step.
    """
    v = inputs[..., 0].astype(np.float64)
    w = inputs[..., 1].astype(np.float64)
    th = theta + np.concatenate([np.zeros((len(v), 1)), np.cumsum(w * dt, axis=1)], axis=1)
    mid = th[:, :-1] + 0.5 * w * dt
    xs = x + np.concatenate([np.zeros((len(v), 1)), np.cumsum(v * dt * np.cos(mid), 1)], 1)
    ys = y + np.concatenate([np.zeros((len(v), 1)), np.cumsum(v * dt * np.sin(mid), 1)], 1)
    return np.stack([xs, ys, th], axis=-1)


def lookup(f: Field, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Value of the cell each world point falls in; ``f.outside`` off the grid."""
    h, w = f.data.shape
    inv = np.float32(1.0 / f.res)
    c = np.floor((x - np.float32(f.ox)) * inv)
    r = np.floor((y - np.float32(f.oy)) * inv)
    off = (c < 0) | (r < 0) | (c >= w) | (r >= h)
    out = f.data[np.clip(r, 0, h - 1).astype(np.intp), np.clip(c, 0, w - 1).astype(np.intp)]
    out[off] = f.outside
    return out


def evaluate(
    body: Body,
    sc: Scene,
    noise: np.ndarray,
    nominal: np.ndarray,
    groups: np.ndarray,
    offsets: np.ndarray | None,
    u_out: np.ndarray,
    cost: np.ndarray,
    col: np.ndarray,
) -> None:
    """Noise, clipping, rollout and costs for all samples at once (one loop over steps).

    Sample i starts from ``nominal[groups[i]]`` (G, T, 2) plus ``noise[i]`` (K, T, 2, unit
    Gaussian, scaled and correlated here) plus ``offsets[i]`` if given; fills ``u_out``
    (the clipped inputs), ``cost`` (mean weighted cost per step) and ``col`` (colliding).
    """
    fp = body.points
    k, t = noise.shape[:2]
    x0, y0, th0, v0, w0 = sc.state
    dt, vmin, vmax, wmax, dvmax, dwmax = sc.limits
    sv, sw, rho = sc.sigma
    s_now, _, huber, _, inf_w, inf_o, win_lo, win_hi, thr_w, thr_o = sc.params
    f32 = np.float32
    eps = noise.copy()
    if rho > 0:
        beta = f32(math.sqrt(1.0 - rho * rho))
        for j in range(1, t):
            eps[:, j] = f32(rho) * eps[:, j - 1] + beta * noise[:, j]
    raw = eps * np.array([sv, sw], dtype=f32)
    raw += nominal[groups]
    if offsets is not None:
        raw += offsets
    vp = np.full(k, v0, dtype=f32)
    wp = np.full(k, w0, dtype=f32)
    for j in range(t):
        vp = np.clip(np.clip(raw[:, j, 0], vp - f32(dvmax), vp + f32(dvmax)), vmin, vmax)
        wp = np.clip(np.clip(raw[:, j, 1], wp - f32(dwmax), wp + f32(dwmax)), -wmax, wmax)
        u_out[:, j, 0] = vp
        u_out[:, j, 1] = wp
    v = u_out[..., 0]
    w = u_out[..., 1]
    poses = rollout_poses(u_out, x0, y0, th0, dt)[:, 1:].astype(f32)
    x, y, th = poses[..., 0], poses[..., 1], poses[..., 2]

    # path: nearest segment of the window
    best_d2 = np.full((k, t), np.inf, dtype=f32)
    best_s = np.zeros((k, t), dtype=f32)
    best_c = np.ones((k, t), dtype=f32)
    best_sn = np.zeros((k, t), dtype=f32)
    for j in range(len(sc.path_len)):
        ax, ay = sc.path_xy[j]
        dx, dy = sc.path_xy[j + 1] - sc.path_xy[j]
        l2 = max(dx * dx + dy * dy, 1e-12)
        tt = np.clip(((x - f32(ax)) * f32(dx) + (y - f32(ay)) * f32(dy)) / f32(l2), 0, 1)
        ex = f32(ax) + tt * f32(dx) - x
        ey = f32(ay) + tt * f32(dy) - y
        d2 = ex * ex + ey * ey
        better = d2 < best_d2
        best_d2 = np.where(better, d2, best_d2)
        best_s = np.where(better, f32(sc.path_s[j]) + tt * f32(sc.path_len[j]), best_s)
        best_c = np.where(better, f32(sc.path_cos[j]), best_c)
        best_sn = np.where(better, f32(sc.path_sin[j]), best_sn)
    c, s = np.cos(th), np.sin(th)
    head = 1.0 - (c * best_c + s * best_sn)
    fi = best_s / f32(sc.vtab_ds)
    i0 = np.clip(fi.astype(np.intp), 0, len(sc.vtab) - 2)
    a = np.clip(fi - i0, 0.0, 1.0)
    vref = sc.vtab[i0] * (1 - a) + sc.vtab[i0 + 1] * a
    window = np.maximum(v - f32(win_hi), 0) ** 2 + np.maximum(f32(win_lo) - v, 0) ** 2
    dv = np.diff(v, axis=1, prepend=np.full((k, 1), v0, dtype=f32))
    dw = np.diff(w, axis=1, prepend=np.full((k, 1), w0, dtype=f32))

    # clearance of every footprint check point
    qx = x[..., None] + c[..., None] * fp[:, 0] - s[..., None] * fp[:, 1]
    qy = y[..., None] + s[..., None] * fp[:, 0] + c[..., None] * fp[:, 1]
    cw = lookup(sc.wall, qx, qy).min(axis=2) if sc.wall else np.full((k, t), FAR, f32)
    co = lookup(sc.obs, qx, qy).min(axis=2) if sc.obs else np.full((k, t), FAR, f32)
    wall = np.maximum(1.0 - cw / f32(inf_w), 0) ** 2
    obst = np.maximum(1.0 - co / f32(inf_o), 0) ** 2
    col[:] = ((cw < thr_w) | (co < thr_o)).any(axis=1)
    goal = np.hypot(x - f32(sc.goal[0]), y - f32(sc.goal[1])) if sc.goal_on else 0.0

    # the weighted terms (mpc_costs.TERMS), progress last: it is charged on some steps only
    wt = sc.weights
    d = np.sqrt(best_d2)
    track = np.where(d <= huber, best_d2, f32(huber) * (2 * d - f32(huber)))
    per_step = (
        wt[TRACK] * track
        + wt[HEADING] * head
        + wt[SPEED_REF] * (v - vref) ** 2
        + wt[SPEED_WINDOW] * window
        + wt[TURN] * w * w
        + wt[SMOOTH] * (dv * dv + dw * dw)
        + wt[WALL] * wall
        + wt[OBSTACLE] * obst
        + wt[GOAL] * goal
    )
    s_exp = sc.s_exp.astype(f32)
    on = s_exp > 1e-3
    if on.any():
        short = np.maximum(1.0 - (best_s[:, on] - f32(s_now)) / s_exp[on], 0.0)
        per_step[:, on] += wt[PROGRESS] * sc.s_wt[0] * short
        if on[-1]:
            per_step[:, -1] += wt[PROGRESS] * sc.s_wt[1] * short[:, -1]
    cost[:] = per_step.sum(axis=1, dtype=np.float64) / t
