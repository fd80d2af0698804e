"""Doorways found in one LiDAR scan: the gap between two stretches of the same wall.

The method of the door-passing paper (seeds/004), made to work without knowing the door:

1. ``planar_scan``: a 3-D cloud (or a planar scan) becomes one planar scan, the nearest
   return per azimuth bin within a height band around the sensor (walls and jambs, not the
   floor returns of the downward rings).
2. ``segment``: the Adaptive Breakpoint Detector (Borges and Aldon) cuts the scan where
   consecutive returns are further apart than a beam at that range could explain, then
   Iterative End-Point Fit splits each piece into straight stretches, each fitted by
   total least squares.
3. ``find_doorways``: two stretches on one line (the wall either side of a doorway) whose
   facing ends are a door's width apart, with no return on that line between them (an
   doorway: the returns there come from beyond it). The paper matches the gap to a
   known door width; here any gap in ``[min_width_m, max_width_m]`` is a doorway, so a
   door that the map lacks or places wrong is found too. It is open when most beams
   through its middle reach past a wall's thickness; a closed leaf stands in the frame
   behind the face (one flush with the wall fills the gap: no doorway).

A sighting is in the scan's frame; its centre lies on the wall face the sensor sees, its
``normal`` points from the sensor's side through the doorway. Pure: no I/O.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numba
import numpy as np

from shared import door_scan_numba
from shared.config import DoorScanConfig

DEFAULTS = DoorScanConfig()  # every constant here is a key of controller.door_scan


@dataclass(frozen=True)
class Stretch:
    """A straight stretch of returns: its two ends, unit direction (from ``a`` to ``b``),
    unit normal (towards the sensor) and the rms distance of its returns from the line."""

    a: np.ndarray
    b: np.ndarray
    direction: np.ndarray
    normal: np.ndarray
    rms: float
    count: int

    @cached_property
    def length(self) -> float:
        return float(np.linalg.norm(self.b - self.a))


@dataclass(frozen=True)
class Doorway:
    """One doorway seen in a scan: its two jamb corners, centre, width, the wall's unit
    direction (from ``left`` to ``right`` jamb) and the unit normal through the doorway,
    away from the sensor."""

    left: np.ndarray
    right: np.ndarray
    centre: np.ndarray
    width: float
    direction: np.ndarray
    normal: np.ndarray
    depth: float | None = None  # the wall's thickness, where a reveal was seen
    open: bool = True  # False: a leaf stands in the frame

    @property
    def plane_centre(self) -> np.ndarray:
        """The middle of the doorway in the wall's thickness (a site's door line), where
        the reveal showed it; else on the face, as ``centre``."""
        return self.centre if self.depth is None else self.centre + self.normal * self.depth / 2


def planar_scan(
    points: np.ndarray, band_m: float = DEFAULTS.band_m, bin_deg: float = DEFAULTS.bin_deg
) -> np.ndarray:
    """(M, 2) returns ordered by azimuth: the nearest per ``bin_deg`` bin of the points
    (N, 2 or 3; sensor frame) within ``band_m`` of the sensor's height."""
    pts = np.asarray(points)
    if pts.ndim != 2 or pts.shape[1] < 2:
        raise ValueError(f"points must be (N, 2) or (N, 3), got shape {pts.shape}")
    if pts.dtype != np.float32:
        pts = pts.astype(np.float64, copy=False)
    n_bins = int(math.floor(360.0 / bin_deg)) + 2  # azimuth +180 deg has a bin of its own
    keep = _nearest_per_bin(pts, float(band_m), float(bin_deg), n_bins)
    return pts[keep, :2].astype(np.float64)


def warm_up() -> None:
    """Compile (or load) the binning kernel now, for float32 clouds (the LiDAR's) and
    float64 points, not in the first cycle that looks for a doorway: in lockstep the
    compile would hold a tick, on wall time a control cycle."""
    for dtype in (np.float32, np.float64):
        planar_scan(np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]], dtype=dtype))
    door_scan_numba.warm_up()


