"""Per-checkpoint figures for the mission report, measured on the ground truth.

For each door: the position and heading error when the chair sets off through it (the
end of position correction), how long it waited at the approach pose, and its lateral
offset from the door's centre when it crossed the door plane. For each elevator: the
floors, the wait at the car, and the time from entering to leaving. Pure: the runner
feeds it the route and the true poses.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from shared.messages import Checkpoint

NEAR_M = 0.3  # "at the approach pose": within this distance of it
STILL = 0.03  # m/s: standing


@dataclass
class _Track:
    cp: Checkpoint
    arrived_s: float | None = None
    set_off_s: float | None = None
    position_error_m: float | None = None
    heading_error_deg: float | None = None
    crossed_s: float | None = None
    lateral_offset_m: float | None = None
    floor_after: str = ""
    _side: float | None = None


@dataclass
class CheckpointLog:
    """Follows the chair through the current route's checkpoints, in order."""

    done: list[dict[str, Any]] = field(default_factory=list)
    _queue: list[_Track] = field(default_factory=list)

    def on_route(self, checkpoints: list[Checkpoint]) -> None:
        """A (new) route: the checkpoints still ahead."""
        self._queue = [_Track(cp) for cp in checkpoints]

    def on_truth(
        self, stamp: float, x: float, y: float, theta: float, v: float, floor: str
    ) -> None:
        if not self._queue:
            return
        t = self._queue[0]
        cp = t.cp
        ax, ay, ath = cp.approach.x, cp.approach.y, cp.approach.theta
        dist = math.hypot(x - ax, y - ay)
        if t.arrived_s is None and dist < NEAR_M:
            t.arrived_s = stamp
        along = (x - ax) * math.cos(ath) + (y - ay) * math.sin(ath)
        if t.arrived_s is not None and t.set_off_s is None:
            if t.position_error_m is None or dist < t.position_error_m:
                t.position_error_m = dist  # closest approach = end of position correction
            if along > 0.05 and v > STILL:
                t.set_off_s = stamp
                dth = math.atan2(math.sin(theta - ath), math.cos(theta - ath))
                t.heading_error_deg = math.degrees(abs(dth))
        if cp.kind == "door":
            self._door(t, stamp, x, y)
        elif (
            t.set_off_s is not None
            and floor == cp.to_floor
            and abs(v) < STILL
            and math.hypot(x - cp.exit.x, y - cp.exit.y) < NEAR_M
        ):
            t.floor_after = floor
            self._finish(stamp)

    def _door(self, t: _Track, stamp: float, x: float, y: float) -> None:
        c = t.cp.centre or t.cp.approach
        n = (math.cos(t.cp.approach.theta), math.sin(t.cp.approach.theta))
        side = (x - c.x) * n[0] + (y - c.y) * n[1]
        if t._side is not None and t._side < 0 <= side:
            t.crossed_s = stamp
            t.lateral_offset_m = -(x - c.x) * n[1] + (y - c.y) * n[0]
            self._finish(stamp)
            return
        t._side = side

    def _finish(self, stamp: float) -> None:
        t = self._queue.pop(0)
        cp = t.cp
        row: dict[str, Any] = {"kind": cp.kind, "id": cp.id, "floor": cp.floor}
        wait = (t.set_off_s - t.arrived_s) if t.set_off_s and t.arrived_s is not None else None
        row.update(
            {
                "arrived_s": _r(t.arrived_s),
                "set_off_s": _r(t.set_off_s),
                "wait_s": _r(wait),
                "position_error_m": _r(t.position_error_m, 3),
                "heading_error_deg": _r(t.heading_error_deg, 2),
            }
        )
        if cp.kind == "door":
            row.update({"crossed_s": _r(stamp), "lateral_offset_m": _r(t.lateral_offset_m, 3)})
        else:
            row.update({"to_floor": cp.to_floor, "left_car_s": _r(stamp)})
        self.done.append(row)


def _r(value: float | None, digits: int = 2) -> float | None:
    return None if value is None else round(value, digits)
