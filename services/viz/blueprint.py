"""The viewer layout sent with every recording and live stream (a rerun blueprint).

Without it the viewer guesses a layout from the entities it sees. With it: the floor map
with the chair, its LiDAR points and route on the left; the behaviour tree, the time series
and the mission status on the right; the ``sim`` timeline selected. Each view names its
entity paths one by one (no globs): they are those of rerun_log.py, and a test checks every
one of them is logged.
"""

from __future__ import annotations

import rerun.blueprint as rrb

TIMELINE = "sim"  # set by rerun_log.set_time from each message's stamp

MAP = (
    "world/map",
    "world/places",
    "world/route/legs",
    "world/route/checkpoints",
    "world/path",
    "world/chair/scan",
    "world/chair/truth",
    "world/chair/truth/footprint",
    "world/chair/pose",
    "world/chair/pose/footprint",
)
SPEED = ("plots/speed/commanded", "plots/speed/measured")
CLEARANCE = ("plots/clearance",)
LOCALISATION_ERROR = ("plots/localisation_error",)
TREE_GRAPH = ("status/tree_graph",)
TREE_TEXT = ("status/tree",)
STATUS = ("status/nav",)


def _plot(name: str, paths: tuple[str, ...]) -> rrb.TimeSeriesView:
    """A time series with its time axis tied to the other plots' (zoom one, zoom all)."""
    return rrb.TimeSeriesView(
        name=name,
        origin="plots",
        contents=list(paths),
        axis_x=rrb.TimeAxis(link="LinkToGlobal"),
    )


def _tree_graph() -> rrb.GraphView:
    """The tree where rerun_log.tree_layout puts it: every force of the graph layout off, so
    nodes neither drift nor jump when a status changes."""
    off = {"enabled": False}
    return rrb.GraphView(
        name="Behaviour tree",
        origin=TREE_GRAPH[0],
        contents=list(TREE_GRAPH),
        force_link=rrb.archetypes.ForceLink(**off),
        force_many_body=rrb.archetypes.ForceManyBody(**off),
        force_position=rrb.archetypes.ForcePosition(**off),
        force_collision_radius=rrb.archetypes.ForceCollisionRadius(**off),
        force_center=rrb.archetypes.ForceCenter(**off),
    )


def _right_column() -> rrb.Vertical:
    tree = rrb.Tabs(
        _tree_graph(),
        rrb.TextDocumentView(name="Tree (text)", origin=TREE_TEXT[0], contents=list(TREE_TEXT)),
    )
    plots = rrb.Vertical(
        _plot("Speed (m/s)", SPEED),
        _plot("Clearance (m)", CLEARANCE),
        _plot("Localisation error (m)", LOCALISATION_ERROR),
    )
    status = rrb.TextLogView(name="Mission", origin=STATUS[0], contents=list(STATUS))
    return rrb.Vertical(tree, plots, status, row_shares=[4, 4, 2])


def fleet_blueprint() -> rrb.Blueprint:
    """The layout of the fleet's recording: the map (current floor) beside the tree, plots
    and status, on the simulation timeline."""
    floor_map = rrb.Spatial2DView(name="Floor map", origin="world", contents=list(MAP))
    return rrb.Blueprint(
        rrb.Horizontal(floor_map, _right_column(), column_shares=[3, 2]),
        rrb.TimePanel(timeline=TIMELINE),
        auto_views=False,
    )
