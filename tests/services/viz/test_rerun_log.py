"""rerun_log's geometry and FleetLog's state: footprints, the tree's layout, localisation
error against the truth of the same tick, the floor whose map is shown."""

from __future__ import annotations

import math

import numpy as np
import rerun as rr

from services.viz.fleet_log import FleetLog, TruthByStamp
from services.viz.rerun_log import (
    footprint_outline,
    localisation_error,
    scan_in_world,
    tree_layout,
)
from shared.config import Footprint
from shared.messages import Odometry, Pose2D, PoseEstimate, TreeNode
from tests.services.viz.fakes import tiny_site


def test_the_footprint_outline_turns_with_the_chair():
    fp = Footprint(width=0.6, rear=0.3, front=0.7)
    outline = footprint_outline(1.0, 2.0, math.pi / 2, fp)
    assert outline.shape == (5, 2) and np.allclose(outline[0], outline[-1])
    # facing +y: the front edge is 0.7 m up, the right side (-y in the chair) at +x
    assert np.allclose(outline[1], [1.3, 2.7])
    assert np.allclose(outline[0], [1.3, 1.7])


def test_the_tree_layout_centres_parents_over_their_children_a_row_per_depth():
    nodes = [
        TreeNode(0, -1, "root", "Sequence", "RUNNING"),
        TreeNode(1, 0, "a", "Leaf", "SUCCESS"),
        TreeNode(2, 0, "b", "Selector", "RUNNING"),
        TreeNode(3, 2, "c", "Leaf", "RUNNING"),
        TreeNode(4, 2, "d", "Leaf", "INVALID"),
    ]
    where = tree_layout(nodes)
    assert where[3][0] < where[4][0] and where[1][0] < where[3][0]
    assert where[2][0] == (where[3][0] + where[4][0]) / 2
    assert where[0][0] == (where[1][0] + where[2][0]) / 2
    assert where[0][1] < where[1][1] == where[2][1] < where[3][1] == where[4][1]
    assert len(set(where.values())) == len(nodes)


def test_the_localisation_error_compares_the_truth_of_the_same_tick():
    truths = TruthByStamp(size=2)
    for stamp, x in ((1.0, 1.0), (1.1, 2.0)):
        truths.add(Odometry(stamp, Pose2D(x, 0.0, 0.0, "1"), 0.5, 0.0))
    pose = PoseEstimate(1.0, Pose2D(1.03, 0.04, 0.0, "1"), np.eye(3))
    assert math.isclose(localisation_error(pose, truths.at(pose.stamp)), 0.05)
    truths.add(Odometry(1.2, Pose2D(3.0, 0.0, 0.0, "1"), 0.5, 0.0))
    assert truths.at(1.0) is None  # forgotten beyond size
    other_floor = PoseEstimate(1.1, Pose2D(2.0, 0.0, 0.0, "2"), np.eye(3))
    assert localisation_error(other_floor, truths.at(1.1)) is None


def test_the_map_shown_follows_the_floor_the_estimate_names():
    log = FleetLog(Footprint(), tiny_site(), start_floor="1")
    rr.set_global_data_recording(rr.RecordingStream("wheelnav-test"))  # logs go nowhere
    try:
        log.on_pose(PoseEstimate(0.1, Pose2D(0.5, 0.4, 0.0, ""), np.eye(3)))
        assert log.floor == "1"  # no floor named: the start floor
        log.on_pose(PoseEstimate(5.0, Pose2D(0.5, 0.4, 0.0, "2"), np.eye(3)))
        assert log.floor == "2"
        log.on_pose(PoseEstimate(6.0, Pose2D(0.5, 0.4, 0.0, "9"), np.eye(3)))
        assert log.floor == "2"  # not a floor of the site: the last map stays
    finally:
        rr.set_global_data_recording(None)


def test_the_scan_shown_on_the_map_leaves_out_the_floor_returns():
    """Seen in a headless viewer on the demo: rings of a 3-D LiDAR's floor returns drawn
    across the floor map as if walls stood there. Only points near the sensor's height
    (as the controller and the localisation take them) are shown."""
    pts = np.array([[1.0, 0.0, 0.05], [2.0, 0.0, -0.6], [0.0, 1.0, -0.1]], dtype=np.float32)
    pose = PoseEstimate(0.0, Pose2D(10.0, 5.0, math.pi / 2, "1"), np.eye(3))
    shown = scan_in_world(pts, pose, 0.5)
    assert np.allclose(shown, [[10.0, 6.0], [9.0, 5.0]], atol=1e-6)
    assert len(scan_in_world(pts, pose, None)) == 3
