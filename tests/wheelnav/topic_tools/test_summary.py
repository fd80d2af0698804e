"""Topic tool helpers: readable summaries and rate statistics."""

from __future__ import annotations

import numpy as np

from shared.messages import Odometry, PointCloud, Pose2D
from wheelnav.topic_tools.summary import RateMeter, summarise


def test_summary_shows_fields_and_array_shapes() -> None:
    text = summarise(PointCloud(1.5, "lidar", np.ones((500, 3), np.float32)))
    assert "type: point_cloud" in text and "array float32 (500, 3)" in text and "..." in text
    text = summarise(Odometry(2.0, Pose2D(1.0, 2.0, 0.5, "1"), 0.3, 0.0))
    assert "pose: {x=1.0000, y=2.0000, theta=0.5000, floor='1'}" in text


def test_rate_meter() -> None:
    m = RateMeter(window=10)
    assert m.stats() is None
    for i in range(50):
        m.tick(i * 0.02)
    s = m.stats()
    assert abs(s["rate_hz"] - 50.0) < 1e-6 and s["n"] == 10


def test_summary_shows_diagnostics_one_key_per_line() -> None:
    from shared.messages import Diagnostics, KeyCounters

    text = summarise(
        Diagnostics(
            1.7e9, "planner", 42, 2, 3.0, 7, 4, [KeyCounters("a/b", 5, 4), KeyCounters("c", 2, 0)]
        )
    )
    assert "restarts: 2" in text and "bad_messages: 4" in text
    assert "keys: 2\n    - {key='a/b', messages_in=5, bad_messages=4}\n    - {key='c'" in text
