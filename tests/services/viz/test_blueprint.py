"""The viewer layout: sent with every recording and stream, and each of its views shows only
entity paths the viz node really logs (fed here with synthetic messages through the node's
own handlers, into an .rrd file as ``wheelnav mission --rrd`` records one)."""

from __future__ import annotations

import argparse
import inspect
import pathlib

import numpy as np
import pytest
import rerun as rr
import rerun.blueprint as rrb
from rerun.chunk import RrdReader

from services.viz import node, rerun_log
from services.viz.blueprint import TIMELINE, fleet_blueprint
from services.viz.fleet_log import FleetLog
from shared.config import Footprint
from shared.messages import (
    Checkpoint,
    NavStatus,
    Odometry,
    Path,
    PointCloud,
    Pose2D,
    PoseEstimate,
    RouteReply,
    SimStatus,
    TreeNode,
    TreeSnapshot,
    Twist,
)
from tests.services.viz.fakes import tiny_site

VIEW_CLASSES = {"2D", "TimeSeries", "Graph", "TextDocument", "TextLog"}


def leg(stamp: float) -> Path:
    return Path(stamp, "leg0", "1", np.array([[0.2, 0.4], [0.5, 0.4], [0.8, 0.5]]), np.zeros(3))


def tree(stamp: float) -> TreeSnapshot:
    nodes = [
        TreeNode(0, -1, "Mission", "Sequence", "RUNNING"),
        TreeNode(1, 0, "Plan", "PlanRoute", "SUCCESS"),
        TreeNode(2, 0, "Drive", "Selector", "RUNNING"),
        TreeNode(3, 2, "Follow", "FollowPath", "RUNNING", "40 %"),
        TreeNode(4, 2, "Recover", "Recover", "INVALID"),
        TreeNode(5, 0, "Arrive", "Arrive", "FAILURE"),
    ]
    return TreeSnapshot(stamp, "g1", "mission", nodes)


def feed(log: FleetLog) -> None:
    """One of each message the node subscribes to, then a ride to floor 2."""
    for stamp, floor in ((1.0, "1"), (2.0, "2")):
        log.on_truth(Odometry(stamp, Pose2D(0.5, 0.4, 0.0, floor), 0.4, 0.0))
        log.on_pose(PoseEstimate(stamp, Pose2D(0.53, 0.4, 0.02, floor), 0.01 * np.eye(3)))
    scan = np.array([[1.0, 0.0, 0.2], [0.0, 1.0, 0.2]], dtype=np.float32)
    log.on_scan(PointCloud(2.0, "lidar", scan))
    rerun_log.log_command(Twist(2.0, 0.4, 0.1))
    rerun_log.log_sim_status(SimStatus(2.0, 0, False, 0.31, 0.3))
    log.on_path(leg(2.0))
    door = Checkpoint("door", "d1", "1", Pose2D(0.5, 0.4, 0.0), Pose2D(0.7, 0.4, 0.0), 0.2)
    log.on_route(RouteReply(True, legs=[leg(2.0), leg(2.0)], checkpoints=[door]))
    rerun_log.log_nav_status(NavStatus(2.0, "g1", "running", "drive", "follow", "", 0.4))
    rerun_log.log_tree(tree(2.0))


def record(path: pathlib.Path) -> None:
    """What the viz node records with ``--save path`` for the messages of ``feed``."""
    node.open_sink(argparse.Namespace(save=str(path), serve=False, viewer=None))
    feed(FleetLog(Footprint(), tiny_site(), "1"))
    rr.disconnect()


def cells(chunk, column: str) -> list:
    """The values of a chunk's component column, one per row (row lists flattened)."""
    out: list = []
    for value in chunk.to_record_batch().column(column).to_pylist():
        out += value if isinstance(value, list) else [value]
    return out


def recorded(path: pathlib.Path) -> tuple[dict[str, int], dict[str, dict], list[str], object]:
    """Rows logged per entity path, the blueprint's views (class, name, origin, query), the
    time panel's timeline, and the reader."""
    reader = RrdReader(path)
    (data,) = reader.recordings()
    rows: dict[str, int] = {}
    for chunk in reader.stream(store=data):
        if not chunk.entity_path.startswith("/__"):
            key = chunk.entity_path.lstrip("/")
            rows[key] = rows.get(key, 0) + chunk.num_rows
    views: dict[str, dict] = {}
    timeline: list[str] = []
    (layout,) = reader.blueprints()
    for chunk in reader.stream(store=layout):
        names = chunk.to_record_batch().schema.names
        parts = chunk.entity_path.strip("/").split("/")
        if parts[0] == "view":
            view = views.setdefault(parts[1], {})
            for column in names:
                if ":" in column:
                    view[column.split(":")[1]] = cells(chunk, column)
        elif parts[0] == "time_panel" and "TimePanelBlueprint:timeline" in names:
            timeline = cells(chunk, "TimePanelBlueprint:timeline")
    return rows, views, timeline, reader


