"""A restarted localisation resumes from its saved pose, moved on by the odometry since."""

from __future__ import annotations

import math

import pytest

from services.localisation.localiser import OdometryLocaliser
from services.localisation.resume import SavedPose, resume_from


def test_the_saved_pose_round_trips_and_bad_ones_are_named() -> None:
    saved = SavedPose(12.5, 3.0, 4.0, 0.5, "2", (10.0, -1.0, 1.0))
    assert SavedPose.from_dict(saved.to_dict()) == saved
    for broken in ({}, {**saved.to_dict(), "pose": [1, 2]}, {**saved.to_dict(), "floor": 2}):
        with pytest.raises(ValueError, match="saved pose"):
            SavedPose.from_dict(broken)
    with pytest.raises(ValueError, match="not finite"):
        SavedPose.from_dict({**saved.to_dict(), "stamp": math.nan})


def test_only_a_save_of_this_run_and_recent_enough_is_resumed() -> None:
    saved = SavedPose(12.5, 3.0, 4.0, 0.5, "2", (0.0, 0.0, 0.0))
    assert resume_from(saved, 13.1, 30.0) == ""
    assert "earlier run" in resume_from(saved, 0.04, 30.0)  # a fresh simulation's clock
    assert "50.0 s old" in resume_from(saved, 62.5, 30.0)
    assert resume_from(None, 1.0, 30.0) == "no saved pose"


def test_the_motion_while_it_was_down_is_kept() -> None:
    # saved at map (3, 4) facing +y with odometry at (10, -1) facing +x; the chair then
    # drove 1 m ahead on odometry: on the map that is 1 m along +y
    loc = OdometryLocaliser(0.0, 0.0, 0.0, "1")  # the configured start pose
    loc.reset(3.0, 4.0, math.pi / 2, "2", (10.0, -1.0, 0.0))
    assert loc.update(11.0, -1.0, 0.0) == pytest.approx((3.0, 5.0, math.pi / 2))
    assert loc.floor == "2"
