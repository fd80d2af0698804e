"""Rerun logging for wheelnav: one function per entity subtree, no Zenoh.

Entity tree (the contract between logging and the viewer layout of blueprint.py)::

    world/map                   occupancy grid of the floor the chair is on
    world/places                named places on that floor
    world/chair/pose            the localisation's pose (arrow)
    world/chair/pose/footprint  the chair's rectangle at that pose
    world/chair/truth           ground truth (simulation only)
    world/chair/truth/footprint the chair's rectangle at the true pose
    world/chair/scan            LiDAR points, in the world frame
    world/path                  the path being followed: the current leg (or a door pass)
    world/route/legs            the route being driven (after each (re)plan)
    world/route/checkpoints     its doors and lifts: approach poses, labelled
    status/nav                  navigator state as text log
    status/tree                 the live behaviour tree as text (statuses and feedback)
    status/tree_graph           the same tree as a graph, nodes coloured by status
    plots/speed/{measured,commanded}  speed (m/s)
    plots/clearance             the chair's clearance to the nearest obstacle (simulation only)
    plots/localisation_error    distance from the pose estimate to the truth (simulation only)

Time is the data's own: the ``sim`` timeline is set from each message's stamp. The map too
is logged on it (not static), so that a new floor replaces the last one from its stamp on.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import rerun as rr

from shared.config import Footprint
from shared.messages import (
    NavStatus,
    Odometry,
    Path,
    PointCloud,
    PoseEstimate,
    RouteReply,
    SimStatus,
    TreeNode,
    TreeSnapshot,
    Twist,
)
from shared.site import Floor, Site
from shared.tree_text import MARKS, render_tree

CHAIR_COLOUR = [30, 144, 255]
ROUTE_COLOUR = [60, 179, 113]
TRUTH_COLOUR = [120, 120, 120]
PATH_COLOUR = [255, 140, 0]
SCAN_COLOUR = [220, 20, 60]
STATUS_COLOURS = {
    "SUCCESS": [60, 179, 113],
    "FAILURE": [220, 20, 60],
    "RUNNING": [255, 165, 0],
    "INVALID": [170, 170, 170],
}
TREE_DX, TREE_DY = 150.0, 90.0  # graph-view units between neighbouring leaves and depths
NO_CLEARANCE_M = 1e6  # the simulator's cap: no clearance measured yet


def set_time(stamp: float) -> None:
    rr.set_time("sim", duration=stamp)


def map_image(cells: np.ndarray) -> np.ndarray:
    """A floor map's occupancy (ROS: -1 unknown, 0 free .. 100 occupied) as a grey image:
    free white, occupied black, unknown mid grey; row r is y = origin + r * resolution."""
    occ = np.clip(cells.astype(np.int16), 0, 100)
    return np.where(cells < 0, 128, 255 - occ * 255 // 100).astype(np.uint8)


def log_site(site: Site, floor: Floor, stamp: float) -> None:
    """The floor's map as a grey image placed in metres by a transform (a 2D view draws
    images, not the 3D GridMap), and its places, from ``stamp`` on: logging another floor
    later shows that one instead (a lift ride)."""
    set_time(stamp)
    grid = floor.map
    rr.log(
        "world/map",
        rr.Transform3D(translation=[grid.origin[0], grid.origin[1], 0.0], scale=grid.resolution),
        rr.Image(map_image(grid.cells)),
    )
    places = [p for p in site.places.values() if p.floor == floor.name]
    if not places:
        rr.log("world/places", rr.Clear(recursive=False))
        return
    rr.log(
        "world/places",
        rr.Points2D([[p.x, p.y] for p in places], radii=0.08, labels=[p.name for p in places]),
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


def footprint_outline(x: float, y: float, theta: float, footprint: Footprint) -> np.ndarray:
    """The chair's rectangle at the pose (x, y, theta) of its rear axle, as a closed outline
    (5 x 2, the first corner repeated)."""
    half = footprint.width / 2
    local = np.array(
        [
            [-footprint.rear, -half],
            [footprint.front, -half],
            [footprint.front, half],
            [-footprint.rear, half],
            [-footprint.rear, -half],
        ]
    )
    c, s = math.cos(theta), math.sin(theta)
    return local @ np.array([[c, s], [-s, c]]) + [x, y]


def _chair(
    path: str, msg: PoseEstimate | Odometry, footprint: Footprint | None, colour: list[int]
) -> None:
    p = msg.pose
    _arrow(path, p.x, p.y, p.theta, colour)
    if footprint is not None:
        outline = footprint_outline(p.x, p.y, p.theta, footprint)
        rr.log(f"{path}/footprint", rr.LineStrips2D([outline], colors=[colour], radii=0.015))


def log_pose(msg: PoseEstimate, footprint: Footprint | None = None) -> None:
    """The estimated pose, and with a ``footprint`` the chair's outline there."""
    set_time(msg.stamp)
    _chair("world/chair/pose", msg, footprint, CHAIR_COLOUR)