def unlogged(views: dict[str, dict], logged: set[str]) -> list[tuple[str, str]]:
    """(view, expression) for every expression of a view's contents that matches nothing
    logged: an exact path not logged, or a ``path/**`` with nothing at or under it."""
    missing = []
    for view in views.values():
        origin = view["space_origin"][0].strip("/")
        for expr in view.get("query", []):
            if expr.startswith("- "):
                continue
            path = expr.removeprefix("+ ").replace("$origin", origin).strip("/")
            if path.endswith("/**"):
                base = path[:-3]
                found = any(p == base or p.startswith(base + "/") for p in logged)
            else:
                found = path in logged
            if not found:
                missing.append((view.get("display_name", ["?"])[0], expr))
    return missing


def test_every_view_of_the_recorded_layout_shows_entities_the_node_logs(tmp_path):
    rrd = tmp_path / "run.rrd"
    record(rrd)
    rows, views, timeline, reader = recorded(rrd)
    assert reader.blueprints()[0].application_id == reader.recordings()[0].application_id
    assert {v["class_identifier"][0] for v in views.values()} == VIEW_CLASSES
    assert len(views) == 7 and all(v.get("query") for v in views.values())
    assert unlogged(views, set(rows)) == []
    assert timeline == [TIMELINE]
    # the floor's map again when the chair reaches floor 2, on the same timeline
    assert rows["world/map"] == 2
    for chunk in reader.stream(store=reader.recordings()[0]):
        if not chunk.is_static:
            assert TIMELINE in chunk.timeline_names, chunk.entity_path


# archetypes a 2D view cannot draw without a pinhole camera at its origin (the viewer says
# "3D visualizers require a pinhole at the origin of the 2D view" and leaves them out)
ONLY_3D = ("GridMap", "Points3D", "Boxes3D", "LineStrips3D", "Arrows3D", "Mesh3D", "Asset3D")


def test_the_floor_map_view_shows_only_what_a_2d_view_draws(tmp_path):
    """Seen in a headless rerun viewer (0.41, llvmpipe) on a recorded demo run: the floor's
    map, logged as a GridMap (a 3D archetype), was missing from the 2D floor-map view,
    which reported the error above; only the scan and the route were drawn."""
    rrd = tmp_path / "run.rrd"
    record(rrd)
    _rows, views, _, reader = recorded(rrd)
    origins = [
        v["space_origin"][0].strip("/") for v in views.values() if v["class_identifier"] == ["2D"]
    ]
    assert origins == ["world"]
    found = []
    for chunk in reader.stream(store=reader.recordings()[0]):
        path = chunk.entity_path.strip("/")
        if path == "world" or path.startswith("world/"):
            found += [
                (path, n)
                for n in chunk.to_record_batch().schema.names
                if n.split(":")[0] in ONLY_3D
            ]
    assert found == []
    assert rows_with(reader, "world/map", "Image:buffer") and rows_with(
        reader, "world/map", "Transform3D:scale"
    )


def rows_with(reader, path: str, column: str) -> int:
    """Rows of ``path`` that carry ``column``."""
    return sum(
        chunk.num_rows
        for chunk in reader.stream(store=reader.recordings()[0])
        if chunk.entity_path.strip("/") == path and column in chunk.to_record_batch().schema.names
    )


def test_a_view_naming_an_entity_never_logged_is_caught(tmp_path):
    rrd = tmp_path / "bad.rrd"
    bad = rrb.Blueprint(
        rrb.Spatial2DView(name="Map", origin="world", contents=["world/map", "world/nowhere"]),
        rrb.TimeSeriesView(name="Plots", origin="plots", contents="$origin/**"),
    )
    rec = rr.RecordingStream("wheelnav")
    rec.save(rrd, default_blueprint=bad)
    rec.log("world/map", rr.Points2D([[0.0, 0.0]]))
    rec.disconnect()
    rows, views, _, _ = recorded(rrd)
    assert sorted(unlogged(views, set(rows))) == [("Map", "world/nowhere"), ("Plots", "$origin/**")]


@pytest.mark.parametrize(
    ("args", "sink"),
    [
        ({"save": "run.rrd"}, "save"),
        ({"serve": True}, "serve_grpc"),
        ({"viewer": "rerun+http://laptop:9876/proxy"}, "connect_grpc"),
        ({}, "spawn"),
    ],
)
def test_every_sink_is_given_the_layout(monkeypatch, args, sink):
    given: dict[str, object] = {}

    def fake(name: str):
        """Stands in for rr.<name>, refusing arguments the real one would refuse."""
        real = inspect.signature(getattr(rr, name))

        def call(*args, **kwargs):
            given[name] = real.bind(*args, **kwargs).arguments.get("default_blueprint")
            return "rerun+http://127.0.0.1:9876/proxy"

        return call

    for name in ("save", "serve_grpc", "serve_web_viewer", "connect_grpc", "spawn"):
        monkeypatch.setattr(rr, name, fake(name))
    parsed = argparse.Namespace(**{"save": None, "serve": False, "viewer": None, **args})
    node.open_sink(parsed)
    assert isinstance(given.pop(sink), rrb.Blueprint)
    assert set(given) <= {"serve_web_viewer"}  # the web page only shows the served stream


def test_the_layout_has_one_map_beside_tree_plots_and_status():
    layout = fleet_blueprint()
    root = layout.root_container
    assert isinstance(root, rrb.Horizontal)
    floor_map, column = root.contents
    assert isinstance(floor_map, rrb.Spatial2DView) and isinstance(column, rrb.Vertical)
    assert layout.time_panel.timeline == TIMELINE
