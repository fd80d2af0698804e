"""The fleet as behaviours see it: a small interface the navigator node implements.

Behaviours receive a :class:`Fleet` through ``setup(fleet=...)`` and never touch Zenoh,
so a tree can be built, drawn and ticked against any implementation of this interface.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

import numpy as np
import py_trees
from py_trees.common import Access, Status

from shared.messages import (
    FollowStatus,
    LiftState,
    Odometry,
    Path,
    Phase,
    Pose2D,
    PoseEstimate,
    RouteReply,
)


class Fleet(Protocol):
    """What mission behaviours may ask of the rest of the fleet."""

    def now(self) -> float:
        """Fleet time in seconds (simulation time in the simulator)."""

    def request_route(
        self, goal: Pose2D | None, place: str, on_done: Callable[[RouteReply | None, str], None]
    ) -> None:
        """Ask the planner for a route from the current pose; ``on_done(reply, error)`` once."""

    def send_path(self, path: Path) -> None:
        """Hand a path to the controller."""

    def stop(self) -> None:
        """Make the controller drop its path and command zero speed."""

    def follow_status(self) -> FollowStatus | None:
        """The controller's latest progress report."""

    def pose(self) -> PoseEstimate | None:
        """The latest pose estimate."""

    def odometry(self) -> Odometry | None:
        """The latest wheel odometry (drifts, but never jumps)."""

    def door_mode(self, door_id: str) -> int | None:
        """The building's last reported DoorMode of ``door_id`` (None if never reported)."""

    def request_door(self, door_id: str, mode: int) -> None:
        """Ask the building to open or close ``door_id`` (a DoorMode value)."""

    def close_door_when_clear(
        self, door_id: str, floor: str, centre: tuple[float, float, float], width_m: float
    ) -> None:
        """Ask the building to close ``door_id`` once its leaf can no longer reach the chair
        (the door on ``floor``, middle and normal ``centre`` (x, y, theta), ``width_m``)."""

    def lidar_door_state(self, x: float, y: float, width_m: float) -> tuple[float, str]:
        """(stamp of the latest scan, "open" / "closed" / "unknown") for the door centred at
        (x, y), ``width_m`` wide (0: unknown)."""

    def lane_blocked(
        self, door_xy: tuple[float, float], direction: float, lead_m: float, width_m: float
    ) -> tuple[float, bool]:
        """(stamp of the latest scan, True if something stands in the chair's lane between
        its leading edge ``lead_m`` ahead and the door plane, moving along ``direction``,
        through a door ``width_m`` wide (0: unknown); a jamb is not in the lane)."""

    def doorways_seen(self) -> tuple[float, list[tuple[float, float, float, float]]]:
        """(stamp of the latest scan, the open doorways it shows on the map: centre x, y in
        the wall's plane, the wall's direction angle, free width)."""

    def room_to_turn(self, radius_m: float) -> bool:
        """True if the latest scan has nothing within ``radius_m`` of the pose point (the
        chair can turn on the spot without sweeping into anything)."""

    def mark_blocking(self) -> int:
        """Remember the scan points just ahead of the chair as obstacles for the route
        requests of this mission (a re-plan goes around them); how many were marked."""

    def mark_near(self, points: np.ndarray) -> int:
        """Remember the scan points within the chair's clearance half width of any of
        ``points`` (N, 2, map frame, the chair's floor), as :meth:`mark_blocking` does:
        what stands on the way ahead; how many."""

    def mark_in_footprint(self, pose: tuple[float, float, float], margin_m: float) -> int:
        """Remember the scan points inside the chair's footprint (its clearance width),
        grown by ``margin_m``, as it would stand at ``pose`` (x, y, heading; map frame), as
        :meth:`mark_blocking` does: what kept a docking from its pose; how many."""

    def hold_door_open(self, door_id: str) -> None:
        """Ask a door the chair has passed to stay open (a lease renewal) without dropping
        its :meth:`close_door_when_clear`."""

    def mark_untraversed(self, floor: str, points: np.ndarray) -> int:
        """Remember ``points`` (N, 2, map frame on ``floor``), a stretch of a leg the chair
        was held on, for the route requests of this mission: a re-plan goes another way
        where there is one; how many were marked."""

    def forget_blocking(self) -> None:
        """Drop every point :meth:`mark_blocking` and :meth:`mark_untraversed` remembered
        (a re-plan they shut off)."""

    def lift_state(self, lift_id: str) -> LiftState | None:
        """The building's last LiftState of ``lift_id``."""

    def session_id(self) -> str:
        """This chair's lift session id."""

    def request_lift(self, lift_id: str, floor: str) -> None:
        """Hold a session on ``lift_id`` and send its car to ``floor``, doors to open there."""

    def release_lift(self, lift_id: str) -> None:
        """End this chair's session on ``lift_id``."""

    def set_floor(self, floor: str) -> None:
        """Tell the localisation the chair is now on ``floor`` (same x, y, heading)."""

    def event(self, kind: str, detail: str) -> None:
        """Report something that happened (a safety stop, a fallback) to whoever listens."""


NS = "/mission"


class FleetBehaviour(py_trees.behaviour.Behaviour):
    """Base of mission behaviours: reaches the fleet through ``setup(fleet=...)``.

    Registers WRITE access to ``/mission/phase``, ``/mission/failure`` and
    ``/mission/blocked`` (the checkpoint a failure is about, for re-planning). ``phase``
    is the :class:`~shared.messages.Phase` a behaviour writes when it starts.
    """

    phase: Phase = Phase.IDLE

    def __init__(self, name: str) -> None:
        super().__init__(name)
        self.fleet: Fleet | None = None
        self.bb = self.attach_blackboard_client(name=name, namespace=NS)
        for key in ("phase", "failure", "blocked"):
            self.bb.register_key(key, access=Access.WRITE)

    def setup(self, **kwargs) -> None:
        if "fleet" not in kwargs:
            raise KeyError(f"{self.name}: setup needs fleet=<Fleet>")
        self.fleet = kwargs["fleet"]

    def fail(self, reason: str) -> Status:
        """FAILURE with ``reason`` as feedback and in ``/mission/failure``."""
        self.feedback_message = reason
        self.bb.failure = f"{self.name}: {reason}"
        return Status.FAILURE

    def stop_if_driving(self, new_status: Status) -> None:
        """Stop the chair from ``terminate`` when this behaviour fails or is interrupted
        while running, not when a behaviour that already ended is invalidated later
        (py_trees' memory composites clear finished children on a later tick, when the
        next behaviour may already have sent the controller its own path)."""
        ended = self.status in (Status.SUCCESS, Status.FAILURE) and new_status == Status.INVALID
        if new_status in (Status.INVALID, Status.FAILURE) and not ended and self.fleet is not None:
            self.fleet.stop()


class OpenInScans:
    """Counts consecutive new scans in which the LiDAR saw a doorway open.

    A scan counts once (by its stamp); "closed" and "unknown" both start the count
    again, so "open" needs ``needed`` scans in a row.
    """

    def __init__(self, needed: int) -> None:
        self.needed = needed
        self.agree = 0
        self._last = -1.0

    def reset(self) -> None:
        self.agree, self._last = 0, -1.0

    def update(self, stamp: float, seen: str) -> bool:
        """Take the latest (stamp, verdict); True once ``needed`` scans in a row said open."""
        if stamp > self._last:
            self._last = stamp
            self.agree = self.agree + 1 if seen == "open" else 0
        return self.agree >= self.needed

    def __str__(self) -> str:
        return f"LiDAR open in {min(self.agree, self.needed)} of {self.needed} scans"
