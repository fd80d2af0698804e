"""The controller's last check before a command leaves: stale inputs and the stop zone.

A command is replaced by zero (and the reason reported as the follow state) when the
pose is stale or lost, when no scan has arrived for ``scan_timeout_s``, or when a LiDAR
point lies in the stop zone: the strip in front of the footprint (behind it when
reversing), as wide as the chair plus ``robot.side_margin_m`` each side (in a precise pass
or docking ``controller.precise_side_margin_m``: beside an 0.80 m door an open leaf leaves
the chair 3-5 cm a side, and the wide strip caught it on every tick; the arc check below
keeps the same margin; in a smooth door pass only for points near the door, its jambs and
leaf, within ``controller.precise_near_door_m`` more than the door's width of a jamb).
Its length grows
with speed, as a protective field does: ``stop_distance_m`` at ``robot.max_speed``, in
proportion below, never under ``stop_min_distance_m`` nor under the braking distance plus
that; a docking crawl next to a wall
corner is not a hazard, a fixed 0.25 m strip held it for ever. Points beside the chair (a
door's jambs) do not stop it. Turning on the spot (slower than ``turn_check_below_mps``),
the footprint turned as far as the chair turns in ``turn_check_s`` (at most
``turn_check_deg``, and no further than the tracker has left to turn plus braking: a
docking turn 6.5 deg from done was held for ever by a leaf 13 deg ahead) must not come
within ``robot.side_margin_m`` of a point (docking
too: a turn through a 4.5 cm pinch beside a wall passed the narrow margin; held at the
wide one, the docker plans a manoeuvre out), or while a docking manoeuvre planned for a
tight room is under way, within ``controller.precise_side_margin_m`` (``turn_margin_m``),
nor nearer to one already that near (a corner swinging on into a wall); a slow turn
checked a full 15 degrees ahead held the chair beside an open leaf it was creeping away
from. Faster, the footprint along the arc it is driving, over the stop zone's length (its
turn capped the same way, straight on after),
must keep the same distance: turning at speed, a front corner swings into a wall beside
the straight strip (campaign b7.m03 stopped 0.9 cm from one). Pure: points come in the robot frame.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from shared.config import ControllerConfig, RobotConfig
from shared.geometry import footprint_gap, moves_close_in, swept_arc_poses, turn_closes_in
from shared.scan_band import band_points
from shared.scan_band import warm_up as warm_band

GUARD_SLACK_M = 0.05  # guard_points keeps this much beyond the farthest a check reaches


def stop_zone_hit(
    points: np.ndarray,
    robot: RobotConfig,
    v: float,
    stop_distance_m: float,
    band_m: float,
    half_width_m: float | None = None,
) -> bool:
    """True if a point (N, 3, robot frame) is in the strip the chair is about to drive into
    (``half_width_m`` each side of its centre line, by default
    ``robot.clearance_half_width_m``)."""
    if points is None or len(points) == 0 or abs(v) < 1e-3:
        return False
    fp = robot.footprint
    half = robot.clearance_half_width_m if half_width_m is None else half_width_m
    pts = points[np.abs(points[:, 2]) < band_m]
    lateral = np.abs(pts[:, 1]) <= half
    if v > 0:
        ahead = (pts[:, 0] >= fp.front) & (pts[:, 0] <= fp.front + stop_distance_m)
    else:
        ahead = (pts[:, 0] <= -fp.rear) & (pts[:, 0] >= -fp.rear - stop_distance_m)
    return bool(np.any(lateral & ahead))


def turn_sweep_hit(
    points: np.ndarray,
    robot: RobotConfig,
    w: float,
    angle_rad: float,
    band_m: float,
    margin_m: float | None = None,
) -> bool:
    """True if turning on the spot by ``angle_rad`` (the sign of ``w``) brings a point (N, 3,
    robot frame) within ``margin_m`` (by default ``robot.side_margin_m``) of the footprint,
    or one already that near nearer still: the corners of a chair turning in a small room
    sweep a circle the stop strip ahead never sees."""
    if points is None or len(points) == 0 or abs(w) < 1e-3:
        return False
    fp = robot.footprint
    margin = robot.side_margin_m if margin_m is None else margin_m
    pts = points[np.abs(points[:, 2]) < band_m][:, :2].astype(float)
    angle = float(np.sign(w)) * angle_rad
    return turn_closes_in(pts, fp.front, fp.rear, fp.width, margin, angle)


def arc_sweep_hit(
    points: np.ndarray,
    robot: RobotConfig,
    v: float,
    w: float,
    length_m: float,
    band_m: float,
    margin_m: float,
    max_turn_rad: float = math.inf,
) -> bool:
    """True if driving ``length_m`` along the arc of (``v``, ``w``) brings a point (N, 3,
    robot frame) within ``margin_m`` of the footprint, or one already that near nearer
    still: turning at speed, a front corner swings into a wall beside the straight strip.
    The arc turns at most ``max_turn_rad`` and goes straight on from there."""
    if points is None or len(points) == 0 or abs(v) < 1e-3:
        return False
    fp = robot.footprint
    pts = points[np.abs(points[:, 2]) < band_m][:, :2].astype(float)
    length = length_m if v > 0 else -length_m
    poses = swept_arc_poses(length, w / v, max_turn_rad, fp.front, fp.rear, fp.width)
    return moves_close_in(pts, fp.front, fp.rear, fp.width, margin_m, poses)


def braking_distance(v: float, robot: RobotConfig, cfg: ControllerConfig) -> float:
    """How far the chair runs on from speed ``v`` once told to stop: ``brake_latency_s``
    at that speed, then braking at ``robot.max_accel``."""
    return abs(v) * cfg.brake_latency_s + v * v / (2.0 * robot.max_accel)


def stop_zone_length(v: float, robot: RobotConfig, cfg: ControllerConfig) -> float:
    """How far beyond the footprint the stop zone reaches at speed ``v``: never less than
    the braking distance plus ``stop_min_distance_m`` (at 0.6 m/s the 0.25 m zone alone
    let the chair run 0.36 m, through what it had stopped for)."""
    share = min(1.0, abs(v) / robot.max_speed)
    braking = braking_distance(v, robot, cfg) + cfg.stop_min_distance_m
    return max(cfg.stop_min_distance_m, cfg.stop_distance_m * share, braking)


def turn_check_angle(
    w: float, robot: RobotConfig, cfg: ControllerConfig, turn_left_rad: float = math.inf
) -> float:
    """How far ahead (radians) a turn on the spot at ``w`` is checked: as far as the chair
    turns in ``turn_check_s``, at most ``turn_check_deg``, and no further than the
    ``turn_left_rad`` the tracker has left to turn plus what the chair turns on while it
    brakes. Campaign b7300w.m04: a docking turn with 6.5 deg to go, checked 15 deg ahead
    beside an open leaf, was held for ever where the turn itself swept clear."""
    return min(
        math.radians(cfg.turn_check_deg),
        abs(w) * cfg.turn_check_s,
        turn_left_rad + braking_turn(w, robot, cfg),
    )


def braking_turn(w: float, robot: RobotConfig, cfg: ControllerConfig) -> float:
    """How far (radians) the chair turns on from turn rate ``w`` once told to stop:
    ``brake_latency_s`` at that rate, then braking at ``robot.max_turn_accel``."""
    return abs(w) * cfg.brake_latency_s + w * w / (2.0 * robot.max_turn_accel)


def near_surface(points: np.ndarray, bin_rad: float, gap_m: float) -> np.ndarray:
    """One point per azimuth bin of ``bin_rad`` (0: every point as it is): the mean of the
    bin's nearest cluster, its points in order of range up to the first gap of more than
    ``gap_m``. The rings and beams that see one patch of a surface average out the LiDAR's
    range noise (it lies along the beam; a cluster, not a window from the nearest point,
    so one reading far out in the noise does not split its surface); what lies farther in
    the same direction is behind the nearer thing, as a planar LiDAR sees it, and a thing
    a few beams see is kept where it is read. A point with no place (NaN, inf) is left out."""
    if bin_rad <= 0 or len(points) == 0:
        return points
    r = np.hypot(points[:, 0], points[:, 1]).astype(np.float64)
    if not np.isfinite(r).all():  # no bin for a point with no place (NaN, inf)
        points, r = points[np.isfinite(r)], r[np.isfinite(r)]
        if len(points) == 0:
            return points
    b = np.floor((np.arctan2(points[:, 1], points[:, 0]) + math.pi) / bin_rad).astype(np.int64)
    if b.max() >= 4 * len(b) + 1024:  # bins far finer than the points: number the used ones
        b = np.unique(b, return_inverse=True)[1].astype(np.int64)
    src = np.ascontiguousarray(points)
    return _nearest_clusters(b, r, src, float(gap_m)).astype(points.dtype, copy=False)


def warm_up() -> None:
    """Compile (or load) :func:`near_surface`'s kernel and the band filter now, not on the
    first scan: float32 points as the scan brings them, float64 as tests pass them."""
    for dtype in (np.float32, np.float64):
        near_surface(np.ones((3, 3), dtype=dtype), 0.01, 0.03)
    warm_band()


@numba.njit(cache=True)
def _nearest_clusters(b: np.ndarray, r: np.ndarray, points: np.ndarray, gap_m: float) -> np.ndarray:
    """Per non-empty bin of ``b`` (ascending), the mean of its nearest cluster's points: the
    bin's points in order of ``r`` (ties: in input order) up to the first step over
    ``gap_m``. The same order and float64 sums as a lexsort by (bin, range) then
    ``np.bincount`` with weights, so the same values bit for bit, in one counting sort."""
    n, dims = points.shape
    n_bins = b.max() + 1
    first = np.zeros(n_bins + 1, dtype=np.int64)  # the bins' starts in the sorted order
    for i in range(n):
        first[b[i] + 1] += 1
    for k in range(n_bins):
        first[k + 1] += first[k]
    fill = first[:-1].copy()
    order = np.empty(n, dtype=np.int64)
    for i in range(n):  # stable: a bin keeps its points in input order
        order[fill[b[i]]] = i
        fill[b[i]] += 1
    out = np.empty((n_bins, dims), dtype=np.float64)
    used = 0
    for k in range(n_bins):
        lo, hi = first[k], first[k + 1]
        if lo == hi:
            continue
        for a in range(lo + 1, hi):  # insertion sort by range, stable (bins are small)
            i = order[a]
            c = a - 1
            while c >= lo and r[order[c]] > r[i]:
                order[c + 1] = order[c]
                c -= 1
            order[c + 1] = i
        end = lo + 1
        while end < hi and not r[order[end]] - r[order[end - 1]] > gap_m:
            end += 1
        for d in range(dims):
            total = 0.0
            for a in range(lo, end):
                total += np.float64(points[order[a], d])
            out[used, d] = total / (end - lo)
        used += 1
    return out[:used]


def guard_points(
    points: np.ndarray | None, robot: RobotConfig, cfg: ControllerConfig, band_m: float
) -> np.ndarray | None:
    """The scan points (N, 3, robot frame) any check of :func:`guard` can reach: inside the
    height band and near enough for the longest stop zone (at twice the top speed) or a
    turn's widest margin, averaged in azimuth bins of ``cfg.guard_bin_deg`` (their nearest
    clusters, split at gaps over ``cfg.guard_gap_m``: :func:`near_surface`): the simulator's
    1 cm range noise read a jamb 4.1 cm from the chair as 1.8 cm, inside the precise margin,
    and held it in an 0.80 m door. Worked out once per scan, it leaves the guard a few
    hundred points."""
    if points is None or len(points) == 0:
        return points
    fp = robot.footprint
    top = 2.0 * max(robot.max_speed, robot.max_reverse_speed)
    margin = max(robot.side_margin_m, cfg.precise_side_margin_m)
    reach = (
        stop_zone_length(top, robot, cfg)
        + float(np.hypot(max(fp.front, fp.rear), fp.width / 2))
        + margin
        + GUARD_SLACK_M
    )
    near = band_points(points, band_m, reach)
    return near_surface(near, math.radians(cfg.guard_bin_deg), cfg.guard_gap_m)


def guard(
    v: float,
    w: float,
    state: str,
    now: float,
    pose_ok: bool,
    scan_stamp: float | None,
    scan_points: np.ndarray | None,
    robot: RobotConfig,
    cfg: ControllerConfig,
    band_m: float,
    precise: bool = False,
    turn_margin_m: float | None = None,
    turn_left_rad: float = math.inf,
    precise_near: tuple[np.ndarray, float] | None = None,
) -> tuple[float, float, str]:
    """(v, w, state) after the safety checks; state names the reason when it stops.
    ``precise``: a precise pass or docking, whose margins are narrower (see the module doc);
    ``turn_margin_m``: the margin of a turn on the spot (a docking manoeuvre's, planned
    narrower in a tight room), else ``robot.side_margin_m``; ``turn_left_rad``: how far
    that turn has to go, when the tracker knows (see :func:`turn_check_angle`);
    ``precise_near``: where the narrow margin holds (see :func:`obstacle_check`)."""
    if not pose_ok:
        return 0.0, 0.0, "stale_pose" if state not in ("arrived", "idle") else state
    if state in ("arrived", "idle"):
        return v, w, state
    if scan_stamp is None or now - scan_stamp > cfg.scan_timeout_s:
        return 0.0, 0.0, "stale_scan"
    held = obstacle_check(
        v, w, scan_points, robot, cfg, band_m, precise, turn_margin_m, turn_left_rad, precise_near
    )
    if held:
        return 0.0, 0.0, "obstacle"
    return v, w, state


def split_near(
    points: np.ndarray | None, centres: np.ndarray, radius: float
) -> tuple[np.ndarray | None, np.ndarray | None]:
    """The points (N, 3) within ``radius`` of one of ``centres`` (K, 2; same frame) in the
    plane, and the rest."""
    if points is None or len(points) == 0:
        return points, points
    c = np.asarray(centres, dtype=float).reshape(-1, 2)
    dx = points[:, 0, None].astype(float) - c[None, :, 0]
    dy = points[:, 1, None].astype(float) - c[None, :, 1]
    near = (dx * dx + dy * dy <= radius * radius).any(axis=1)
    return points[near], points[~near]


def obstacle_check(
    v: float,
    w: float,
    scan_points: np.ndarray | None,
    robot: RobotConfig,
    cfg: ControllerConfig,
    band_m: float,
    precise: bool = False,
    turn_margin_m: float | None = None,
    turn_left_rad: float = math.inf,
    precise_near: tuple[np.ndarray, float] | None = None,
) -> str:
    """Which of :func:`guard`'s obstacle checks holds (v, w): "strip" (a point in the stop
    zone), "arc" (the footprint along the arc it drives), "turn" (a turn on the spot), or
    "" for none. The node logs it, with the nearest point, when a hold starts.
    ``precise_near`` (centres (K, 2) in the robot frame, radius): where a precise pass keeps
    its narrow margin (a door's jambs and leaf); other points keep ``robot.side_margin_m``.
    Without it a precise pass keeps the narrow margin everywhere (docking, lift cars)."""
    wide = robot.side_margin_m
    if precise and precise_near is not None:
        near, far = split_near(scan_points, *precise_near)
        groups = [(near, cfg.precise_side_margin_m), (far, wide)]
    else:
        groups = [(scan_points, cfg.precise_side_margin_m if precise else wide)]
    length = stop_zone_length(v, robot, cfg)
    for pts, margin in groups:
        if stop_zone_hit(pts, robot, v, length, band_m, robot.footprint.width / 2 + margin):
            return "strip"
    turning = abs(v) < cfg.turn_check_below_mps
    turn_end = turn_left_rad + braking_turn(w, robot, cfg)
    if not turning:
        for pts, margin in groups:
            if arc_sweep_hit(pts, robot, v, w, length, band_m, margin, turn_end):
                return "arc"
    angle = turn_check_angle(w, robot, cfg, turn_left_rad)
    turn_margin = robot.side_margin_m if turn_margin_m is None else turn_margin_m
    if turning and turn_sweep_hit(scan_points, robot, w, angle, band_m, turn_margin):
        return "turn"
    return ""


def describe_hold(
    check: str,
    v: float,
    w: float,
    scan_points: np.ndarray | None,
    robot: RobotConfig,
    band_m: float,
) -> str:
    """One line on why :func:`guard` holds (v, w): the ``check`` that holds (see
    :func:`obstacle_check`) and the scan point nearest the footprint (chair frame), for the
    log when a hold starts."""
    text = f"{check or 'no'} check, command v {v:.2f} m/s w {w:.2f} rad/s"
    if scan_points is None or len(scan_points) == 0:
        return text
    fp = robot.footprint
    pts = scan_points[np.abs(scan_points[:, 2]) < band_m][:, :2].astype(float)
    if len(pts) == 0:
        return text
    gap = footprint_gap(pts, fp.front, fp.rear, fp.width)
    i = int(np.argmin(gap))
    return f"{text}; nearest point ({pts[i, 0]:.3f}, {pts[i, 1]:.3f}) m, {gap[i]:.3f} m off"
