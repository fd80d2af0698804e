"""Sampling MPC path follower: noisy input sequences, unicycle rollouts, costs, one command.

The seed system's path-following controller, rebuilt without its weak points. Each cycle:

1. take the previous best input sequence, shifted by the *real* time since the last call
   (the seed shifted by one 0.3 s step while its loop ran at 0.2 s), and add Gaussian noise
   to get ``samples`` candidate sequences of ``steps`` (v, w) pairs; a share of them is
   drawn around pure-pursuit guides of the path and of lanes beside it;
2. roll every candidate out on the unicycle model of the rear-axle point, clipping each step
   to the chair's speed and acceleration limits;
3. score every rollout: cross-track distance, progress, heading, speed window, speed
   reference, turn effort, smoothness, goal approach, and the footprint's clearance from the
   map's walls (a distance field) and from live LiDAR points; a rollout whose footprint
   comes closer than ``safety_margin_m`` to either is colliding and dropped (where the
   chair already stands that near, only nearer than now is);
4. select: MPPI (softmax-weighted mean) or the seed's rule (mean of the best-5 % cluster
   that holds the best sample); return the first input and keep the sequence.

When every candidate collides the chair stops and reports ``blocked`` (the seed had no
fallback). Two interchangeable evaluators share the same arithmetic: a numpy one
(vectorised over samples x steps, the reference) and a numba kernel (the default, about
ten times faster). Pure computation: no I/O, no clock.

The pieces, top-down:

* this module: :class:`SamplingMPC` (the cycle: sampling, warm start, selection);
* ``shared.config.MPCConfig``: every tuning value, the fleet's ``controller.mpc`` section;
* ``mpc_costs``: the cost terms, declared once (name, weight, what each charges);
* ``mpc_scene``: what rollouts are scored against (footprint, distance fields, the path);
* ``mpc_guides``: the pure-pursuit guides that seed samples;
* ``mpc_numpy``, ``mpc_numba``: evaluator 1 (reference) and evaluator 2 (kernel).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from services.controller import mpc_costs, mpc_numba, mpc_numpy
from services.controller.command import Command
from services.controller.mpc_guides import guide_rollout, guide_rollout_nb
from services.controller.mpc_numpy import rollout_poses
from services.controller.mpc_scene import (
    FAR,
    Field,
    Scene,
    footprint_body,
    footprint_points,
    obstacle_field,
    simplify,
    wall_field,
)
from shared.config import ControllerConfig, MPCConfig, RobotConfig
from shared.normals import NormalStream

__all__ = ["Evaluation", "MPCConfig", "SamplingMPC", "footprint_points", "rollout_poses"]


NEAR_SPEED = 0.1  # m/s: the fastest a cycle samples nearer than the margin (_threshold)
NEAR_TURN = 0.3  # rad/s
NOISE_THREAD = "controller-noise"  # draws the next cycle's noise (shared/normals.py)
THR_WALL, THR_OBS = 8, 9  # where Scene.params holds each field's collision reading


@dataclass
class Evaluation:
    """Scores of explicit input sequences (see ``SamplingMPC.evaluate``)."""

    cost: np.ndarray  # (K,) total cost
    colliding: np.ndarray  # (K,) footprint came closer than the safety margin
    inputs: np.ndarray  # (K, T, 2) the sequences after speed and acceleration clipping
    poses: np.ndarray  # (K, T + 1, 3) the rollouts, initial pose first


class SamplingMPC:
    """Follows one path at a time with a sampling MPC; see the module docstring.

    ``goal_tolerance_m``: "arrived" within this distance of the last waypoint; it is the
    controller's one tolerance (``controller.goal_tolerance_m``, shared with pure pursuit)
    and defaults to that key's default.
    """

    def __init__(
        self,
        cfg: MPCConfig,
        robot: RobotConfig,
        goal_tolerance_m: float | None = None,
        lag_s: float | None = None,
    ) -> None:
        cfg.validate()
        self.cfg = cfg
        self.robot = robot
        self.goal_tolerance_m = (
            ControllerConfig().goal_tolerance_m if goal_tolerance_m is None else goal_tolerance_m
        )
        self.lag_s = ControllerConfig().brake_latency_s if lag_s is None else lag_s
        self._noise_shape = (cfg.samples, cfg.steps, 2)
        self._noise_size = math.prod(self._noise_shape)  # one cycle's block
        self._noise = NormalStream(np.random.default_rng(cfg.seed), self._noise_size, NOISE_THREAD)
        self._body = footprint_body(robot.footprint, cfg.footprint_spacing_m, cfg.safety_margin_m)
        self._u = np.empty((cfg.samples, cfg.steps, 2), dtype=np.float32)
        self._cost = np.empty(cfg.samples)
        self._col = np.empty(cfg.samples, dtype=np.bool_)
        self._groups, self._exact = _sample_groups(cfg)
        self._weights = mpc_costs.weights(cfg)
        self._wall: Field | None = None
        self._nominal: np.ndarray | None = None
        self._sent = (0.0, 0.0)  # the last command returned (while _nominal is kept)
        self.last_plan = np.zeros((0, 3))  # poses of the chosen sequence, for display
        self.last_colliding = 0.0  # share of samples dropped as colliding last cycle
        self.blocked_note = ""  # why the last cycle was blocked, for the node's log
        self.set_path(np.zeros((0, 2)), np.zeros(0))

    # -- inputs ---------------------------------------------------------------------------

    def set_path(self, waypoints: np.ndarray, v_ref: np.ndarray) -> None:
        """Follow ``waypoints`` (N, 2) at speeds ``v_ref`` (N,); an empty path means stop."""
        pts = np.asarray(waypoints, dtype=np.float64).reshape(-1, 2)
        vr = np.asarray(v_ref, dtype=np.float64).reshape(-1)
        if len(vr) != len(pts):
            raise ValueError(f"{len(pts)} waypoints but {len(vr)} speeds")
        self._pts = pts
        legs = np.linalg.norm(np.diff(pts, axis=0), axis=1)
        self._s = np.concatenate([[0.0], np.cumsum(legs)]) if len(pts) else np.zeros(0)
        self._total = float(self._s[-1]) if len(pts) else 0.0
        keep = simplify(pts, 0.01) if len(pts) > 1 else np.arange(len(pts))
        self._spts = pts[keep] if len(pts) > 1 else np.repeat(pts, 2, axis=0)
        self._ss = self._s[keep] if len(pts) > 1 else np.zeros(2 * len(pts))
        self._vtab_ds = 0.05
        n = int(self._total / self._vtab_ds) + 2
        grid = np.arange(n) * self._vtab_ds
        self._vtab = np.interp(grid, self._s, vr) if len(pts) else np.zeros(n)
        self._target = 1 if len(pts) > 1 else 0
        self._progress_s = 0.0
        self._arrived = False
        self._nominal = None

    def set_distance_field(
        self, dist: np.ndarray, resolution: float, origin: tuple[float, float]
    ) -> None:
        """Use ``dist`` (metres to the nearest wall per cell, row 0 at the bottom) for walls.

        Cell (r, c) has its centre at ``origin + ((c + .5) * res, (r + .5) * res)``; off the
        grid is a wall (see ``mpc_scene.wall_field``).
        """
        self._wall = wall_field(dist, resolution, origin)

    def reset(self) -> None:
        """Forget the warm start (the next cycle samples around a cold guess)."""
        self._nominal = None

    # -- the cycle ------------------------------------------------------------------------

    def step(
        self,
        x: float,
        y: float,
        theta: float,
        v: float,
        w: float,
        obstacles: np.ndarray | None = None,
        period_s: float | None = None,
    ) -> Command:
        """One control cycle from pose (x, y, theta) and measured speeds (v, w).

        ``obstacles`` are world-frame LiDAR points (M, 2); ``period_s`` is the real time
        since the previous call (``dt`` if not given), used to shift the warm start and to
        bound the change of the returned command by the acceleration limits.
        """
        if len(self._pts) == 0:
            return Command(0.0, 0.0, "idle")
        sent = self._sent if self._nominal is not None else None  # last cycle's command
        self.blocked_note = ""
        if not all(map(math.isfinite, (x, y, theta, v, w))):
            self._nominal = None
            return Command(0.0, 0.0, "stale")  # no usable state: stop
        cfg = self.cfg
        period = cfg.dt if period_s is None or not period_s > 0 else float(period_s)
        self._target = self._target_at(x, y)
        s_now, cross = self._project(x, y, self._target)
        self._progress_s = max(self._progress_s, s_now)
        goal = self._pts[-1]
        to_goal = math.hypot(goal[0] - x, goal[1] - y)
        progress = self._progress_s / self._total if self._total > 0 else 1.0
        last_leg = self._target >= len(self._pts) - 1
        if self._arrived or (last_leg and to_goal <= self.goal_tolerance_m):
            self._arrived = True
            self._nominal = None
            return Command(0.0, 0.0, "arrived", 1.0, to_goal, cross)

        scene = self._scene(x, y, theta, v, w, s_now, obstacles, last_leg, to_goal)
        lanes = cfg.guide_offsets_m if cfg.guide_fraction > 0 else []
        nominal = np.empty((1 + len(lanes), cfg.steps, 2), dtype=np.float32)
        for lane, offset in enumerate(lanes):
            self._guide(scene, offset, nominal[1 + lane])
        if self._nominal is not None:
            nominal[0] = self._shifted(period)
        else:  # cold start: around the first guide (or standing still), wider in w
            nominal[0] = nominal[1] if lanes else 0.0
            scene.sigma[1] = cfg.sigma_w_cold
        noise = self._noise.take(self._noise_size).reshape(self._noise_shape)
        noise[self._exact] = 0.0  # the warm start and each guide as they are
        self._run(scene, noise, nominal, self._u, self._cost, self._col, self._groups)
        valid = ~self._col
        if not valid.any() and self._loosen(scene):
            self._run(scene, noise, nominal, self._u, self._cost, self._col, self._groups)
            valid = ~self._col
        self._noise.ahead()
        self.last_colliding = float(1.0 - valid.mean())
        if not valid.any():
            self._nominal = None
            self.last_plan = np.zeros((0, 3))
            self.blocked_note = self._blocked_note(scene, x, y, theta)
            return Command(0.0, 0.0, "blocked", progress, to_goal, cross)

        best = int(np.argmin(np.where(valid, self._cost, np.inf)))
        pick = self._mppi if cfg.selection == "mppi" else self._cluster
        seq = pick(valid, best, scene)
        if self._collides(scene, seq):  # averaging two ways round an obstacle may hit it
            seq = self._u[best].copy()
        self._nominal = seq
        self.last_plan = rollout_poses(seq[None], x, y, theta, cfg.dt)[0]
        cmd_v, cmd_w = self._limit(float(seq[0, 0]), float(seq[0, 1]), v, w, period, sent)
        self._sent = (cmd_v, cmd_w)
        return Command(cmd_v, cmd_w, "following", progress, to_goal, cross)

    def evaluate(
        self,
        x: float,
        y: float,
        theta: float,
        v: float,
        w: float,
        inputs: np.ndarray,
        obstacles: np.ndarray | None = None,
    ) -> Evaluation:
        """Score explicit input sequences (K, T, 2) from a state, as a cycle would (no noise)."""
        seq = np.ascontiguousarray(inputs, dtype=np.float32)
        if seq.ndim != 3 or seq.shape[1:] != (self.cfg.steps, 2):
            raise ValueError(f"inputs must be (K, {self.cfg.steps}, 2), got {seq.shape}")
        if len(self._pts) == 0:
            raise ValueError("evaluate needs a path (set_path first)")
        target = self._target_at(x, y)
        s_now, _ = self._project(x, y, target)
        goal = self._pts[-1]
        to_goal = math.hypot(goal[0] - x, goal[1] - y)
        last_leg = target >= len(self._pts) - 1
        scene = self._scene(x, y, theta, v, w, s_now, obstacles, last_leg, to_goal)
        k = len(seq)
        out = np.empty_like(seq)
        cost, col = np.empty(k), np.empty(k, dtype=np.bool_)
        zero = np.zeros((1, self.cfg.steps, 2), np.float32)
        groups = np.zeros(k, dtype=np.int64)
        self._run(scene, np.zeros_like(seq), zero, out, cost, col, groups, offsets=seq)
        return Evaluation(cost, col, out, rollout_poses(out, x, y, theta, self.cfg.dt))

    # -- pieces of the cycle --------------------------------------------------------------

    def _target_at(self, x: float, y: float) -> int:
        """The seed's rule: the target advances once the pose passes the plane through it
        normal to the incoming leg (several at once if several are passed)."""
        pts, n, tgt = self._pts, len(self._pts), self._target
        while 1 <= tgt < n - 1:
            a, b = pts[tgt - 1], pts[tgt]
            if (x - b[0]) * (b[0] - a[0]) + (y - b[1]) * (b[1] - a[1]) < 0:
                break
            tgt += 1
        return tgt

    def _project(self, x: float, y: float, target: int) -> tuple[float, float]:
        """Arc length and distance of the nearest point on the target's leg or the next."""
        pts, n = self._pts, len(self._pts)
        if n == 1:
            return 0.0, math.hypot(x - pts[0, 0], y - pts[0, 1])
        best_d, best_s = math.inf, 0.0
        for j in range(max(0, target - 1), min(target + 1, n - 1)):
            a, b = pts[j], pts[j + 1]
            dx, dy = b[0] - a[0], b[1] - a[1]
            l2 = max(dx * dx + dy * dy, 1e-12)
            t = min(1.0, max(0.0, ((x - a[0]) * dx + (y - a[1]) * dy) / l2))
            d = math.hypot(a[0] + t * dx - x, a[1] + t * dy - y)
            if d < best_d:
                best_d, best_s = d, float(self._s[j] + t * math.sqrt(l2))
        return best_s, best_d

    def _expected_progress(self, s_now: float) -> np.ndarray:
        """Arc length the path's v_ref would cover from ``s_now`` by each step (T,).

        The progress term charges the shortfall against it, never rewards more: a plain
        reward for arc length would also push the chair past v_ref. ``progress_running``
        of it is charged at every step, the rest at the horizon's end. Charging only the
        end let a rollout wait first and hurry later for the same cost, and with clearance
        costs ahead (a 1.0 m door) waiting was cheaper: as the horizon receded the chair
        dithered before the door for ever. Charging only the steps makes it rush straight
        at an obstacle and turn too late (the box scene), hence the blend.
        """
        s, ds, n = s_now, self._vtab_ds, len(self._vtab)
        out = np.empty(self.cfg.steps)
        for k in range(self.cfg.steps):
            s += self._vtab[min(int(s / ds), n - 1)] * self.cfg.dt
            out[k] = min(s, self._total) - s_now
        return out

    def _horizon_reach(self) -> float:
        """How far any rollout can get (m)."""
        return self.robot.max_speed * self.cfg.steps * self.cfg.dt

    def _scene(
        self,
        x: float,
        y: float,
        theta: float,
        v: float,
        w: float,
        s_now: float,
        obstacles: np.ndarray | None,
        last_leg: bool,
        to_goal: float,
    ) -> Scene:
        """Arrays for one evaluation: limits, the path window around ``s_now``, fields."""
        cfg, r = self.cfg, self.robot
        reach = self._horizon_reach()
        lo = np.searchsorted(self._ss, s_now - 0.5, side="right") - 1
        ahead = s_now + reach + cfg.guide_lookahead_m + 0.5
        hi = np.searchsorted(self._ss, ahead, side="left")
        lo = int(min(max(lo, 0), len(self._ss) - 2))
        hi = int(min(max(hi, lo + 1), len(self._ss) - 1))
        pxy = np.ascontiguousarray(self._spts[lo : hi + 1])
        d = np.diff(pxy, axis=0)
        seg = np.hypot(d[:, 0], d[:, 1])
        safe = np.maximum(seg, 1e-12)
        limits = np.array(
            [
                cfg.dt,
                -r.max_reverse_speed,
                r.max_speed,
                r.max_turn_rate,
                r.max_accel * cfg.dt,
                r.max_turn_accel * cfg.dt,
            ]
        )
        s_exp = self._expected_progress(s_now)
        obs = obstacle_field(
            obstacles,
            x,
            y,
            cfg.obstacle_resolution_m,
            max(cfg.obstacle_influence_m, self._body.threshold),
            self._body,
            reach,
        )
        thr_w = self._threshold(self._wall, x, y, theta)
        thr_o = self._threshold(obs, x, y, theta)
        if min(thr_w, thr_o) < self._body.threshold:  # nearer than the margin: slowly
            limits[1] = max(limits[1], -NEAR_SPEED)
            limits[2] = min(limits[2], NEAR_SPEED)
            limits[3] = min(limits[3], NEAR_TURN)
        params = np.array(
            [
                s_now,
                s_exp[-1],
                cfg.track_huber_m,
                self._body.threshold,
                cfg.wall_influence_m,
                cfg.obstacle_influence_m,
                cfg.v_window_min,
                cfg.v_window_max,
                thr_w,  # THR_WALL
                thr_o,  # THR_OBS
            ]
        )
        return Scene(
            state=np.array([x, y, theta, v, w], dtype=np.float64),
            limits=limits,
            sigma=np.array([cfg.sigma_v, cfg.sigma_w, cfg.noise_corr]),
            wall=self._wall,
            obs=obs,
            path_xy=pxy,
            path_s=np.ascontiguousarray(self._ss[lo : hi + 1]),
            path_len=seg,
            path_cos=np.where(seg > 0, d[:, 0] / safe, 1.0),
            path_sin=np.where(seg > 0, d[:, 1] / safe, 0.0),
            vtab=self._vtab,
            vtab_ds=self._vtab_ds,
            goal=self._pts[-1].copy(),
            goal_on=bool(last_leg and to_goal < cfg.goal_radius_m),
            params=params,
            s_exp=s_exp,
            s_wt=np.array([cfg.progress_running, (1.0 - cfg.progress_running) * cfg.steps]),
            weights=self._weights,
        )

    def _threshold(self, f: Field | None, x: float, y: float, theta: float) -> float:
        """The reading in ``f`` below which a rollout collides.

        The footprint's margin; but where the chair already stands nearer than that (beside
        an open leaf after a pass), what it reads now: it may leave along or away, never
        nearer. Else every rollout would collide from its first step and it could not
        leave. The cycle then samples no faster than ``NEAR_SPEED`` and ``NEAR_TURN``: at
        speed each cycle started a little nearer than the last predicted, and that ratchet
        drove a corner into a wall at 0.5 m/s twice in the campaign (b6.m04, b9.m01).
        """
        return min(self._body.threshold, self._clearance_now(f, x, y, theta))

    @staticmethod
    def _collision_fields(scene: Scene) -> tuple[tuple[str, Field | None, int], ...]:
        """Each field a rollout may collide with: its name, the field, and where
        ``scene.params`` holds the reading a rollout may not go below."""
        return (("walls", scene.wall, THR_WALL), ("LiDAR", scene.obs, THR_OBS))

    def _blocked_note(self, scene: Scene, x: float, y: float, theta: float) -> str:
        """Why every rollout collided: each field's reading where the chair stands against
        the reading a rollout may not go below."""
        parts = []
        for name, f, i in self._collision_fields(scene):
            if f is not None:
                now = self._clearance_now(f, x, y, theta)
                parts.append(f"{name} {now:.3f} m (may not go below {scene.params[i]:.3f})")
        return "every rollout collides; read where it stands: " + (", ".join(parts) or "none")

    def _loosen(self, scene: Scene) -> bool:
        """Lower each threshold that is the chair's reading now (nearer than the margin:
        :meth:`_threshold`) by one cell of its field, for a second try when every rollout
        collided; False if none is. A check point crossing into the next cell may read a
        cell less without coming nearer: where the chair stood at a cell's lucky reading,
        5 cm beside an open leaf after a pass, every rollout read less and it stood
        "blocked" (door bench, 0.80 m hinged). Only then: in the first try, "nearer" stays
        exact, and the guard keeps the exact rule on the scan's points."""
        loosened = False
        for _, f, i in self._collision_fields(scene):
            if f is not None and scene.params[i] < self._body.threshold:
                scene.params[i] -= f.res
                loosened = True
        return loosened

    def _clearance_now(self, f: Field | None, x: float, y: float, theta: float) -> float:
        """The footprint's reading in ``f`` where the chair stands (FAR without a field)."""
        if f is None:
            return FAR
        c, s = math.cos(theta), math.sin(theta)
        pts = self._body.points.astype(np.float64)
        qx = (x + c * pts[:, 0] - s * pts[:, 1]).astype(np.float32)
        qy = (y + s * pts[:, 0] + c * pts[:, 1]).astype(np.float32)
        return float(mpc_numpy.lookup(f, qx, qy).min())

    def _shifted(self, period: float) -> np.ndarray:
        """The previous sequence shifted by ``period`` (interpolated), its last input held."""
        steps = self.cfg.steps
        t = np.arange(steps) + period / self.cfg.dt
        out = np.empty((steps, 2), dtype=np.float32)
        idx = np.arange(steps)
        for j in range(2):
            out[:, j] = np.interp(t, idx, self._nominal[:, j])
        return out

    def _guide(self, sc: Scene, offset: float, out: np.ndarray) -> None:
        """Pure pursuit of the path window shifted ``offset`` m to the left, into ``out``
        (see ``mpc_guides``: why guides seed a share of the samples)."""
        fn = guide_rollout_nb if self.cfg.backend == "numba" else guide_rollout
        fn(
            sc.state,
            sc.limits,
            sc.path_xy,
            sc.path_s,
            sc.path_len,
            sc.vtab,
            sc.vtab_ds,
            self.cfg.guide_lookahead_m,
            offset,
            out,
        )

    def _run(
        self,
        scene: Scene,
        noise: np.ndarray,
        nominal: np.ndarray,
        u_out: np.ndarray,
        cost: np.ndarray,
        col: np.ndarray,
        groups: np.ndarray,
        offsets: np.ndarray | None = None,
    ) -> None:
        """Fill ``u_out``, ``cost`` and ``col`` for nominal + noise (+ per-sample offsets).

        ``nominal`` is (G, T, 2); sample i starts from ``nominal[groups[i]]``.
        """
        args = (self._body, scene, noise, nominal, groups, offsets, u_out, cost, col)
        if self.cfg.backend == "numba":
            mpc_numba.evaluate(*args, self.cfg.threads)
        else:
            mpc_numpy.evaluate(*args)

    def _collides(self, scene: Scene, seq: np.ndarray) -> bool:
        """Whether one sequence's rollout collides (checks a selected mean sequence)."""
        cost, col = np.empty(1), np.empty(1, dtype=np.bool_)
        out = np.empty((1, *seq.shape), dtype=np.float32)
        nominal = seq[None].astype(np.float32)
        groups = np.zeros(1, dtype=np.int64)
        self._run(scene, np.zeros_like(out), nominal, out, cost, col, groups)
        return bool(col[0])

    def _mppi(self, valid: np.ndarray, best: int, scene: Scene) -> np.ndarray:
        """Softmax of -cost / lambda over the non-colliding samples, weighted mean sequence."""
        c = np.where(valid, self._cost, np.inf)
        wts = np.exp(-(c - c.min()) / self.cfg.temperature)
        wts /= wts.sum()
        flat = self._u.reshape(len(wts), -1)
        return (wts.astype(np.float32) @ flat).reshape(self.cfg.steps, 2)

    def _cluster(self, valid: np.ndarray, best: int, scene: Scene) -> np.ndarray:
        """The seed's rule: best ``top_fraction``, greedy clusters, mean of the best's cluster.

        Greedy clustering seeds its first cluster with the best sample and gives it every
        top sample whose trajectory stays within ``cluster_radius_m`` (mean gap) of it;
        later clusters never hold the best sample, so only this one is built.
        """
        idx = np.flatnonzero(valid)
        n_top = max(1, math.ceil(self.cfg.top_fraction * len(idx)))
        top = idx[np.argsort(self._cost[idx], kind="stable")[:n_top]]
        x, y, th = scene.state[:3]
        poses = rollout_poses(self._u[top], x, y, th, self.cfg.dt)[:, 1:, :2]
        gap = np.linalg.norm(poses - poses[0], axis=2).mean(axis=1)
        members = top[gap <= self.cfg.cluster_radius_m]
        return self._u[members].mean(axis=0)

    def _limit(
        self,
        v: float,
        w: float,
        v_now: float,
        w_now: float,
        period: float,
        sent: tuple[float, float] | None = None,
    ) -> tuple[float, float]:
        """Clip a command to what the accelerations allow, then to the limits.

        It changes by at most what the accelerations give in ``period`` from the last
        command ``sent`` (from the measured speeds when there is none), and leads the
        measured speeds by at most what they give in the period and the chair's lag
        (``lag_s``) together: the measured speed trails the command by the lag, and a
        command led by one period only set the chair off at a third of ``robot.max_accel``
        (the demo took 2.7 s to reach 0.5 m/s, 1.4 s lost against the ideal)."""
        r = self.robot
        ref_v, ref_w = (v_now, w_now) if sent is None else sent
        v = _window(v, ref_v, v_now, r.max_accel * period, r.max_accel * (period + self.lag_s))
        w = _window(
            w, ref_w, w_now, r.max_turn_accel * period, r.max_turn_accel * (period + self.lag_s)
        )
        v = min(max(v, -r.max_reverse_speed), r.max_speed)
        w = min(max(w, -r.max_turn_rate), r.max_turn_rate)
        return v, w


