"""One route on one floor, as the planner service would plan it, with timings.

The planner (:class:`services.planner.grid_planner.Planner`) gives the waypoints, speeds,
length and the corner path before densifying (cell centres, start and goal exact); the route
planner (:class:`services.planner.routes.RoutePlanner`) gives the doors and lifts the route
passes. Blocked or outside points fail before planning, naming the nearest free cell.
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass

import numpy as np
from scipy.ndimage import distance_transform_edt

from services.planner import errors
from services.planner.grid_planner import Plan, Planner, inflation_radius
from services.planner.routes import Checkpoint, RoutePlanner
from shared.config import FleetConfig, PlannerConfig
from shared.site import GridMap, Site

Point = tuple[float, float]


@dataclass
class PlanResult:
    """A planned route and what a picture of it needs (the grid and its lethal cells)."""

    floor: str
    start: Point
    goal: Point
    radius_m: float
    path: np.ndarray  # (N, 2) corners of the A* path before densifying, metres
    plan: Plan
    plan_ms: list[float]
    checkpoints: list[Checkpoint]
    grid: GridMap
    lethal: np.ndarray


def planner_config(cfg: FleetConfig, radius_m: float | None) -> PlannerConfig:
    """The planner section, with its margin set so that the inflation radius is ``radius_m``
    (None: the configured one). The margin may go below zero for a radius under half the
    chair's width: only the inflation reads it."""
    if radius_m is None:
        return cfg.planner
    if not (math.isfinite(radius_m) and radius_m > 0):
        raise errors.BadRequest(f"radius must be a number of metres > 0, got {radius_m}")
    body = inflation_radius(cfg.robot, cfg.planner) - cfg.planner.inflation_margin_m
    return dataclasses.replace(cfg.planner, inflation_margin_m=radius_m - body)


def plan_route(
    site: Site,
    floor: str,
    start: Point,
    goal: Point,
    cfg: FleetConfig,
    radius_m: float | None = None,
    repeat: int = 1,
) -> PlanResult:
    """Plan from ``start`` to ``goal`` on ``floor`` ("" = the first), timing the plan
    ``repeat`` times; PlanError (one line) if a point is outside or blocked or no route."""
    if repeat < 1:
        raise errors.BadRequest(f"repeat must be at least 1, got {repeat}")
    floor = site.floor(floor).name
    pcfg = planner_config(cfg, radius_m)
    planner = Planner(site, cfg.robot, pcfg)
    grid, lethal = planner.lethal(floor)
    free_cell(grid, lethal, start, "start", planner.radius)
    free_cell(grid, lethal, goal, "goal", planner.radius)
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        plan = planner.plan(start, goal, floor)
        times.append((time.perf_counter() - t0) * 1000.0)
    routes = RoutePlanner(planner, site, pcfg, cfg.controller.stop_distance_m)
    route = routes.request(start, floor, goal, floor)
    return PlanResult(
        floor,
        start,
        goal,
        planner.radius,
        plan.corners,
        plan,
        times,
        route.checkpoints,
        grid,
        lethal,
    )


def free_cell(
    grid: GridMap, lethal: np.ndarray, xy: Point, what: str, radius_m: float
) -> tuple[int, int]:
    """The (row, col) of ``xy`` if the chair may stand there; else OutsideMap, or
    StartOccupied / GoalOccupied naming the nearest free cell."""
    if not all(math.isfinite(v) for v in xy):
        raise errors.BadRequest(f"{what} {xy} is not a finite point")
    r, c = grid.to_cell(*xy)
    if not grid.contains(r, c):
        rows, cols = grid.shape
        x0, y0 = grid.origin[0], grid.origin[1]
        x1, y1 = x0 + cols * grid.resolution, y0 + rows * grid.resolution
        raise errors.OutsideMap(
            f"{what} {_xy(xy)} is outside the map (x {x0:.2f} to {x1:.2f}, y {y0:.2f} to {y1:.2f})"
        )
    if not lethal[r, c]:
        return r, c
    blocked = errors.StartOccupied if what == "start" else errors.GoalOccupied
    where = "inside an obstacle"
    if not grid.occupied(True)[r, c]:
        where += f"'s {radius_m:.2f} m inflation"
    nearest = nearest_free(grid, lethal, (r, c))
    tail = f"nearest free cell {_xy(nearest)}" if nearest else "no free cell on this floor"
    raise blocked(f"{what} {_xy(xy)} is {where}; {tail}")


def nearest_free(grid: GridMap, lethal: np.ndarray, cell: tuple[int, int]) -> Point | None:
    """Centre of the free (not lethal) cell nearest to ``cell``; None if there is none."""
    if lethal.all():
        return None
    _dist, (rows, cols) = distance_transform_edt(lethal, return_indices=True)
    r, c = int(rows[cell]), int(cols[cell])
    x, y = grid.to_world(np.array([[r, c]]))[0]
    return float(x), float(y)


def _xy(p: Point) -> str:
    return f"({p[0]:.2f}, {p[1]:.2f})"
