"""Sampling MPC path follower: noisy input sequences, unicycle rollouts, costs, one command.

The seed system's path-following controller, rebuilt without its weak points. Each cycle:

1. take the previous best input sequence, shifted by the *real* time since the last call
   (the seed shifted by one 0.3 s step while its loop ran at 0.2 s), and add Gaussian noise
   to get ``samples`` candidate sequences of ``steps`` (v, w) pairs;
2. roll every candidate out on the unicycle model of the rear-axle point, clipping each step
   to the chair's speed and acceleration limits;
3. score every rollout: cross-track distance, progress, heading, speed window, speed
   reference, turn effort, smoothness, goal approach, and the footprint's clearance from the
   map's walls (a distance field) and from live LiDAR points; a rollout whose footprint
   comes closer than ``safety_margin_m`` to either is colliding and dropped;
4. select: MPPI (softmax-weighted mean) or the seed's rule (mean of the best-5 % cluster
   that holds the best sample); return the first input and keep the sequence.

When every candidate collides the chair stops and reports ``blocked`` (the seed had no
fallback). Two interchangeable evaluators share the same arithmetic: a numpy one
(vectorised over samples x steps, the reference) and a numba kernel (the default, about
ten times faster). Pure computation: no I/O, no clock.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numba
import numpy as np
from scipy.ndimage import distance_transform_edt

from services.controller.pure_pursuit import Command
from shared.config import Footprint, RobotConfig

FAR = 1.0e3  # clearance (m) reported where nothing is near
_LANES = (0.0, -0.4, 0.4, -0.8, 0.8)  # default guide lanes: offsets left of the path (m)
_PARTS = (2, 2)  # footprint split lengthwise x crosswise; each part has a bounding circle


@dataclass
class MPCConfig:
    """Sampling-MPC tuning; costs are means over the horizon so weights hold for any length."""

    samples: int = 1000  # candidate input sequences per cycle
    steps: int = 21  # horizon length in model steps
    dt: float = 0.2  # model step (s); the warm start is shifted by the real loop period
    sigma_v: float = 0.10  # linear-speed noise (m/s) around the warm start
    sigma_w: float = 0.08  # angular-speed noise (rad/s) around the warm start
    sigma_w_cold: float = 0.3  # angular-speed noise on a cold start (no warm start yet)
    noise_corr: float = 0.0  # AR(1) correlation of the noise from one step to the next
    guide_fraction: float = 0.1  # share of samples drawn around pure-pursuit guides
    guide_lookahead_m: float = 0.8  # a guide steers to the path point this far ahead
    guide_offsets_m: list[float] = field(default_factory=lambda: list(_LANES))  # guide lanes
    selection: str = "mppi"  # "mppi" (softmax-weighted mean) or "cluster" (the seed's rule)
    temperature: float = 0.01  # MPPI lambda: lower trusts the best samples more
    top_fraction: float = 0.05  # cluster: share of the best samples kept
    cluster_radius_m: float = 0.15  # cluster: mean position gap for joining the best's cluster
    w_track: float = 2.0  # cross-track distance to the path: squared, linear beyond huber
    track_huber_m: float = 0.2  # beyond this the tracking cost grows linearly (side steps)
    w_progress: float = 1.0  # share of the arc length v_ref would cover that is not covered
    progress_running: float = 0.3  # part of that charged at every step, the rest at the end
    w_heading: float = 0.5  # 1 - cos(heading error to the nearest path segment)
    w_speed_ref: float = 0.5  # (v - v_ref)^2, v_ref from the path at the projected point
    w_speed_window: float = 10.0  # squared excess outside [v_window_min, v_window_max]
    v_window_min: float = -0.25  # lower end of the speed window (m/s)
    v_window_max: float = 0.55  # upper end of the speed window (m/s)
    w_turn: float = 0.1  # input effort: w^2
    w_smooth: float = 1.0  # (dv^2 + dw^2) between consecutive inputs
    w_wall: float = 1.0  # (1 - clearance / wall_influence_m)^2 against the map's walls
    wall_influence_m: float = 0.3  # wall clearance beyond which walls cost nothing
    w_obstacle: float = 1.0  # (1 - clearance / obstacle_influence_m)^2 against LiDAR points
    obstacle_influence_m: float = 0.5  # obstacle clearance beyond which points cost nothing
    w_goal: float = 1.0  # mean distance to the goal once within goal_radius_m of it
    goal_radius_m: float = 1.5  # the goal term starts this close to the last waypoint
    goal_tolerance_m: float = 0.15  # "arrived" within this distance of the last waypoint
    safety_margin_m: float = 0.05  # footprint closer than this to a wall/point: colliding
    footprint_spacing_m: float = 0.1  # largest gap between footprint check points
    obstacle_resolution_m: float = 0.05  # cell size of the per-cycle LiDAR distance field
    backend: str = "numba"  # "numba" (fast kernel) or "numpy" (vectorised reference)
    threads: int = 0  # numba kernel threads, 0 = all; 1 is steadier on a busy CPU
    seed: int = 0  # noise seed: a fixed seed gives the same commands for the same inputs

    def validate(self) -> None:
        """Raise ValueError on a setting the controller cannot run with."""
        if self.samples < 2 or self.steps < 1:
            raise ValueError("samples must be >= 2 and steps >= 1")
        if not (self.dt > 0 and self.temperature > 0 and self.footprint_spacing_m > 0):
            raise ValueError("dt, temperature and footprint_spacing_m must be > 0")
        if self.selection not in ("mppi", "cluster"):
            raise ValueError(f"selection must be mppi or cluster, got {self.selection!r}")
        if self.backend not in ("numba", "numpy"):
            raise ValueError(f"backend must be numba or numpy, got {self.backend!r}")
        if not 0.0 <= self.guide_fraction <= 1.0 or not self.guide_lookahead_m > 0:
            raise ValueError("guide_fraction must be in [0, 1], guide_lookahead_m > 0")
        if self.guide_fraction > 0 and not self.guide_offsets_m:
            raise ValueError("guide_offsets_m needs at least one lane when guide_fraction > 0")
        if not 0.0 <= self.noise_corr < 1.0:
            raise ValueError("noise_corr must be in [0, 1)")
        if self.threads < 0:
            raise ValueError("threads must be >= 0 (0 = all)")
        if not (self.wall_influence_m > 0 and self.obstacle_influence_m > 0):
            raise ValueError("influence distances must be > 0")
        if not 0.0 <= self.progress_running <= 1.0:
            raise ValueError("progress_running must be in [0, 1]")


@dataclass
class Evaluation:
    """Scores of explicit input sequences (see ``SamplingMPC.evaluate``)."""

    cost: np.ndarray  # (K,) total cost
    colliding: np.ndarray  # (K,) footprint came closer than the safety margin
    inputs: np.ndarray  # (K, T, 2) the sequences after speed and acceleration clipping
    poses: np.ndarray  # (K, T + 1, 3) the rollouts, initial pose first


def footprint_points(fp: Footprint, spacing: float) -> tuple[np.ndarray, float]:
    """Check points on the footprint's outline (body frame) and half the largest gap.

    Corners plus evenly spaced edge points at most ``spacing`` apart. A point obstacle that
    keeps ``d`` from every check point keeps ``sqrt(d^2 - gap^2)`` from the edges between
    them, so the collision threshold is widened by the half gap instead of adding points.
    """
    length = fp.front + fp.rear
    nx = max(1, math.ceil(length / spacing - 1e-9))
    ny = max(1, math.ceil(fp.width / spacing - 1e-9))
    xs = np.linspace(-fp.rear, fp.front, nx + 1)
    ys = np.linspace(-fp.width / 2, fp.width / 2, ny + 1)
    pts = [(x, ys[0]) for x in xs] + [(x, ys[-1]) for x in xs]
    pts += [(xs[0], y) for y in ys[1:-1]] + [(xs[-1], y) for y in ys[1:-1]]
    return np.array(pts, dtype=np.float32), 0.5 * max(length / nx, fp.width / ny)


def rollout_poses(inputs: np.ndarray, x: float, y: float, theta: float, dt: float) -> np.ndarray:
    """Poses (K, T + 1, 3) of the unicycle driven by ``inputs`` (K, T, 2), midpoint heading."""
    v = inputs[..., 0].astype(np.float64)
    w = inputs[..., 1].astype(np.float64)
    th = theta + np.concatenate([np.zeros((len(v), 1)), np.cumsum(w * dt, axis=1)], axis=1)
    mid = th[:, :-1] + 0.5 * w * dt
    xs = x + np.concatenate([np.zeros((len(v), 1)), np.cumsum(v * dt * np.cos(mid), 1)], 1)
    ys = y + np.concatenate([np.zeros((len(v), 1)), np.cumsum(v * dt * np.sin(mid), 1)], 1)
    return np.stack([xs, ys, th], axis=-1)


@dataclass
class _Field:
    """A distance field for lookups: values (H, W) float32, origin and resolution."""

    data: np.ndarray
    ox: float
    oy: float
    res: float
    outside: float  # value off the grid


@dataclass
class _Scene:
    """Everything one evaluation needs, prepared once per cycle (arrays ready for numba)."""

    state: np.ndarray  # x, y, theta, v, w
    limits: np.ndarray  # dt, v_min, v_max, w_max, dv_max, dw_max (per step)
    sigma: np.ndarray  # sigma_v, sigma_w, noise_corr
    wall: _Field | None
    obs: _Field | None
    path_xy: np.ndarray  # (S + 1, 2) window of the simplified path
    path_s: np.ndarray  # (S + 1,) arc length at those vertices
    path_len: np.ndarray  # (S,) segment lengths
    path_cos: np.ndarray  # (S,) segment heading cosines
    path_sin: np.ndarray  # (S,) segment heading sines
    vtab: np.ndarray  # v_ref sampled every vtab_ds metres of arc length
    vtab_ds: float
    goal: np.ndarray  # (2,)
    goal_on: bool
    params: np.ndarray  # s_now, expected progress, huber, threshold, influences, window
    s_exp: np.ndarray  # (T,) arc length v_ref would cover from s_now by each step
    s_wt: np.ndarray  # progress shortfall weights: every step, extra at the last step
    weights: np.ndarray  # see _WEIGHTS


_WEIGHTS = (
    "w_track",
    "w_heading",
    "w_speed_ref",
    "w_speed_window",
    "w_turn",
    "w_smooth",
    "w_wall",
    "w_obstacle",
    "w_goal",
    "w_progress",
)


# --------------------------------------------------------------------------------------
# The controller
# --------------------------------------------------------------------------------------


class SamplingMPC:
    """Follows one path at a time with a sampling MPC; see the module docstring."""

    def __init__(self, cfg: MPCConfig, robot: RobotConfig) -> None:
        cfg.validate()
        self.cfg = cfg
        self.robot = robot
        self._rng = np.random.default_rng(cfg.seed)
        pts, half_gap = footprint_points(robot.footprint, cfg.footprint_spacing_m)
        self._threshold = math.hypot(cfg.safety_margin_m, half_gap)
        self._fp, self._parts, self._part_r, self._part_idx = _footprint_parts(robot.footprint, pts)
        self._noise = np.empty((cfg.samples, cfg.steps, 2), dtype=np.float32)
        self._u = np.empty_like(self._noise)
        self._cost = np.empty(cfg.samples)
        self._col = np.empty(cfg.samples, dtype=np.bool_)
        self._groups, self._exact = _sample_groups(cfg)
        self._weights = np.array([getattr(cfg, n) for n in _WEIGHTS], dtype=np.float64)
        self._wall: _Field | None = None
        self._nominal: np.ndarray | None = None
        self.last_plan = np.zeros((0, 3))  # poses of the chosen sequence, for display
        self.last_colliding = 0.0  # share of samples dropped as colliding last cycle
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
        keep = _simplify(pts, 0.01) if len(pts) > 1 else np.arange(len(pts))
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

        Cell (r, c) has its centre at ``origin + ((c + .5) * res, (r + .5) * res)``. A point
        reads the value of the cell it falls in, lowered by half a cell diagonal so that
        the reading never exceeds the distance at the point itself; off the grid is a wall.
        """
        d = np.asarray(dist, dtype=np.float32)
        if d.ndim != 2 or min(d.shape) < 2:
            raise ValueError(f"distance field must be 2-D and at least 2 x 2, got {d.shape}")
        if not resolution > 0:
            raise ValueError(f"resolution must be > 0, got {resolution}")
        d = np.minimum(np.nan_to_num(d, nan=0.0, posinf=FAR), FAR) - np.float32(
            _half_diag(resolution)
        )
        d = np.ascontiguousarray(d, dtype=np.float32)
        self._wall = _Field(d, float(origin[0]), float(origin[1]), float(resolution), 0.0)

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
        if self._arrived or (last_leg and to_goal <= cfg.goal_tolerance_m):
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
        self._rng.standard_normal(out=self._noise, dtype=np.float32)
        self._noise[self._exact] = 0.0  # the warm start and each guide as they are
        self._run(scene, self._noise, nominal, self._u, self._cost, self._col, self._groups)
        valid = ~self._col
        self.last_colliding = float(1.0 - valid.mean())
        if not valid.any():
            self._nominal = None
            self.last_plan = np.zeros((0, 3))
            return Command(0.0, 0.0, "blocked", progress, to_goal, cross)

        best = int(np.argmin(np.where(valid, self._cost, np.inf)))
        pick = self._mppi if cfg.selection == "mppi" else self._cluster
        seq = pick(valid, best, scene)
        if self._collides(scene, seq):  # averaging two ways round an obstacle may hit it
            seq = self._u[best].copy()
        self._nominal = seq
        self.last_plan = rollout_poses(seq[None], x, y, theta, cfg.dt)[0]
        cmd_v, cmd_w = self._limit(float(seq[0, 0]), float(seq[0, 1]), v, w, period)
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
    ) -> _Scene:
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
        params = np.array(
            [
                s_now,
                s_exp[-1],
                cfg.track_huber_m,
                self._threshold,
                cfg.wall_influence_m,
                cfg.obstacle_influence_m,
                cfg.v_window_min,
                cfg.v_window_max,
            ]
        )
        return _Scene(
            state=np.array([x, y, theta, v, w], dtype=np.float64),
            limits=limits,
            sigma=np.array([cfg.sigma_v, cfg.sigma_w, cfg.noise_corr]),
            wall=self._wall,
            obs=self._obstacle_field(x, y, obstacles),
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

    def _obstacle_field(self, x: float, y: float, obstacles: np.ndarray | None) -> _Field | None:
        """Distance field of the LiDAR points that a rollout's footprint could come near.

        Points are stamped into a grid of ``obstacle_resolution_m`` over their bounding box
        (grown by what the cost and the early-out test read) clipped to the horizon's reach.
        Values are lowered by a whole cell diagonal: half for a point anywhere in its cell,
        half for the query point anywhere in its cell (see ``set_distance_field``).
        """
        if obstacles is None or len(obstacles) == 0:
            return None
        cfg = self.cfg
        pts = np.asarray(obstacles, dtype=np.float64)[:, :2]
        res = cfg.obstacle_resolution_m
        grow = max(cfg.obstacle_influence_m, self._threshold) + self._part_r + 3.0 * res
        reach = self._horizon_reach() + float(np.abs(self._fp).max()) * 1.5 + grow
        near = (np.abs(pts[:, 0] - x) <= reach) & (np.abs(pts[:, 1] - y) <= reach)
        pts = pts[near & np.isfinite(pts).all(axis=1)]
        if len(pts) == 0:
            return None
        lo = np.maximum(pts.min(axis=0) - grow, (x - reach, y - reach))
        hi = np.minimum(pts.max(axis=0) + grow, (x + reach, y + reach))
        shape = np.maximum(np.ceil((hi - lo) / res).astype(int), 2)
        cols = ((pts[:, 0] - lo[0]) / res).astype(int)
        rows = ((pts[:, 1] - lo[1]) / res).astype(int)
        free = np.ones((shape[1], shape[0]), dtype=bool)
        free[np.clip(rows, 0, shape[1] - 1), np.clip(cols, 0, shape[0] - 1)] = False
        dist = distance_transform_edt(free).astype(np.float32)
        dist *= np.float32(res)
        dist -= np.float32(2.0 * _half_diag(res))
        return _Field(dist, float(lo[0]), float(lo[1]), res, FAR)

    def _shifted(self, period: float) -> np.ndarray:
        """The previous sequence shifted by ``period`` (interpolated), its last input held."""
        steps = self.cfg.steps
        t = np.arange(steps) + period / self.cfg.dt
        out = np.empty((steps, 2), dtype=np.float32)
        idx = np.arange(steps)
        for j in range(2):
            out[:, j] = np.interp(t, idx, self._nominal[:, j])
        return out

    def _guide(self, sc: _Scene, offset: float, out: np.ndarray) -> None:
        """Pure pursuit of the path window shifted ``offset`` m to the left, into ``out``.

        Guides seed a share of the samples: white noise of a few hundredths rad/s rarely
        adds up to the sustained turn a corner needs or to the side step that passes an
        obstacle; a pure-pursuit rollout of the path (or of a lane beside it) holds them.
        """
        fn = _guide_nb if self.cfg.backend == "numba" else _guide_py
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
        scene: _Scene,
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
        if self.cfg.backend == "numba":
            wall, obs = scene.wall or _EMPTY, scene.obs or _EMPTY
            most = numba.config.NUMBA_NUM_THREADS
            numba.set_num_threads(min(self.cfg.threads, most) if self.cfg.threads else most)
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
                self._fp,
                self._parts,
                self._part_r,
                self._part_idx,
                wall.data,
                np.array([wall.ox, wall.oy, 1.0 / wall.res, wall.outside, _slack(wall)]),
                scene.wall is not None,
                obs.data,
                np.array([obs.ox, obs.oy, 1.0 / obs.res, obs.outside, _slack(obs)]),
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
        else:
            _evaluate_numpy(self._fp, scene, noise, nominal, groups, offsets, u_out, cost, col)

    def _collides(self, scene: _Scene, seq: np.ndarray) -> bool:
        """Whether one sequence's rollout collides (checks a selected mean sequence)."""
        cost, col = np.empty(1), np.empty(1, dtype=np.bool_)
        out = np.empty((1, *seq.shape), dtype=np.float32)
        nominal = seq[None].astype(np.float32)
        groups = np.zeros(1, dtype=np.int64)
        self._run(scene, np.zeros_like(out), nominal, out, cost, col, groups)
        return bool(col[0])

    def _mppi(self, valid: np.ndarray, best: int, scene: _Scene) -> np.ndarray:
        """Softmax of -cost / lambda over the non-colliding samples, weighted mean sequence."""
        c = np.where(valid, self._cost, np.inf)
        wts = np.exp(-(c - c.min()) / self.cfg.temperature)
        wts /= wts.sum()
        flat = self._u.reshape(len(wts), -1)
        return (wts.astype(np.float32) @ flat).reshape(self.cfg.steps, 2)

    def _cluster(self, valid: np.ndarray, best: int, scene: _Scene) -> np.ndarray:
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
        self, v: float, w: float, v_now: float, w_now: float, period: float
    ) -> tuple[float, float]:
        """Clip a command to what the accelerations allow in ``period``, then to the limits."""
        r = self.robot
        dv, dw = r.max_accel * period, r.max_turn_accel * period
        v = min(max(min(max(v, v_now - dv), v_now + dv), -r.max_reverse_speed), r.max_speed)
        w = min(max(min(max(w, w_now - dw), w_now + dw), -r.max_turn_rate), r.max_turn_rate)
        return v, w


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


