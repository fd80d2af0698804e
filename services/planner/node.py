"""Planner service: answers route requests on the robot's route key.

Loads the site once, inflates every floor, and replies to each RouteRequest with a
RouteReply: a path with a speed profile, or an error code from services/planner/errors.py
and a one-line reason (goal in a wall, unknown place, no path...).
"""

from __future__ import annotations

import itertools

from services.planner.core import Planner
from services.planner.errors import PlanError
from shared.messages import Path, RouteReply, RouteRequest
from shared.service import Service
from shared.site import SiteError, load_site

NAME = "planner"


def main(argv: list[str] | None = None) -> None:
    with Service(NAME, __doc__.splitlines()[0], argv) as svc:
        cfg, keys, bus = svc.cfg, svc.keys, svc.bus
        try:
            planner = Planner(load_site(cfg.site), cfg.robot, cfg.planner)
        except SiteError as exc:
            svc.log.error("cannot start: %s", exc)
            raise SystemExit(2) from None
        ids = itertools.count(1)

        def on_route(req: RouteRequest) -> RouteReply:
            goal = (req.goal.x, req.goal.y) if req.goal is not None else None
            goal_floor = req.goal.floor if req.goal is not None else ""
            try:
                plan = planner.route(
                    (req.start.x, req.start.y), req.start.floor, goal, goal_floor, req.place
                )
            except PlanError as exc:
                svc.log.warning("route refused (%s): %s", exc.code, exc)
                return RouteReply(False, error_code=exc.code, error=str(exc))
            path = Path(0.0, f"route-{next(ids)}", plan.floor, plan.waypoints, plan.v_ref)
            svc.log.info(
                "route %s: %.1f m, %d waypoints", path.path_id, plan.length_m, len(plan.waypoints)
            )
            return RouteReply(True, path=path)

        bus.serve(svc.declare("serves", keys.route), RouteRequest, on_route)
        svc.wait()


if __name__ == "__main__":
    main()