def _window(value: float, sent: float, now: float, step: float, lead: float) -> float:
    """``value`` within ``step`` of ``sent`` and ``lead`` of ``now``; within ``lead`` of
    ``now`` alone where the two do not meet (the chair was held while the command ran on)."""
    lo, hi = max(sent - step, now - lead), min(sent + step, now + lead)
    if lo > hi:
        lo, hi = now - lead, now + lead
    return min(max(value, lo), hi)


def _sample_groups(cfg: MPCConfig) -> tuple[np.ndarray, np.ndarray]:
    """Which nominal each sample starts from (0 = warm start, 1.. = guide lanes), and the
    samples that get no noise (sample 0 and the first of each lane)."""
    lanes = len(cfg.guide_offsets_m) if cfg.guide_fraction > 0 else 0
    n_guide = min(cfg.samples - 1, round(cfg.guide_fraction * cfg.samples)) if lanes else 0
    groups = np.zeros(cfg.samples, dtype=np.int64)
    groups[1 : 1 + n_guide] = 1 + np.arange(n_guide) * lanes // max(n_guide, 1)
    firsts = [0] + [
        1 + int(np.argmax(groups[1:] == g)) for g in range(1, lanes + 1) if (groups == g).any()
    ]
    return groups, np.array(firsts, dtype=np.int64)