@numba.njit(cache=True)
def _nearest_per_bin(pts: np.ndarray, band_m: float, bin_deg: float, n_bins: int) -> np.ndarray:
    """Indices of the nearest finite return per azimuth bin (the first of equals), bins in
    order: one pass over a VLP-16 cloud (25,000 points) instead of a sort of them."""
    best_r = np.full(n_bins, np.inf)
    best_i = np.full(n_bins, -1, dtype=np.int64)
    has_z = pts.shape[1] > 2
    for i in range(pts.shape[0]):
        if has_z and not abs(np.float64(pts[i, 2])) < band_m:
            continue
        x, y = np.float64(pts[i, 0]), np.float64(pts[i, 1])
        if not (math.isfinite(x) and math.isfinite(y)):
            continue
        r = math.hypot(x, y)
        if not r > 1e-6:
            continue
        b = int(math.floor((math.degrees(math.atan2(y, x)) + 180.0) / bin_deg))
        b = min(max(b, 0), n_bins - 1)
        if r < best_r[b]:
            best_r[b] = r
            best_i[b] = i
    return best_i[best_i >= 0]


def _breaks(xy: np.ndarray, cfg: DoorScanConfig) -> list[np.ndarray]:
    """Adaptive Breakpoint Detector: runs of returns with no jump a beam cannot explain."""
    if len(xy) < 2:
        return [xy] if len(xy) else []
    r = np.hypot(xy[:, 0], xy[:, 1])
    dphi = np.abs(np.diff(np.unwrap(np.arctan2(xy[:, 1], xy[:, 0]))))
    lam = math.radians(cfg.breakpoint_angle_deg)
    dphi = np.clip(dphi, math.radians(cfg.bin_deg) * 0.5, lam * 0.9)
    d_max = r[:-1] * np.sin(dphi) / np.sin(lam - dphi) + 3 * cfg.range_sigma_m
    jump = np.linalg.norm(np.diff(xy, axis=0), axis=1) > d_max
    cuts = np.flatnonzero(jump) + 1
    return [p for p in np.split(xy, cuts) if len(p)]


def _split(xy: np.ndarray, split_m: float) -> list[np.ndarray]:
    """Iterative End-Point Fit: split at the return furthest from the chord while it is
    further than ``split_m``."""
    if len(xy) < 3:
        return [xy]
    a, b = xy[0], xy[-1]
    chord = b - a
    n = np.linalg.norm(chord)
    if n < 1e-9:
        d = np.linalg.norm(xy - a, axis=1)
    else:
        d = np.abs(chord[0] * (xy[:, 1] - a[1]) - chord[1] * (xy[:, 0] - a[0])) / n
    i = int(np.argmax(d))
    if d[i] <= split_m or i in (0, len(xy) - 1):
        return [xy]
    return _split(xy[: i + 1], split_m) + _split(xy[i:], split_m)


def _fit(xy: np.ndarray) -> Stretch:
    """Total least squares line through the returns; ends are the extreme projections."""
    mean = xy.mean(axis=0)
    _, _, vt = np.linalg.svd(xy - mean, full_matrices=False)
    direction = vt[0]
    if np.dot(direction, xy[-1] - xy[0]) < 0:
        direction = -direction
    normal = np.array([-direction[1], direction[0]])
    if np.dot(normal, mean) > 0:  # towards the sensor (the origin)
        normal = -normal
    along = (xy - mean) @ direction
    off = (xy - mean) @ normal
    a, b = mean + along.min() * direction, mean + along.max() * direction
    return Stretch(a, b, direction, normal, float(np.sqrt(np.mean(off**2))), len(xy))


def segment(scan_xy: np.ndarray, cfg: DoorScanConfig = DEFAULTS) -> list[Stretch]:
    """The straight stretches of a planar scan (ordered by azimuth) long enough for walls."""
    out = []
    for run in _breaks(scan_xy, cfg):
        for piece in _split(run, cfg.split_m):
            if len(piece) >= cfg.min_points:
                s = _fit(piece)
                if s.length >= cfg.min_length_m:
                    out.append(s)
    return out


