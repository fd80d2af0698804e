"""Per-checkpoint figures from statuses and true poses, in either arrival order."""

from __future__ import annotations

from shared.messages import Checkpoint, Pose2D
from wheelnav.mission.checkpoints import CheckpointLog

DOOR = Checkpoint(
    "door",
    "d1",
    "1",
    Pose2D(1.0, 0.0, 0.0, "1"),
    Pose2D(3.2, 0.0, 0.0, "1"),
    2.2,
    "manual",
    centre=Pose2D(2.0, 0.0, 0.0, "1"),
)


def corrected(late_status: bool) -> dict:
    log = CheckpointLog()
    log.on_route([DOOR])
    log.on_truth(1.0, 0.5, 0.0, 0.0, 0.1, "1")
    log.on_status(1.0, "Door d1 (2/3)", "correct")
    log.on_truth(2.0, 0.98, 0.01, 0.02, 0.0, "1")
    if late_status:  # the next tick's truth overtook the status of tick 2.0
        log.on_truth(2.02, 0.90, 0.01, 0.30, 0.0, "1")
        log.on_status(2.0, "Door d1 (2/3)", "turn")
    else:
        log.on_status(2.0, "Door d1 (2/3)", "turn")
        log.on_truth(2.02, 0.90, 0.01, 0.30, 0.0, "1")
    (row,) = log.rows(3.0)
    return row


def test_phase0_errors_are_taken_at_the_status_tick_whatever_arrives_first() -> None:
    in_order, late = corrected(False), corrected(True)
    assert in_order["position_error_m"] == late["position_error_m"] == 0.022  # (0.98, 0.01)
    assert in_order["heading_error_deg"] == late["heading_error_deg"] == 1.15  # 0.02 rad
    assert in_order["correction_s"] == 1.0 and in_order["result"] == "abandoned"