def _footprint_parts(
    fp: Footprint, pts: np.ndarray
) -> tuple[np.ndarray, np.ndarray, float, np.ndarray]:
    """Split the footprint into ``_PARTS`` sub-rectangles for the early-out test.

    Returns the check points sorted by part, the parts' centres, the common radius of
    their bounding circles and where each part's points start (and the last ends).
    """
    nx, ny = _PARTS
    length = fp.front + fp.rear
    lx, ly = length / nx, fp.width / ny
    ix = np.minimum(((pts[:, 0] + fp.rear) / lx + 1e-6).astype(int), nx - 1)
    iy = np.minimum(((pts[:, 1] + fp.width / 2) / ly + 1e-6).astype(int), ny - 1)
    part = ix * ny + iy
    order = np.argsort(part, kind="stable")
    centres = np.array(
        [[-fp.rear + (i + 0.5) * lx, -fp.width / 2 + (j + 0.5) * ly]
         for i in range(nx) for j in range(ny)],
        dtype=np.float64,
    )  # fmt: skip
    starts = np.searchsorted(part[order], np.arange(nx * ny + 1)).astype(np.int64)
    return pts[order], centres, math.hypot(lx / 2, ly / 2), starts


def _half_diag(res: float) -> float:
    """Half a cell diagonal: how far a point can be from the centre of its cell."""
    return res * math.sqrt(0.5)


