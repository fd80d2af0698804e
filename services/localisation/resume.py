"""Where a restarted localisation picks up: the last pose it published, moved on by the
odometry since.

The service saves its pose together with the odometry pose it had then. Restarted, it
takes the saved pose only if the first odometry it hears is no older than the save and at
most ``within_s`` newer (an older save belongs to an earlier run: a fresh simulation's
clock starts again at zero), and re-anchors its odometry on the saved odometry pose, so the
motion while it was down is not lost however long ago the last save was. Pure: no I/O.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class SavedPose:
    """The last published pose, its floor and the odometry pose (ox, oy, otheta) of then."""

    stamp: float
    x: float
    y: float
    theta: float
    floor: str
    odom: tuple[float, float, float]

    def to_dict(self) -> dict[str, Any]:
        return {
            "stamp": self.stamp,
            "pose": [self.x, self.y, self.theta],
            "floor": self.floor,
            "odom": list(self.odom),
        }

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> SavedPose:
        """The saved pose; ValueError naming the field if ``d`` is not one."""
        try:
            stamp = float(d["stamp"])
            x, y, theta = (float(v) for v in d["pose"])
            ox, oy, ot = (float(v) for v in d["odom"])
            floor = d["floor"]
        except (KeyError, TypeError, ValueError) as exc:
            raise ValueError(f"saved pose: missing or malformed field ({exc})") from None
        if not isinstance(floor, str):
            raise ValueError("saved pose: floor is not a string")
        if not all(math.isfinite(v) for v in (stamp, x, y, theta, ox, oy, ot)):
            raise ValueError("saved pose: a value is not finite")
        return cls(stamp, x, y, theta, floor, (ox, oy, ot))


def resume_from(saved: SavedPose | None, first_stamp: float, within_s: float) -> str:
    """Why ``saved`` is not to be resumed from at the first odometry's ``first_stamp``
    ("" if it is)."""
    if saved is None:
        return "no saved pose"
    if first_stamp < saved.stamp:
        return f"the saved pose (t = {saved.stamp:.2f} s) is from an earlier run"
    if first_stamp - saved.stamp > within_s:
        return (
            f"the saved pose is {first_stamp - saved.stamp:.1f} s old "
            f"(localisation.resume_within_s {within_s:g})"
        )
    return ""
