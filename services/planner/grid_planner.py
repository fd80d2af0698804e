"""The planner's core: from a site and two poses to a path with a speed profile.

Per floor it inflates the map once (circular, by the footprint's half width plus a
margin), then answers each request with an 8-connected A* on the inflated grid, a
line-of-sight shortening that never crosses the inflated area, waypoints about
``waypoint_spacing_m`` apart and a reference speed that falls to 0 at the goal.
No I/O and no clock: the node turns requests into calls and errors into codes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from services.planner import errors, grid_astar
from services.planner.grid_astar import Landmarks, NoPathError, astar
from services.planner.inflation import inflate, obstacle_distance
from shared.config import PlannerConfig, RobotConfig
from shared.site import GridMap, Site, SiteError

CLOSED_BAND_M = 0.15  # a closed door blocks the cells this far either side of its segment


@dataclass
class Plan:
    """A planned path on one floor (a leg of a route): waypoints (N, 2), speeds (N,), length."""

    floor: str
    waypoints: np.ndarray
    v_ref: np.ndarray
    length_m: float
    zones: list[str] = field(default_factory=list)  # per waypoint: room/corridor/door/goal
    corners: np.ndarray | None = None  # (M, 2) the search's path before densifying


@dataclass
class _FloorGrid:
    grid: GridMap
    lethal: np.ndarray
    cost: np.ndarray
    landmarks: Landmarks | None
    occupied: np.ndarray  # the map's walls (and open leaves), not inflated
    room: np.ndarray  # each cell's distance to the nearest obstacle (m)


def inflation_radius(robot: RobotConfig, cfg: PlannerConfig) -> float:
    """Radius the obstacles grow by: half the chair's width plus the safety margin."""
    return robot.footprint.width / 2 + cfg.inflation_margin_m


