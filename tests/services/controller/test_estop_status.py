"""The controller's status under the emergency stop (services/controller/node.py)."""

from __future__ import annotations

from services.controller.node import stopped_status
from shared.messages import FollowStatus


def test_the_status_under_the_stop_says_estop_and_keeps_the_paths_figures() -> None:
    last = FollowStatus(3.0, "r.0", "following", 0.4, 2.0, 0.05, precise=True)
    held = stopped_status(last, 4.0, "r.0")
    assert held == FollowStatus(4.0, "r.0", "estop", 0.4, 2.0, 0.05, precise=True)
    dropped = stopped_status(last, 4.0, "")  # the navigator's stop replaced the path
    assert dropped == FollowStatus(4.0, "", "estop", 0.0, 0.0, 0.0)
    assert stopped_status(None, 0.0, "r.0").state == "estop"
