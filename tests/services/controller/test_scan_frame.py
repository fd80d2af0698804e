"""A scan is placed on the map with the pose the chair had when it was taken."""

from __future__ import annotations

import math

import numpy as np
import pytest

from services.controller.node import PoseHistory, scan_to_world
from shared.messages import PointCloud, Pose2D, PoseEstimate


def _est(t: float, theta: float) -> PoseEstimate:
    return PoseEstimate(t, Pose2D(0.0, 0.0, theta, "1"), np.eye(3))


def test_a_scan_taken_before_a_turn_is_placed_with_the_pose_it_was_taken_at() -> None:
    # campaign b2.m00 and b8.m03: turning on the spot at 0.5 rad/s beside a wall, a scan
    # 0.1 s old placed with the newest pose sat 3 degrees round, 4 cm off at the corners;
    # the docker's turn check kept 5 cm from points that were not where the wall was, and
    # the chair's corner passed 0.047 m from it
    history = PoseHistory(1.0)
    for i in range(6):
        history.add(_est(0.02 * i, 0.5 * 0.02 * i))  # turning at 0.5 rad/s
    scan = PointCloud(0.0, "lidar", np.array([[0.8, 0.0, 0.0]], np.float32))
    assert history.at(0.0).pose.theta == 0.0
    wall = scan_to_world(scan, history.at(scan.stamp), 0.5, 4.0)
    assert wall[0] == pytest.approx([0.8, 0.0])
    newest = scan_to_world(scan, history.latest(), 0.5, 4.0)
    assert math.hypot(*(newest[0] - wall[0])) > 0.03  # what the newest pose did


def test_the_history_keeps_a_window_and_answers_the_nearest_pose_not_after() -> None:
    history = PoseHistory(0.5)
    assert history.at(1.0) is None and history.latest() is None
    for i in range(100):
        history.add(_est(0.02 * i, 0.01 * i))
    assert history.oldest_stamp() >= 1.98 - 0.5 - 1e-9
    assert history.at(1.9).stamp == pytest.approx(1.9)
    assert history.at(1.905).stamp == pytest.approx(1.9)  # not after the scan
    assert history.at(0.0).stamp == history.oldest_stamp()  # older than kept: the oldest
    assert history.at(5.0).stamp == pytest.approx(1.98)