def _slack(f: _Field) -> float:
    """How far a reading at a point can undershoot the reading at a nearby centre, less the gap.

    Readings are cell values lowered by half a diagonal (h): reading(q) >= true(q) - 2h >=
    true(p) - |q - p| - 2h >= reading(p) - |q - p| - 2h.
    """
    return 2.0 * _half_diag(f.res)


def _simplify(pts: np.ndarray, tol: float) -> np.ndarray:
    """Indices of the vertices Douglas-Peucker keeps (collinear runs become one segment)."""
    keep = np.zeros(len(pts), dtype=bool)
    keep[0] = keep[-1] = True
    stack = [(0, len(pts) - 1)]
    while stack:
        i, j = stack.pop()
        if j <= i + 1:
            continue
        a, b = pts[i], pts[j]
        d = b - a
        n = math.hypot(d[0], d[1])
        rel = pts[i + 1 : j] - a
        if n < 1e-12:
            dist = np.hypot(rel[:, 0], rel[:, 1])
        else:
            dist = np.abs(rel[:, 0] * d[1] - rel[:, 1] * d[0]) / n
        k = int(np.argmax(dist))
        if dist[k] > tol:
            m = i + 1 + k
            keep[m] = True
            stack += [(i, m), (m, j)]
    return np.flatnonzero(keep)


