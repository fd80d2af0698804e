"""Planner service: answers route requests and takes door/elevator availability updates.

Loads the site once (inflation and landmarks per floor), then replies to each
RouteRequest with a RouteReply: legs joined by door and elevator checkpoints, or an
error code from services/planner/errors.py and a one-line reason (goal in a wall,
unknown place, no path, every door or elevator on the way unavailable...).
"""

from __future__ import annotations

import itertools

import numpy as np

from services.planner.errors import PlanError
from services.planner.grid_planner import Planner
from services.planner.routes import Checkpoint, Route, RoutePlanner
from shared import messages as m
from shared.service import Service
from shared.site import SiteError, load_site

NAME = "planner"


def _pose(p: tuple[float, float, float], floor: str) -> m.Pose2D:
    return m.Pose2D(float(p[0]), float(p[1]), float(p[2]), floor)


def to_reply(route: Route, route_id: str) -> m.RouteReply:
    """The wire form of a route: legs, checkpoints, and the start floor's legs as one path."""
    legs = [
        m.Path(0.0, f"{route_id}.{i}", leg.floor, leg.waypoints, leg.v_ref, zones=leg.zones)
        for i, leg in enumerate(route.legs)
    ]
    checkpoints = [_checkpoint(c) for c in route.checkpoints]
    first_floor = []
    for i, leg in enumerate(route.legs):
        first_floor.append(leg)
        if i < len(route.checkpoints) and route.checkpoints[i].kind == "elevator":
            break
    waypoints = np.concatenate([leg.waypoints for leg in first_floor])
    v_ref = np.concatenate([leg.v_ref for leg in first_floor])
    v_ref[-1] = 0.0
    path = m.Path(0.0, route_id, route.legs[0].floor, waypoints, v_ref)
    return m.RouteReply(True, path, legs=legs, checkpoints=checkpoints)


def _checkpoint(c: Checkpoint) -> m.Checkpoint:
    return m.Checkpoint(
        c.kind,
        c.id,
        c.floor,
        _pose(c.approach, c.floor),
        _pose(c.exit, c.to_floor or c.floor),
        c.pass_distance_m,
        c.door_type,
        c.width_m,
        c.to_floor,
        m.Pose2D(c.centre[0], c.centre[1], c.approach[2], c.floor),
        c.controller,
        c.in_sweep,
        c.leaf_away,
    )


def main(argv: list[str] | None = None) -> None:
    with Service(NAME, __doc__.splitlines()[0], argv) as svc:
        cfg, keys, bus = svc.cfg, svc.keys, svc.bus
        try:
            site = load_site(cfg.site)
            routes = RoutePlanner(
                Planner(site, cfg.robot, cfg.planner),
                site,
                cfg.planner,
                cfg.controller.stop_distance_m,
            )
        except SiteError as exc:
            svc.log.error("cannot start: %s", exc)
            raise SystemExit(2) from None
        ids = itertools.count(1)

        def on_route(req: m.RouteRequest) -> m.RouteReply:
            goal = (req.goal.x, req.goal.y) if req.goal is not None else None
            goal_floor = req.goal.floor if req.goal is not None else ""
            for name in routes.expire(req.stamp):
                svc.log.info(
                    "%s is available again: marked unavailable %g s or more ago",
                    name,
                    cfg.planner.unavailable_retry_s,
                )
            try:
                route = routes.request(
                    (req.start.x, req.start.y),
                    req.start.floor,
                    goal,
                    goal_floor,
                    req.place,
                    req.avoid,
                    [(b.x, b.y, b.floor) for b in req.blocked],
                    untraversed=[(u.x, u.y, u.floor) for u in req.untraversed],
                )
            except PlanError as exc:
                svc.log.warning("route refused (%s): %s", exc.code, exc)
                return m.RouteReply(False, error_code=exc.code, error=str(exc))
            route_id = f"route-{next(ids)}"
            svc.log.info(
                "%s: %.1f m, %d legs, checkpoints %s",
                route_id,
                route.length_m,
                len(route.legs),
                [c.id for c in route.checkpoints] or "none",
            )
            return to_reply(route, route_id)

        def on_update(msg: m.Availability) -> None:
            try:
                routes.set_door_blocked(msg.name, not msg.available, msg.stamp)
            except PlanError as exc:
                svc.log.warning("availability update refused: %s", exc)
                return
            svc.log.info(
                "%s is now %s%s",
                msg.name,
                "available" if msg.available else "unavailable",
                f" ({msg.reason})" if msg.reason else "",
            )

        bus.serve(svc.declare("serves", keys.route), m.RouteRequest, on_route)
        bus.subscribe(svc.declare("subscribes", keys.planner_updates), m.Availability, on_update)
        svc.wait()


if __name__ == "__main__":
    main()