def find_doorways(points: np.ndarray, cfg: DoorScanConfig = DEFAULTS) -> list[Doorway]:
    """Every doorway in one scan (N, 2 or 3 points, sensor frame), nearest first: between
    two stretches of one wall, or between a stretch of wall and the face of a hinged leaf
    standing open towards the sensor (the wall on the leaf's far side hidden behind it).
    Compiled (``shared/door_scan_numba.py``); :func:`find_doorways_numpy` is the reference
    it follows, to about 1e-12 m."""
    scan = planar_scan(points, cfg.band_m, cfg.bin_deg)
    rows = door_scan_numba.doorways(scan, door_scan_numba.params(cfg))
    return [_from_row(r) for r in rows]


def _from_row(r: np.ndarray) -> Doorway:
    left, right = r[0:2].copy(), r[2:4].copy()
    depth = None if math.isnan(r[9]) else float(r[9])
    return Doorway(
        left, right, (left + right) / 2, float(r[4]), r[5:7].copy(), r[7:9].copy(), depth, r[10] > 0
    )


def find_doorways_numpy(points: np.ndarray, cfg: DoorScanConfig = DEFAULTS) -> list[Doorway]:
    """:func:`find_doorways` in numpy and Python, step by step as the module's docstring
    tells it: the reference the compiled finder is tested against."""
    scan = planar_scan(points, cfg.band_m, cfg.bin_deg)
    stretches = segment(scan, cfg)
    found: list[Doorway] = []
    for s, lo, hi in _gaps(stretches, cfg):
        door = _doorway(scan, stretches, s, lo, hi, cfg)
        if door is not None:
            found.append(door)
    found.sort(key=lambda w: float(np.linalg.norm(w.centre)))
    return _distinct(found, cfg.distinct_m)


def _gaps(stretches: list[Stretch], cfg: DoorScanConfig) -> list[tuple[Stretch, float, float]]:
    """Candidate gaps (the wall's stretch, the gap's ends along it from its end ``a``):
    two stretches on one line, and a stretch of wall beside a leaf's face."""
    gaps = []
    cos_par = math.cos(math.radians(cfg.parallel_deg))
    for i, first in enumerate(stretches):
        for second in stretches[i + 1 :]:
            if abs(float(np.dot(first.direction, second.direction))) < cos_par:
                continue
            # the longer stretch is the wall's line (a short one's direction is not good
            # enough to reach across a doorway); the other's facing end must lie on it
            s, t = (first, second) if first.length >= second.length else (second, first)
            d = s.direction
            s_ends = sorted(float(np.dot(p - s.a, d)) for p in (s.a, s.b))
            t_ends = sorted((float(np.dot(p - s.a, d)), k) for k, p in enumerate((t.a, t.b)))
            if t_ends[0][0] >= s_ends[1]:
                lo, (hi, k) = s_ends[1], t_ends[0]
            elif s_ends[0] >= t_ends[1][0]:
                (lo, k), hi = t_ends[1], s_ends[0]
            else:
                continue  # overlapping: one wall, no gap
            if abs(float(np.dot((t.a, t.b)[k] - s.a, s.normal))) > cfg.on_line_m:
                continue
            gaps.append((s, lo, hi))
    for s in stretches:  # a leaf's face as the far jamb
        ends = sorted(float(np.dot(p - s.a, s.direction)) for p in (s.a, s.b))
        for at in _leaf_faces(stretches, s, cfg):
            if at > ends[1]:
                gaps.append((s, ends[1], at))
            elif at < ends[0]:
                gaps.append((s, at, ends[0]))
    return gaps


