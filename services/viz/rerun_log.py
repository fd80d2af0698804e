"""Rerun logging for wheelnav: one function per entity subtree, no Zenoh.

Entity tree (the contract between logging and the viewer layout)::

    world/map                 occupancy grid of the current floor (static)
    world/places              named places of the site (static)
    world/chair/pose          the localisation's pose (arrow)
    world/chair/truth         ground truth (simulation only)
    world/chair/scan          LiDAR points, in the world frame
    world/path                the path being followed
    world/route/legs          the route being driven (after each (re)plan)
    world/route/checkpoints   its doors and lifts: approach poses, labelled
    status/nav                navigator state as text log
    status/tree               the live behaviour tree (statuses and feedback)
    plots/speed               commanded and measured speed

Time is the data's own: the ``sim`` timeline is set from each message's stamp.
"""

from __future__ import annotations

import math

import numpy as np
import rerun as rr

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
from shared.site import Floor, Site
from shared.tree_text import render_tree

CHAIR_COLOUR = [30, 144, 255]
ROUTE_COLOUR = [60, 179, 113]
TRUTH_COLOUR = [120, 120, 120]
PATH_COLOUR = [255, 140, 0]
SCAN_COLOUR = [220, 20, 60]


def set_time(stamp: float) -> None:
    rr.set_time("sim", duration=stamp)


def log_site(site: Site, floor: Floor) -> None:
    """The floor's map as a GridMap (ROS occupancy conventions) and the site's places."""
    grid = floor.map
    cells = grid.cells.astype(np.int8)
    h, w = cells.shape
    rr.log(
        "world/map",
        rr.GridMap(
            data=cells.tobytes(),
            format=rr.components.ImageFormat(
                width=w, height=h, color_model="L", channel_datatype="U8"
            ),
            cell_size=grid.resolution,
            translation=[grid.origin[0], grid.origin[1], 0.0],
            colormap=rr.components.Colormap.RvizMap,
        ),
        static=True,
    )
    places = [p for p in site.places.values() if p.floor == floor.name]
    if places:
        rr.log(
            "world/places",
            rr.Points2D([[p.x, p.y] for p in places], radii=0.08, labels=[p.name for p in places]),
            static=True,
        )


def _arrow(path: str, x: float, y: float, theta: float, colour: list[int]) -> None:
    rr.log(
        path,
        rr.Arrows2D(
            origins=[[x, y]],
            vectors=[[0.5 * math.cos(theta), 0.5 * math.sin(theta)]],
            colors=[colour],
        ),
    )


def log_pose(msg: PoseEstimate) -> None:
    set_time(msg.stamp)
    _arrow("world/chair/pose", msg.pose.x, msg.pose.y, msg.pose.theta, CHAIR_COLOUR)


def log_truth(msg: Odometry) -> None:
    set_time(msg.stamp)
    _arrow("world/chair/truth", msg.pose.x, msg.pose.y, msg.pose.theta, TRUTH_COLOUR)
    rr.log("plots/speed/measured", rr.Scalars(msg.v))


def log_command(msg: Twist) -> None:
    set_time(msg.stamp)
    rr.log("plots/speed/commanded", rr.Scalars(msg.v))


def log_scan(msg: PointCloud, pose: PoseEstimate | None) -> None:
    """Scan points moved into the world frame with the latest pose estimate."""
    if pose is None:
        return
    set_time(msg.stamp)
    c, s = math.cos(pose.pose.theta), math.sin(pose.pose.theta)
    pts = msg.points[:, :2].astype(np.float64)
    world = np.stack(
        [pose.pose.x + c * pts[:, 0] - s * pts[:, 1], pose.pose.y + s * pts[:, 0] + c * pts[:, 1]],
        axis=1,
    )
    rr.log("world/chair/scan", rr.Points2D(world, radii=0.03, colors=[SCAN_COLOUR]))


def log_path(msg: Path, stamp: float) -> None:
    set_time(stamp)
    if len(msg.waypoints) == 0:
        rr.log("world/path", rr.Clear(recursive=False))
        return
    rr.log("world/path", rr.LineStrips2D([msg.waypoints], colors=[PATH_COLOUR], radii=0.03))


def log_route(msg: RouteReply, stamp: float) -> None:
    """The route's legs and its checkpoints' approach poses (labelled with their ids)."""
    set_time(stamp)
    legs = [leg.waypoints for leg in msg.legs if len(leg.waypoints) > 1]
    if legs:
        rr.log("world/route/legs", rr.LineStrips2D(legs, colors=[ROUTE_COLOUR], radii=0.02))
    if msg.checkpoints:
        rr.log(
            "world/route/checkpoints",
            rr.Points2D(
                [[c.approach.x, c.approach.y] for c in msg.checkpoints],
                radii=0.12,
                colors=[ROUTE_COLOUR],
                labels=[f"{c.kind} {c.id}" for c in msg.checkpoints],
            ),
        )


def log_tree(msg: TreeSnapshot) -> None:
    """The behaviour tree as text, as ``wheelnav tree`` draws it."""
    set_time(msg.stamp)
    text = f"```\n{render_tree(msg)}\n```"
    rr.log("status/tree", rr.TextDocument(text, media_type=rr.MediaType.MARKDOWN))


def log_nav_status(msg: NavStatus) -> None:
    set_time(msg.stamp)
    parts = [msg.state, msg.action, msg.phase, f"{100 * msg.progress:.0f} %", msg.reason]
    text = " ".join(p for p in parts if p)
    level = rr.TextLogLevel.ERROR if msg.state == "failed" else rr.TextLogLevel.INFO
    rr.log("status/nav", rr.TextLog(text, level=level))
