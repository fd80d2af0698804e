"""Viz service: streams the fleet's topics into a rerun recording or viewer.

Subscribes to pose, ground truth, scans, path, commands, clearance and mission status, and
logs them under the entity tree of services/viz/rerun_log.py on the ``sim`` timeline.
Records to an ``.rrd`` file (``--save``), serves a viewer (``--serve``), or connects to a
running viewer (``--viewer URL``); each of them gets the layout of services/viz/blueprint.py.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable

import rerun as rr

from services.viz import rerun_log
from services.viz.blueprint import fleet_blueprint
from services.viz.fleet_log import FleetLog
from services.viz.sink_args import add_sink_arguments
from shared.messages import (
    NavStatus,
    Odometry,
    Path,
    PointCloud,
    PoseEstimate,
    RouteReply,
    SimStatus,
    TreeSnapshot,
    Twist,
)
from shared.service import Service
from shared.site import Site, SiteError, load_site

NAME = "viz"


def open_sink(args: argparse.Namespace) -> str | None:
    """Start the recording and its one sink, each given the fleet's layout so that a viewer
    opens on it (a user's own changes to the layout win until they reset it); the gRPC
    address when serving."""
    rr.init("wheelnav", spawn=False)
    layout = fleet_blueprint()
    if args.save:
        rr.save(args.save, default_blueprint=layout)
    elif args.serve:
        uri = rr.serve_grpc(default_blueprint=layout)
        rr.serve_web_viewer(connect_to=uri)
        return uri
    elif args.viewer:
        rr.connect_grpc(args.viewer, default_blueprint=layout)
    else:
        rr.spawn(default_blueprint=layout)
    return None


def _site(svc: Service) -> tuple[Site | None, str]:
    """The site and the floor the chair starts on (no site: no map, the rest is logged)."""
    try:
        site = load_site(svc.cfg.site)
        s = svc.cfg.sim.start
        return site, site.start_pose(s.place, s.x, s.y, s.theta, s.floor)[3]
    except SiteError as exc:
        svc.log.warning("no map to show: %s", exc)
        return None, ""


def main(argv: list[str] | None = None) -> None:
    with Service(NAME, __doc__.splitlines()[0], argv, add_sink_arguments) as svc:
        keys, bus = svc.keys, svc.bus
        uri = open_sink(svc.args)
        if uri:
            svc.log.info("serving the recording on %s", uri)
        site, floor = _site(svc)
        log = FleetLog(svc.cfg.robot.footprint, site, floor, svc.cfg.localisation.scan_band_m)

        def sub(key: str, kind: type, handler: Callable[..., None]) -> None:
            bus.subscribe(svc.declare("subscribes", key), kind, handler)

        sub(keys.pose, PoseEstimate, log.on_pose)
        sub(keys.ground_truth, Odometry, log.on_truth)
        sub(keys.sim_status, SimStatus, rerun_log.log_sim_status)
        sub(keys.cmd_vel, Twist, rerun_log.log_command)
        sub(keys.scan, PointCloud, log.on_scan)
        sub(keys.path, Path, log.on_path)
        sub(keys.nav_status, NavStatus, rerun_log.log_nav_status)
        sub(keys.tree, TreeSnapshot, rerun_log.log_tree)
        sub(keys.nav_route, RouteReply, log.on_route)
        svc.wait()
        rr.disconnect()


if __name__ == "__main__":
    main()