def _doorway(
    scan: np.ndarray,
    stretches: list[Stretch],
    s: Stretch,
    lo: float,
    hi: float,
    cfg: DoorScanConfig,
) -> Doorway | None:
    """The doorway in wall ``s`` between ``lo`` and ``hi`` (along it from its end ``a``),
    if the returns show one: jambs where the wall's returns end (or a leaf's face), no
    return on the wall's line between them, beams through the gap, no jamb at the edge of
    a shadow (the wall may go on behind what casts it)."""
    if not cfg.min_width_m <= hi - lo <= cfg.max_width_m:
        return None
    d = s.direction
    along = (scan - s.a) @ d
    off = (scan - s.a) @ s.normal
    on_line = np.abs(off) < cfg.on_line_m
    # the jambs: follow the wall's returns from each end towards the other while they are
    # close together (a fit ends short of a corner where the reveal bends away); a closed
    # leaf flush with the wall closes the gap
    wall = np.sort(along[on_line & (along > lo - cfg.jamb_m) & (along < hi + cfg.jamb_m)])
    lo, hi = _follow(wall, lo, +1, cfg.step_m), _follow(wall, hi, -1, cfg.step_m)
    # a hinged leaf swung open towards the sensor stands across the wall's line at its
    # hinge jamb and hides the wall behind it: its face is that side's jamb
    leaf = _leaf_face(stretches, s, lo, hi, cfg)
    near_leaf = np.zeros(len(scan), dtype=bool)
    if leaf is not None:
        near_leaf = np.abs(along - leaf) < cfg.leaf_thickness_m
        sensor = float(np.dot(-s.a, d))  # the sensor's place along the wall
        if leaf - lo < hi - leaf:  # seen from the hinge's side, the face is the outer one
            lo = leaf = leaf + (cfg.leaf_side_m if sensor < leaf else 0.0)
        else:
            hi = leaf = leaf - (cfg.leaf_side_m if sensor > leaf else 0.0)
    width = hi - lo
    if not cfg.min_width_m <= width <= cfg.max_width_m:
        return None
    gap = (along > lo + cfg.reveal_m) & (along < hi - cfg.reveal_m)
    if np.any(on_line & ~near_leaf & gap):
        return None  # something on the wall's line in the gap: a leaf, a post
    c = float(np.dot(s.normal, s.a))
    ends = [(e, side) for e, side in ((lo, +1), (hi, -1)) if leaf is None or e != leaf]
    if any(_hidden(scan, off, s, c, e, side, cfg) for e, side in ends):
        return None  # a jamb at the edge of a shadow: the wall may go on behind it
    beyond = off < -cfg.on_line_m
    if not np.any(beyond):
        return None
    # where the beams to returns beyond the wall cross its line (the sensor is at the
    # origin): some must cross in the gap, else it is a gap in the returns
    cross = scan[beyond] * (c / (scan[beyond] @ s.normal))[:, None]
    through = (cross - s.a) @ d
    if not np.any((through > lo + cfg.reveal_m) & (through < hi - cfg.reveal_m)):
        return None
    # open: most beams through the gap's middle half reach past a wall's thickness (a
    # closed leaf stands in the frame, a few cm behind the face; an open hinged one
    # stands at a jamb)
    middle = (through > lo + width / 4) & (through < hi - width / 4)
    deep = -off[beyond][middle] > cfg.max_depth_m
    is_open = bool(np.mean(deep) >= 0.5) if middle.any() else True
    left, right = s.a + lo * d, s.a + hi * d
    depth = _reveal_depth(along, off, lo, hi, cfg)
    return Doorway(left, right, (left + right) / 2, width, d.copy(), -s.normal, depth, is_open)


def _leaves(
    stretches: list[Stretch], wall: Stretch, reach_m: float, cfg: DoorScanConfig
) -> list[Stretch]:
    """Stretches that may be the face of a leaf standing across ``wall``'s line: at least
    ``leaf_min_m`` long, within ``leaf_deg`` of its normal, out on the sensor's side, the
    nearer end within ``reach_m`` of the line."""
    n = wall.normal
    found = []
    for u in stretches:
        if u is wall or u.length < cfg.leaf_min_m:
            continue
        if abs(float(np.dot(u.direction, n))) < math.cos(math.radians(cfg.leaf_deg)):
            continue
        offs = [float(np.dot(p - wall.a, n)) for p in (u.a, u.b)]
        if min(offs) <= reach_m and max(offs) >= cfg.leaf_min_m:
            found.append(u)
    return found


