"""Why the navigator holds its mission: the emergency stop, and the rider's pause.

The emergency stop (shared/estop.py) holds the mission while it is active; cleared, the
mission goes on. The rider taking the joystick (``DriverStatus.joystick_active`` from
the chair driver) pauses a running mission, and the pause lasts until someone asks to
resume (``wheelnav resume``: a NavResume): it never ends by itself when the rider lets
go, and a resume is refused while the rider still holds the joystick (the mission would
take the chair back the moment they let go). A new goal or a cancel ends it. The two are
apart on purpose: the stop is the operator's, for every layer; the pause is the mission's,
and only the rider's hand on the joystick can start it. Pure: no I/O.
"""

from __future__ import annotations

import math

from shared.messages import Pose2D

RIDER = "the rider took the joystick"
MOVED_M = 0.5  # moved farther while held (the rider drove it): the route is planned again


class Holds:
    """The emergency stop in words (``estop``, "" when none), the pause, the rider."""

    def __init__(self) -> None:
        self.estop = ""
        self.paused = ""
        self.rider = False  # the driver's last word: the rider holds the joystick

    def pause_for_rider(self) -> bool:
        """Pause the mission if the rider holds the joystick; True if that starts a pause."""
        if self.rider and not self.paused:
            self.paused = RIDER
            return True
        return False

    def resume(self) -> str:
        """End the pause: "" if it ended, else why not."""
        if not self.paused:
            return "the mission is not paused"
        if self.rider:
            return "the rider still holds the joystick"
        self.paused = ""
        return ""

    def reason(self) -> str:
        """Why the mission is held, as the status says it ("" when it is not)."""
        parts = []
        if self.estop:
            parts.append(f"held: {self.estop}")
        if self.paused:
            parts.append(f"paused: {self.paused}")
        return "; ".join(parts)


def moved_m(before: Pose2D | None, after: Pose2D | None) -> float:
    """How far the chair moved between two poses (0 without either; any floor change
    counts as far)."""
    if before is None or after is None:
        return 0.0
    if before.floor != after.floor:
        return math.inf
    return math.hypot(after.x - before.x, after.y - before.y)