class Planner:
    """Plans on every floor of a site; inflated grids are computed once per floor."""

    def __init__(self, site: Site, robot: RobotConfig, cfg: PlannerConfig) -> None:
        self.site = site
        self.cfg = cfg
        self.robot = robot
        self.radius = inflation_radius(robot, cfg)
        self._floors: dict[str, _FloorGrid] = {}
        grid_astar.warm_up()  # compile (or load) the JIT now
        for name, floor in site.floors.items():
            occ = with_open_leaves(floor.map.occupied(cfg.unknown_is_occupied), site, name)
            lethal, cost = inflate(occ, floor.map.resolution, self.radius, cfg.cost_band_m)
            lm = Landmarks(lethal, cfg.landmarks) if cfg.landmarks and (~lethal).any() else None
            room = obstacle_distance(occ, floor.map.resolution).astype(np.float32)
            self._floors[name] = _FloorGrid(floor.map, lethal, cost, lm, occ, room)

    def resolve_place(self, place: str) -> tuple[float, float, float, str]:
        """(x, y, theta, floor) of a named place; UnknownPlace if the site has none so called."""
        try:
            p = self.site.place(place)
        except SiteError as exc:
            raise errors.UnknownPlace(str(exc)) from None
        return p.x, p.y, p.theta, p.floor

    def floor_name(self, floor: str) -> str:
        """The site's name for ``floor`` ("" = the first); UnknownFloor if there is none."""
        try:
            return self.site.floor(floor).name
        except SiteError as exc:
            raise errors.UnknownFloor(str(exc)) from None

    def lethal(self, floor: str) -> tuple[GridMap, np.ndarray]:
        """The floor's grid and the cells the chair's reference point may not enter
        (obstacles and open leaves grown by the inflation radius)."""
        fg = self._floors[self.floor_name(floor)]
        return fg.grid, fg.lethal

    def is_free(self, xy: tuple[float, float], floor: str) -> bool:
        """True if the chair's reference point may stand at ``xy`` (inside the map, not lethal)."""
        fg = self._floors[self.floor_name(floor)]
        r, c = fg.grid.to_cell(*xy)
        return fg.grid.contains(r, c) and not fg.lethal[r, c]

    def plan(
        self,
        start: tuple[float, float],
        goal: tuple[float, float],
        floor: str,
        closed: list[tuple[tuple[float, float], tuple[float, float]]] = (),
        points: list[tuple[float, float]] = (),
        arrive_heading: float | None = None,
        run_in_m: float = 0.0,
    ) -> Plan:
        """A path from ``start`` to ``goal`` (x, y) on ``floor`` ("" = the site's first floor).

        A start within the inflation of a wall (not in it: where the chair stands) leaves
        it first by the shortest straight line that crosses no wall.
        ``closed`` lists segments (door openings) the path must not cross (a band
        ``CLOSED_BAND_M`` each side, thinner where the start or the goal stands in it: a
        recovery can leave the chair in a doorway); ``points`` are
        obstacles the map lacks (what held the chair), inflated like the map's. With
        ``arrive_heading``, the path ends with a straight run-in of up to ``run_in_m``
        along that heading (shorter where the space behind the goal is), so the chair
        arrives at a door's or a lift's pose facing it instead of turning on the spot
        there, which a small room or a corridor may not allow.
        """
        floor = self.floor_name(floor)
        fg = self._floors[floor]
        s = self._cell(fg, start, "start", errors.StartOccupied, fg.occupied)
        g = self._cell(fg, goal, "goal", errors.GoalOccupied)
        lead: list[tuple[float, float]] = []  # a start in the inflation: the way out of it
        if fg.lethal[s]:
            s = self._way_out(fg, s, start)
            lead, start = [start], tuple(float(v) for v in fg.grid.to_world(np.array([s]))[0])
        lethal = fg.lethal
        if closed or len(points):
            lethal = lethal.copy()
            ends = np.array([start, goal], float)
            for p1, p2 in closed:
                near = float(segment_distances(ends, p1, p2).min())
                band = min(CLOSED_BAND_M, max(0.0, near - 2 * fg.grid.resolution))
                block_segment(lethal, fg.grid, p1, p2, band)
            for p in points:
                block_segment(lethal, fg.grid, p, p, self.radius)
            lethal[s] = lethal[g] = False
        pts = self._search(fg, lethal, s, g, start, goal, floor)
        if arrive_heading is not None and run_in_m > 0:
            pre = run_in_point(fg.grid, lethal, start, goal, arrive_heading, run_in_m)
            if pre is not None:
                via = self._search(fg, lethal, s, fg.grid.to_cell(*pre), start, pre, floor)
                last = via[-1] - via[-2] if len(via) > 1 else None
                heading = np.array([math.cos(arrive_heading), math.sin(arrive_heading)])
                if last is not None and float(last @ heading) >= -0.4 * np.linalg.norm(last):
                    pts = np.vstack([via, [goal]])  # a turn of at most ~115 deg into it
        if lead:
            pts = np.vstack([lead, pts])
        length = float(np.linalg.norm(np.diff(pts, axis=0), axis=1).sum())
        spacing = max(self.cfg.waypoint_spacing_m, length / self.cfg.max_waypoints)
        waypoints = densify(pts, spacing)
        v_ref = speed_profile(waypoints, self.cfg.cruise_speed, self.cfg.goal_speed_radius_m)
        return Plan(floor, waypoints, v_ref, length, corners=pts)

    def _search(
        self,
        fg: _FloorGrid,
        lethal: np.ndarray,
        s: tuple[int, int],
        g: tuple[int, int],
        start: tuple[float, float],
        goal: tuple[float, float],
        floor: str,
    ) -> np.ndarray:
        """The corners (world, start and goal exact) of the A* path from cell s to g."""
        try:
            cells = astar(lethal, s, g, fg.cost if self.cfg.cost_band_m > 0 else None, fg.landmarks)
        except NoPathError as exc:
            raise errors.NoPath(
                f"no path from {_xy(start)} to {_xy(goal)} on floor {floor}: {exc}"
            ) from None
        keep = self.radius + self.cfg.shortcut_margin_m
        pts = fg.grid.to_world(shorten(cells, lethal, fg.room, keep))
        pts[0], pts[-1] = start, goal
        return pts

    def _way_out(
        self, fg: _FloorGrid, s: tuple[int, int], start: tuple[float, float]
    ) -> tuple[int, int]:
        """The nearest cell clear of the inflation within ``self.radius`` plus two cells of
        a start inside it, on a straight line that crosses no wall (the chair stands there:
        a recovery or the safety checks left it nearer a wall than the inflation allows);
        StartOccupied if there is none."""
        res = fg.grid.resolution
        k = int(math.ceil(self.radius / res)) + 2
        r0, c0 = max(s[0] - k, 0), max(s[1] - k, 0)
        window = fg.lethal[r0 : s[0] + k + 1, c0 : s[1] + k + 1]
        rows, cols = np.nonzero(~window)
        cells = np.column_stack((rows + r0, cols + c0))
        dist = np.hypot(cells[:, 0] - s[0], cells[:, 1] - s[1])
        here = np.array(s)
        for i in np.argsort(dist, kind="stable"):
            if dist[i] <= k and line_is_free(fg.occupied, here, cells[i]):
                return int(cells[i, 0]), int(cells[i, 1])
        raise errors.StartOccupied(
            f"start {_xy(start)} is within {self.radius:.2f} m of a wall with no way out"
        )

    def _cell(
        self,
        fg: _FloorGrid,
        xy: tuple[float, float],
        what: str,
        blocked_error: type[errors.PlanError],
        blocked: np.ndarray | None = None,
    ) -> tuple[int, int]:
        """The cell of ``xy``: a typed error if it is not finite, off the map or in
        ``blocked`` (default: the inflated map)."""
        if not all(math.isfinite(v) for v in xy):
            raise errors.OutsideMap(f"{what} {xy} is not a finite point")
        r, c = fg.grid.to_cell(*xy)
        if not fg.grid.contains(r, c):
            raise errors.OutsideMap(f"{what} ({xy[0]:.2f}, {xy[1]:.2f}) is outside the map")
        if blocked is not None and blocked[r, c]:
            raise blocked_error(f"{what} ({xy[0]:.2f}, {xy[1]:.2f}) is inside a wall")
        if blocked is None and fg.lethal[r, c]:
            raise blocked_error(
                f"{what} ({xy[0]:.2f}, {xy[1]:.2f}) is inside a wall or within "
                f"{self.radius:.2f} m of one"
            )
        return r, c