def log_truth(msg: Odometry, footprint: Footprint | None = None) -> None:
    """The true pose (outline too with a ``footprint``) and the measured speed."""
    set_time(msg.stamp)
    _chair("world/chair/truth", msg, footprint, TRUTH_COLOUR)
    rr.log("plots/speed/measured", rr.Scalars(msg.v))


def localisation_error(pose: PoseEstimate, truth: Odometry) -> float | None:
    """How far (m) the estimate is from the true pose; None when they name different floors."""
    a, b = pose.pose, truth.pose
    if a.floor and b.floor and a.floor != b.floor:
        return None
    return math.hypot(a.x - b.x, a.y - b.y)


def log_localisation_error(pose: PoseEstimate, truth: Odometry) -> None:
    """The estimate's distance to the truth of the same tick (simulation only)."""
    error = localisation_error(pose, truth)
    if error is None:
        return
    set_time(pose.stamp)
    rr.log("plots/localisation_error", rr.Scalars(error))


def log_sim_status(msg: SimStatus) -> None:
    """The chair's clearance to the nearest obstacle (m; negative: in collision)."""
    if msg.clearance_m >= NO_CLEARANCE_M:
        return
    set_time(msg.stamp)
    rr.log("plots/clearance", rr.Scalars(msg.clearance_m))


def log_command(msg: Twist) -> None:
    set_time(msg.stamp)
    rr.log("plots/speed/commanded", rr.Scalars(msg.v))


def scan_in_world(points: np.ndarray, pose: PoseEstimate, band_m: float | None) -> np.ndarray:
    """Scan points (N, 3, sensor frame) within ``band_m`` of the sensor's height (all with
    None), moved into the world frame (N, 2) with ``pose``: a 3-D LiDAR's floor returns
    would draw rings on the map that no wall stands on."""
    pts = points if band_m is None else points[np.abs(points[:, 2]) < band_m]
    c, s = math.cos(pose.pose.theta), math.sin(pose.pose.theta)
    xy = pts[:, :2].astype(np.float64)
    return np.stack(
        [pose.pose.x + c * xy[:, 0] - s * xy[:, 1], pose.pose.y + s * xy[:, 0] + c * xy[:, 1]],
        axis=1,
    )


def log_scan(msg: PointCloud, pose: PoseEstimate | None, band_m: float | None = None) -> None:
    """Scan points (those within ``band_m`` of the sensor's height) moved into the world
    frame with the latest pose estimate."""
    if pose is None:
        return
    set_time(msg.stamp)
    world = scan_in_world(msg.points, pose, band_m)
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


def tree_layout(nodes: list[TreeNode]) -> dict[int, tuple[float, float]]:
    """Where each node of a tree snapshot goes in the graph view, Groot-like: one row per
    depth downwards from the root, leaves side by side in display order, each parent centred
    over its children. Fixed positions keep the tree still while statuses change."""
    ids = {n.id for n in nodes}
    children: dict[int, list[int]] = {}
    for n in nodes:
        children.setdefault(n.parent if n.parent in ids else -1, []).append(n.id)
    leaves = itertools.count()
    where: dict[int, tuple[float, float]] = {}

    def place(node: int, depth: int) -> float:
        xs = [place(child, depth + 1) for child in children.get(node, [])]
        x = (xs[0] + xs[-1]) / 2 if xs else float(next(leaves))
        where[node] = (x * TREE_DX, depth * TREE_DY)
        return x

    for root in children.get(-1, []):
        place(root, 0)
    return where


def _log_tree_graph(msg: TreeSnapshot) -> None:
    if not msg.nodes:
        rr.log("status/tree_graph", rr.Clear(recursive=False))
        return
    where = tree_layout(msg.nodes)
    ids = {n.id for n in msg.nodes}
    rr.log(
        "status/tree_graph",
        rr.GraphNodes(
            [str(n.id) for n in msg.nodes],
            positions=[where[n.id] for n in msg.nodes],
            colors=[STATUS_COLOURS.get(n.status, STATUS_COLOURS["INVALID"]) for n in msg.nodes],
            labels=[f"{MARKS.get(n.status, '?')} {n.name}" for n in msg.nodes],
            show_labels=True,
        ),
        rr.GraphEdges(
            [(str(n.parent), str(n.id)) for n in msg.nodes if n.parent in ids],
            graph_type="directed",
        ),
    )


def log_tree(msg: TreeSnapshot) -> None:
    """The behaviour tree as text, as ``wheelnav tree`` draws it, and as a graph coloured by
    status (green success, red failure, orange running, grey not ticked)."""
    set_time(msg.stamp)
    text = f"```\n{render_tree(msg)}\n```"
    rr.log("status/tree", rr.TextDocument(text, media_type=rr.MediaType.MARKDOWN))
    _log_tree_graph(msg)


def log_nav_status(msg: NavStatus) -> None:
    set_time(msg.stamp)
    parts = [msg.state, msg.action, msg.phase, f"{100 * msg.progress:.0f} %", msg.reason]
    text = " ".join(p for p in parts if p)
    level = rr.TextLogLevel.ERROR if msg.state == "failed" else rr.TextLogLevel.INFO
    rr.log("status/nav", rr.TextLog(text, level=level))
