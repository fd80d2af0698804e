"""Guides of the sampling MPC: pure-pursuit rollouts of the path that seed a share of samples.

White noise of a few hundredths rad/s rarely adds up to the sustained turn a corner needs or
to the side step that passes an obstacle; a pure-pursuit rollout of the path (or of a lane
beside it, ``MPCConfig.guide_offsets_m``) holds them. ``guide_rollout`` is plain Python
(the numpy backend uses it as it is); ``guide_rollout_nb`` is the same function compiled by
numba (cached on disk).
"""

from __future__ import annotations

import math

import numba
import numpy as np


def guide_rollout(state, limits, pxy, ps, plen, vtab, vtab_ds, lookahead, offset, out):
    """Pure-pursuit rollout (turning on the spot beyond 60 degrees) with the model's limits.

    The look-ahead point, ``lookahead`` m further along the path window ``pxy`` (arc
    lengths ``ps``, segment lengths ``plen``), is moved ``offset`` m to the left of the
    path (right if negative). Speeds follow ``vtab`` (v_ref every ``vtab_ds`` m of arc
    length). Writes the inputs (T, 2) into ``out``.
    """
    x, y, th, vp, wp = state[0], state[1], state[2], state[3], state[4]
    dt, vmin, vmax, wmax, dvmax, dwmax = (
        limits[0],
        limits[1],
        limits[2],
        limits[3],
        limits[4],
        limits[5],
    )
    n_seg = plen.shape[0]
    n_tab = vtab.shape[0]
    for k in range(out.shape[0]):
        best_d2, best_s = 1e30, 0.0
        for j in range(n_seg):
            ax, ay = pxy[j, 0], pxy[j, 1]
            dx, dy = pxy[j + 1, 0] - ax, pxy[j + 1, 1] - ay
            l2 = max(dx * dx + dy * dy, 1e-12)
            tt = min(max(((x - ax) * dx + (y - ay) * dy) / l2, 0.0), 1.0)
            d2 = (ax + tt * dx - x) ** 2 + (ay + tt * dy - y) ** 2
            if d2 < best_d2:
                best_d2, best_s = d2, ps[j] + tt * plen[j]
        st = min(best_s + lookahead, ps[n_seg])
        j = 0
        while j < n_seg - 1 and ps[j + 1] < st:
            j += 1
        f = min(max((st - ps[j]) / max(plen[j], 1e-12), 0.0), 1.0)
        sx, sy = pxy[j + 1, 0] - pxy[j, 0], pxy[j + 1, 1] - pxy[j, 1]
        n = max(math.sqrt(sx * sx + sy * sy), 1e-12)
        dx = pxy[j, 0] + f * sx - offset * sy / n - x
        dy = pxy[j, 1] + f * sy + offset * sx / n - y
        dist = math.sqrt(dx * dx + dy * dy)
        alpha = math.atan2(dy, dx) - th
        alpha = math.atan2(math.sin(alpha), math.cos(alpha))
        fi = best_s / vtab_ds
        i0 = min(max(int(fi), 0), n_tab - 2)
        fa = min(max(fi - i0, 0.0), 1.0)
        vref = vtab[i0] * (1.0 - fa) + vtab[i0 + 1] * fa
        if dist < 1e-3:
            v, w = 0.0, 0.0
        elif abs(alpha) > math.pi / 3:
            v, w = 0.0, 2.0 * alpha
        else:
            v = max(vref, 0.0) * math.cos(alpha)
            w = 2.0 * v * math.sin(alpha) / dist
        v = min(max(min(max(v, vp - dvmax), vp + dvmax), vmin), vmax)
        w = min(max(min(max(w, wp - dwmax), wp + dwmax), -wmax), wmax)
        out[k, 0] = v
        out[k, 1] = w
        mid = th + 0.5 * w * dt
        x += v * dt * math.cos(mid)
        y += v * dt * math.sin(mid)
        th += w * dt
        vp, wp = v, w


guide_rollout_nb = numba.njit(cache=True, fastmath=True)(guide_rollout)


def warm_up() -> None:
    """Compile (or load) ``guide_rollout_nb`` now, not in the first MPC cycle: a two-point
    path with the argument types ``SamplingMPC._guide`` passes (float64 state, limits, path
    window and speed table, float scalars, a float32 (T, 2) row of the nominal inputs)."""
    guide_rollout_nb(
        np.zeros(5),
        np.array([0.2, -0.3, 1.0, 1.0, 0.1, 0.2]),
        np.array([[0.0, 0.0], [1.0, 0.0]]),
        np.array([0.0, 1.0]),
        np.array([1.0]),
        np.array([0.3, 0.3, 0.0]),
        0.5,
        0.8,
        0.0,
        np.empty((3, 2), dtype=np.float32),
    )