def with_open_leaves(occ: np.ndarray, site: Site, floor: str) -> np.ndarray:
    """``occ`` with the fully open leaf of every hinged door on ``floor`` drawn in: a manual
    door may stand open, its leaf a short wall the map does not show."""
    leaves = [(d, d.open_leaf()) for d in site.doors if d.floor == floor]
    leaves = [(d, leaf) for d, leaf in leaves if leaf is not None]
    if not leaves:
        return occ
    occ = occ.copy()
    grid = site.floor(floor).map
    for door, (hinge, tip) in leaves:
        # one cell out of the opening, beside the jamb, and one cell thick (the cells the
        # line crosses): the leaf must not narrow its own door, nor, grown by the
        # inflation, close the centre line of a narrow one beside it
        ux, uy = (door.p1[0] - door.p2[0]) / door.width_m, (door.p1[1] - door.p2[1]) / door.width_m
        shift = grid.resolution
        a = (hinge[0] + ux * shift, hinge[1] + uy * shift)
        b = (tip[0] + ux * shift, tip[1] + uy * shift)
        block_segment(occ, grid, a, b, 0.0)
    return occ


def _xy(p: tuple[float, float]) -> str:
    return f"({p[0]:.2f}, {p[1]:.2f})"


def segment_distances(
    pts: np.ndarray, p1: tuple[float, float], p2: tuple[float, float]
) -> np.ndarray:
    """Distance of each point (N, 2) to the segment p1-p2."""
    a, b = np.asarray(p1, float), np.asarray(p2, float)
    d = b - a
    t = np.clip(((pts - a) @ d) / max(float(d @ d), 1e-12), 0.0, 1.0)
    return np.linalg.norm(pts - (a + t[:, None] * d), axis=1)


def block_segment(
    lethal: np.ndarray,
    grid: GridMap,
    p1: tuple[float, float],
    p2: tuple[float, float],
    thickness_m: float = CLOSED_BAND_M,
) -> None:
    """Mark the cells within ``thickness_m`` of segment p1-p2 lethal (a closed door)."""
    a, b = np.asarray(p1, float), np.asarray(p2, float)
    n = max(2, int(np.ceil(np.linalg.norm(b - a) / (grid.resolution / 2))) + 1)
    pts = a + (b - a) * np.linspace(0.0, 1.0, n)[:, None]
    # every sample's every offset at once: looped offset by offset, a recovery's 61 marked
    # points (17 x 17 offsets each) took 2-3 s a route on a 30 x 63 m floor
    k = int(np.ceil(thickness_m / grid.resolution))
    dr, dc = np.mgrid[-k : k + 1, -k : k + 1].reshape(2, -1)
    rows = np.floor((pts[:, 1] - grid.origin[1]) / grid.resolution).astype(int)
    cols = np.floor((pts[:, 0] - grid.origin[0]) / grid.resolution).astype(int)
    rows, cols = (rows[:, None] + dr[None, :]).ravel(), (cols[:, None] + dc[None, :]).ravel()
    ok = (rows >= 0) & (rows < lethal.shape[0]) & (cols >= 0) & (cols < lethal.shape[1])
    lethal[rows[ok], cols[ok]] = True