def _along(wall: Stretch, u: Stretch) -> float:
    """Where the stretch ``u``'s middle lies along ``wall`` (from its end ``a``)."""
    return float(np.dot((u.a + u.b) / 2 - wall.a, wall.direction))


def _leaf_faces(stretches: list[Stretch], wall: Stretch, cfg: DoorScanConfig) -> list[float]:
    """Along ``wall``, the faces of every leaf standing across its line and reaching it
    (the hinge; a reveal in line with the face may carry it on through the wall)."""
    return [_along(wall, u) for u in _leaves(stretches, wall, cfg.on_line_m, cfg)]


def _leaf_face(
    stretches: list[Stretch], wall: Stretch, lo: float, hi: float, cfg: DoorScanConfig
) -> float | None:
    """Along ``wall``, the face of the longest leaf standing across it in the gap [lo, hi],
    its nearer end within ``leaf_reach_m`` of the line (the part by the hinge may be hidden
    or seen too edge-on to make a stretch); None: no leaf."""
    inside = [
        u
        for u in _leaves(stretches, wall, cfg.leaf_reach_m, cfg)
        if lo - cfg.jamb_m < _along(wall, u) < hi + cfg.jamb_m
    ]
    return _along(wall, max(inside, key=lambda u: u.length)) if inside else None


def _hidden(
    scan: np.ndarray,
    off: np.ndarray,
    wall: Stretch,
    c: float,
    end: float,
    inward: int,
    cfg: DoorScanConfig,
) -> bool:
    """True if beams that cross ``wall``'s line just inside the gap from ``end`` (towards
    ``inward``) end on something nearer than the wall: the end is the edge of a shadow.
    ``off``: each return's distance from the wall's line, towards the sensor."""
    front = scan[off > cfg.on_line_m]
    if len(front) == 0:
        return False
    dots = front @ wall.normal
    scale = np.divide(c, dots, out=np.zeros_like(dots), where=np.abs(dots) > 1e-9)
    ok = scale > 1.0  # the beam goes on past the return to the wall's line
    cross = front[ok] * scale[ok][:, None]
    at = (cross - wall.a) @ wall.direction
    inside = (at - end) * inward
    return bool(np.any((inside > cfg.reveal_m) & (inside < cfg.shadow_m)))


def _follow(wall: np.ndarray, end: float, step: int, step_m: float) -> float:
    """From ``end``, along sorted positions ``wall`` in direction ``step`` (+1 up, -1
    down), while consecutive returns are less than ``step_m`` apart."""
    values = wall if step > 0 else wall[::-1]
    for v in values:
        if (v - end) * step <= 0:
            continue
        if (v - end) * step > step_m:
            break
        end = float(v)
    return end


def _reveal_depth(
    along: np.ndarray, off: np.ndarray, lo: float, hi: float, cfg: DoorScanConfig
) -> float | None:
    """The wall's thickness from a jamb's reveal: the deepest return beyond the face
    within ``reveal_m`` of a jamb's line (None if no reveal shows)."""
    at_jamb = (np.abs(along - lo) < cfg.reveal_m) | (np.abs(along - hi) < cfg.reveal_m)
    depth = -off[at_jamb & (off < -cfg.on_line_m) & (off > -cfg.max_depth_m)]
    return float(depth.max()) if len(depth) >= cfg.min_points else None


def _distinct(doorways: list[Doorway], distinct_m: float) -> list[Doorway]:
    """One sighting per doorway: a wall seen as several stretches gives the same gap twice."""
    out: list[Doorway] = []
    for w in doorways:
        if all(np.linalg.norm(w.centre - o.centre) > distinct_m for o in out):
            out.append(w)
    return out


@dataclass(frozen=True)
class DoorEstimate:
    """A doorway fused over scans, in the map frame: its centre in the wall's thickness
    (on the face until a reveal has shown the thickness), width, the wall's unit direction,
    the unit normal (away from where it was first seen), the thickness (None: not seen),
    how many sightings made it, the standard error of the centre (m) and whether it is
    open."""

    centre: np.ndarray
    width: float
    direction: np.ndarray
    normal: np.ndarray
    depth: float | None
    sightings: int
    sigma_m: float
    open: bool = True  # as the latest sighting saw it (a door opens and closes)


