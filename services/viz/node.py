"""Viz service: streams the fleet's topics into a rerun recording or viewer.

Subscribes to pose, ground truth, scans, path, commands and mission status, and logs
them under the entity tree of services/viz/rerun_log.py on the ``sim`` timeline. Records to
an ``.rrd`` file (``--save``), serves a viewer (``--serve``), or connects to a running
viewer (``--viewer URL``).
"""

from __future__ import annotations

import argparse

import rerun as rr

from services.viz import rerun_log
from shared.messages import (
    NavStatus,
    Odometry,
    Path,
    PointCloud,
    PoseEstimate,
    RouteReply,
    TreeSnapshot,
    Twist,
)
from shared.service import Service
from shared.site import SiteError, load_site

NAME = "viz"


def _arguments(parser: argparse.ArgumentParser) -> None:
    sink = parser.add_mutually_exclusive_group()
    sink.add_argument("--save", metavar="FILE.rrd", help="record to a file")
    sink.add_argument("--serve", action="store_true", help="serve a web viewer")
    sink.add_argument("--viewer", metavar="URL", help="connect to a running rerun viewer")


def main(argv: list[str] | None = None) -> None:
    with Service(NAME, __doc__.splitlines()[0], argv, _arguments) as svc:
        cfg, keys, bus, args = svc.cfg, svc.keys, svc.bus, svc.args
        rr.init("wheelnav", spawn=False)
        if args.save:
            rr.save(args.save)
        elif args.serve:
            rr.serve_web_viewer()
        elif args.viewer:
            rr.connect_grpc(args.viewer)
        else:
            rr.spawn()
        try:
            site = load_site(cfg.site)
            s = cfg.sim.start
            floor = site.start_pose(s.place, s.x, s.y, s.theta, s.floor)[3]
            rerun_log.log_site(site, site.floor(floor))
        except SiteError as exc:
            svc.log.warning("no map to show: %s", exc)
        latest: dict[str, PoseEstimate] = {}
        clock = {"t": 0.0}

        def on_pose(msg: PoseEstimate) -> None:
            latest["pose"] = msg
            clock["t"] = msg.stamp
            rerun_log.log_pose(msg)

        bus.subscribe(svc.declare("subscribes", keys.pose), PoseEstimate, on_pose)
        bus.subscribe(svc.declare("subscribes", keys.ground_truth), Odometry, rerun_log.log_truth)
        bus.subscribe(svc.declare("subscribes", keys.cmd_vel), Twist, rerun_log.log_command)
        bus.subscribe(
            svc.declare("subscribes", keys.scan),
            PointCloud,
            lambda m: rerun_log.log_scan(m, latest.get("pose")),
        )
        bus.subscribe(
            svc.declare("subscribes", keys.path), Path, lambda m: rerun_log.log_path(m, clock["t"])
        )
        bus.subscribe(
            svc.declare("subscribes", keys.nav_status), NavStatus, rerun_log.log_nav_status
        )
        bus.subscribe(svc.declare("subscribes", keys.tree), TreeSnapshot, rerun_log.log_tree)
        bus.subscribe(
            svc.declare("subscribes", keys.nav_route),
            RouteReply,
            lambda m: rerun_log.log_route(m, clock["t"]),
        )
        svc.wait()
        rr.disconnect()


if __name__ == "__main__":
    main()