def run_in_point(
    grid: GridMap,
    lethal: np.ndarray,
    start: tuple[float, float],
    goal: tuple[float, float],
    heading: float,
    run_in_m: float,
    min_m: float = 0.3,
    lateral_m: float = 0.3,
) -> tuple[float, float] | None:
    """Where a straight run-in to ``goal`` along ``heading`` starts: ``run_in_m`` back, or
    less where the space behind the goal is short (never under ``min_m``); None when
    ``start`` already lies on that line behind the goal, is within ``run_in_m`` of it, or
    no run-in fits."""
    d = np.array([math.cos(heading), math.sin(heading)])
    rel = np.asarray(start, float) - np.asarray(goal, float)
    along, lateral = -float(rel @ d), abs(float(rel[0] * d[1] - rel[1] * d[0]))
    if (along >= 0 and lateral <= lateral_m) or math.hypot(*rel) <= run_in_m:
        return None  # on the line already, or too near for a run-in: docking turns it
    g = np.array(grid.to_cell(*goal))
    for r in np.arange(run_in_m, min_m - 1e-9, -0.1):
        p = np.asarray(goal, float) - d * r
        cell = grid.to_cell(float(p[0]), float(p[1]))
        if not grid.contains(*cell) or lethal[cell]:
            continue
        if line_is_free(lethal, np.array(cell), g):
            return float(p[0]), float(p[1])
    return None


def line_is_free(
    lethal: np.ndarray,
    a: np.ndarray,
    b: np.ndarray,
    room: np.ndarray | None = None,
    least: float | None = None,
) -> bool:
    """True if the straight segment between cells ``a`` and ``b`` touches no lethal cell
    (and, given ``room`` and ``least``, no cell nearer an obstacle than ``least``)."""
    n = int(np.ceil(np.abs(b - a).max() * 2)) + 1
    t = np.linspace(0.0, 1.0, n)[:, None]
    pts = np.rint(a + (b - a) * t).astype(int)
    if lethal[pts[:, 0], pts[:, 1]].any():
        return False
    return room is None or least is None or bool(room[pts[:, 0], pts[:, 1]].min() >= least)


def shorten(
    cells: np.ndarray, lethal: np.ndarray, room: np.ndarray | None = None, keep: float = 0.0
) -> np.ndarray:
    """Keep only the corners needed so every straight leg stays outside the lethal area
    and, given ``room`` (each cell's distance to the nearest obstacle), never nearer to
    one than ``keep`` where the search's own path kept that far (nor nearer than it did
    where it came closer): a shortcut pulled tight round a corner leaves the chair's side
    at the inflation's margin, where its turns sweep the walls."""
    near = None if room is None else room[cells[:, 0], cells[:, 1]]
    keep_m = [0]
    i = 0
    last = len(cells) - 1
    while i < last:
        lo, hi = i + 1, last
        while lo < hi:  # farthest visible cell, by bisection on the path index
            mid = (lo + hi + 1) // 2
            floor = None if near is None else min(keep, float(near[i : mid + 1].min()))
            if line_is_free(lethal, cells[i], cells[mid], room, floor):
                lo = mid
            else:
                hi = mid - 1
        i = lo
        keep_m.append(i)
    return cells[keep_m]


def densify(points: np.ndarray, spacing: float) -> np.ndarray:
    """Insert points so no leg is longer than ``spacing`` (keeps the given corners)."""
    out = [points[0]]
    for a, b in zip(points[:-1], points[1:], strict=True):
        n = max(1, math.ceil(float(np.linalg.norm(b - a)) / spacing))
        for k in range(1, n + 1):
            out.append(a + (b - a) * (k / n))
    return np.asarray(out, dtype=float)


def speed_profile(
    waypoints: np.ndarray, cruise: float, slow_radius: float, min_speed: float = 0.1
) -> np.ndarray:
    """Cruise speed, braking at a constant deceleration within ``slow_radius`` of the
    goal (cruise x sqrt(distance left / slow_radius)), 0 at the goal: a speed falling
    linearly with the distance never gets there, and crept at ``min_speed``."""
    legs = np.linalg.norm(np.diff(waypoints, axis=0), axis=1)
    to_go = np.concatenate([np.cumsum(legs[::-1])[::-1], [0.0]])
    if slow_radius <= 0:
        v = np.full(len(waypoints), cruise)
    else:
        v = np.clip(cruise * np.sqrt(to_go / slow_radius), min_speed, cruise)
    v[-1] = 0.0
    return v