_EMPTY = _Field(np.full((2, 2), FAR, dtype=np.float32), 0.0, 0.0, 1.0, FAR)
_NO_OFFSETS = np.zeros((1, 1, 2), dtype=np.float32)


# --------------------------------------------------------------------------------------
# Evaluator 1: numpy, vectorised over samples x steps (the reference)
# --------------------------------------------------------------------------------------


def _lookup_np(f: _Field, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Value of the cell each world point falls in; ``f.outside`` off the grid."""
    h, w = f.data.shape
    inv = np.float32(1.0 / f.res)
    c = np.floor((x - np.float32(f.ox)) * inv)
    r = np.floor((y - np.float32(f.oy)) * inv)
    off = (c < 0) | (r < 0) | (c >= w) | (r >= h)
    out = f.data[np.clip(r, 0, h - 1).astype(np.intp), np.clip(c, 0, w - 1).astype(np.intp)]
    out[off] = f.outside
    return out


def _evaluate_numpy(
    fp: np.ndarray,
    sc: _Scene,
    noise: np.ndarray,
    nominal: np.ndarray,
    groups: np.ndarray,
    offsets: np.ndarray | None,
    u_out: np.ndarray,
    cost: np.ndarray,
    col: np.ndarray,
) -> None:
    """Noise, clipping, rollout and costs for all samples at once (one loop over steps)."""
    k, t = noise.shape[:2]
    x0, y0, th0, v0, w0 = sc.state
    dt, vmin, vmax, wmax, dvmax, dwmax = sc.limits
    sv, sw, rho = sc.sigma
    s_now, _, huber, thr, inf_w, inf_o, win_lo, win_hi = sc.params
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
    cw = _lookup_np(sc.wall, qx, qy).min(axis=2) if sc.wall else np.full((k, t), FAR, f32)
    co = _lookup_np(sc.obs, qx, qy).min(axis=2) if sc.obs else np.full((k, t), FAR, f32)
    wall = np.maximum(1.0 - cw / f32(inf_w), 0) ** 2
    obst = np.maximum(1.0 - co / f32(inf_o), 0) ** 2
    col[:] = ((cw < thr) | (co < thr)).any(axis=1)
    goal = np.hypot(x - f32(sc.goal[0]), y - f32(sc.goal[1])) if sc.goal_on else 0.0

    wt = sc.weights
    d = np.sqrt(best_d2)
    track = np.where(d <= huber, best_d2, f32(huber) * (2 * d - f32(huber)))
    per_step = (
        wt[0] * track
        + wt[1] * head
        + wt[2] * (v - vref) ** 2
        + wt[3] * window
        + wt[4] * w * w
        + wt[5] * (dv * dv + dw * dw)
        + wt[6] * wall
        + wt[7] * obst
        + wt[8] * goal
    )
    s_exp = sc.s_exp.astype(f32)
    on = s_exp > 1e-3
    if on.any():
        short = np.maximum(1.0 - (best_s[:, on] - f32(s_now)) / s_exp[on], 0.0)
        per_step[:, on] += wt[9] * sc.s_wt[0] * short
        if on[-1]:
            per_step[:, -1] += wt[9] * sc.s_wt[1] * short[:, -1]
    cost[:] = per_step.sum(axis=1, dtype=np.float64) / t


# --------------------------------------------------------------------------------------
# Evaluator 2: numba, one fused pass per sample (the default)
# --------------------------------------------------------------------------------------


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

    A part of the footprint (see ``_PARTS``) whose bounding-circle centre reads more than
    radius + slack + cutoff cannot hold a point below the cutoff and is skipped; FAR then
    stands for "at least the cutoff". Each check point is transformed once for both fields.
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
    """Same arithmetic as ``_evaluate_numpy``, one sample per iteration, no temporaries."""
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
    cuts = np.array([max(inf_w, thr), max(inf_o, thr)])
    n_seg = plen.shape[0]
    n_tab = vtab.shape[0]
    for i in numba.prange(k_n):
        g = groups[i]
        x, y, th, vp, wp = x0, y0, th0, v0, w0
        ev, ew = 0.0, 0.0
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
                if cw < thr or co < thr:
                    hit = True
            if goal_on:
                a_goal += math.sqrt((x - goal[0]) ** 2 + (y - goal[1]) ** 2)

        total = (
            wt[0] * a_track
            + wt[1] * a_head
            + wt[2] * a_ref
            + wt[3] * a_win
            + wt[4] * a_turn
            + wt[5] * a_smooth
            + wt[6] * a_wall
            + wt[7] * a_obs
            + wt[8] * a_goal
            + wt[9] * a_prog
        )
        cost[i] = total / t_n
        col[i] = hit


def _guide_py(state, limits, pxy, ps, plen, vtab, vtab_ds, lookahead, offset, out):
    """Pure-pursuit rollout (turning on the spot beyond 60 degrees) with the model's limits.

    The look-ahead point is moved ``offset`` m to the left of the path (right if negative).
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


_guide_nb = numba.njit(cache=True, fastmath=True)(_guide_py)