class DoorTracker:
    """Fuses doorway sightings from scan after scan into door estimates on the map.

    A sighting joins the estimate whose face centre is within ``join_m`` and whose wall
    runs the same way; the estimate is the mean of its sightings (jambs, thickness), each
    weighted by 1 / range^2 from the sensor (at most as at ``near_m``): a far sighting
    places a jamb less well, and the near ones are taken in the frame the chair steers in
    now (with the mapped door off, localisation drifts a little as the chair nears it).
    The uncertainty is the weighted spread of the centres over the square root of the
    sightings' effective number.
    """

    def __init__(self, join_m: float = DEFAULTS.join_m, near_m: float = DEFAULTS.near_m) -> None:
        self.join_m = join_m
        self.near_m = near_m
        self._tracks: list[dict] = []

    def add(self, doorways: list[Doorway], pose: tuple[float, float, float]) -> None:
        """Add one scan's sightings, taken with the sensor at map ``pose`` (x, y, theta)."""
        x, y, t = pose
        rot = np.array([[math.cos(t), -math.sin(t)], [math.sin(t), math.cos(t)]])
        origin = np.array([x, y])
        for w in doorways:
            left, right = origin + rot @ w.left, origin + rot @ w.right
            normal = rot @ w.normal
            track = self._match((left + right) / 2, right - left)
            if track is None:
                track = {"normal": normal, "left": [], "right": [], "weight": [], "depth": []}
                self._tracks.append(track)
            n = track["normal"]
            if np.dot(right - left, [-n[1], n[0]]) < 0:
                left, right = right, left  # the same jamb order in every sighting
            track["left"].append(left)
            track["right"].append(right)
            track["weight"].append(1.0 / max(float(np.linalg.norm(w.centre)), self.near_m) ** 2)
            if w.depth is not None:
                track["depth"].append(w.depth)
            track["open"] = w.open

    @staticmethod
    def _jambs(track: dict) -> tuple[np.ndarray, np.ndarray]:
        """The track's left and right jambs: its sightings' weighted means."""
        weights = track["weight"]
        left = np.average(track["left"], axis=0, weights=weights)
        return left, np.average(track["right"], axis=0, weights=weights)

    @classmethod
    def _centre(cls, track: dict) -> np.ndarray:
        left, right = cls._jambs(track)
        return (left + right) / 2

    def _match(self, centre: np.ndarray, span: np.ndarray) -> dict | None:
        for track in self._tracks:
            c = self._centre(track)
            n = track["normal"]
            along = abs(float(np.dot(span, [n[1], -n[0]]))) / max(np.linalg.norm(span), 1e-9)
            if np.linalg.norm(c - centre) <= self.join_m and along > math.cos(0.3):
                return track
        return None

    def estimates(self) -> list[DoorEstimate]:
        """Every doorway seen so far, the most often seen first."""
        out = []
        for track in self._tracks:
            weights = np.array(track["weight"])
            left, right = self._jambs(track)
            span = right - left
            width = float(np.linalg.norm(span))
            direction = span / max(width, 1e-9)
            normal = np.array([direction[1], -direction[0]])
            if np.dot(normal, track["normal"]) < 0:
                normal = -normal
            depth = float(np.mean(track["depth"])) if track["depth"] else None
            centre = (left + right) / 2 + (0.0 if depth is None else depth / 2) * normal
            centres = (np.array(track["left"]) + np.array(track["right"])) / 2
            n = len(centres)
            off = np.sum((centres - (left + right) / 2) ** 2, 1)
            spread = float(np.sqrt(np.average(off, weights=weights)))
            sigma = spread / math.sqrt(weights.sum() ** 2 / np.sum(weights**2))
            out.append(
                DoorEstimate(centre, width, direction, normal, depth, n, sigma, track["open"])
            )
        out.sort(key=lambda e: -e.sightings)
        return out
