"""Elevator behaviours, driven by the building's lift protocol (Open-RMF LiftRequest/State).

The seed typed the floor number on a console; here every step is a request or a state
the building reports, and every wait sits under a timeout in the tree that uses them.
"""

from __future__ import annotations

from py_trees.common import Status

from behaviours.fleet import FleetBehaviour, OpenInScans
from shared.messages import LiftDoor, LiftMode, LiftMotion, Phase


class _LiftBehaviour(FleetBehaviour):
    """A fleet behaviour about one lift."""

    def __init__(self, name: str, lift_id: str) -> None:
        super().__init__(name)
        self.lift_id = lift_id


class RequestLift(_LiftBehaviour):
    """Hold a session on the lift and send its car to ``floor`` (doors to open there).

    Always SUCCESS at once; WaitForLift reports whether the building obeyed.
    """

    phase = Phase.ELEVATOR

    def __init__(self, lift_id: str, floor: str) -> None:
        super().__init__(f"Call {lift_id} to {floor}", lift_id)
        self.floor = floor

    def update(self) -> Status:
        self.bb.phase = self.phase
        self.fleet.request_lift(self.lift_id, self.floor)
        self.feedback_message = f"requested floor {self.floor}"
        return Status.SUCCESS


class WaitForLift(_LiftBehaviour):
    """RUNNING until the car stands at ``floor`` with its doors open for our session.

    With ``door_xy`` (the car door's middle; ``door_width_m`` wide, 0 if unknown) the
    LiDAR must also see the doorway open in ``scans`` consecutive new scans: ahead when
    the car arrives, behind the chair when it stops at the destination (the VLP-16 sees
    all round). FAILURE at once when the building reports the lift out of service
    (OFFLINE), naming it in ``/mission/blocked`` so the navigator can try another lift.
    A lift held by another session keeps it RUNNING (busy) until the timeout above it
    fires.
    """

    def __init__(
        self,
        lift_id: str,
        floor: str,
        door_xy: tuple[float, float] | None = None,
        scans: int = 3,
        phase: Phase = Phase.CALL,
        door_width_m: float = 0.0,
    ) -> None:
        super().__init__(f"WaitForLift {lift_id} at {floor}", lift_id)
        self.floor = floor
        self.phase = phase
        self.door_xy = door_xy
        self.door_width_m = door_width_m
        self.lidar = OpenInScans(scans)

    def initialise(self) -> None:
        self.bb.phase = self.phase
        self.lidar.reset()

    def _lidar_open(self) -> bool:
        """The car door seen open (ahead or behind the chair) in ``scans`` new scans."""
        if self.door_xy is None:
            return True
        return self.lidar.update(*self.fleet.lidar_door_state(*self.door_xy, self.door_width_m))

    def update(self) -> Status:
        state = self.fleet.lift_state(self.lift_id)
        if state is None:
            self.feedback_message = "no state from the lift yet"
            return Status.RUNNING
        if state.current_mode == LiftMode.OFFLINE:
            self.bb.blocked = self.lift_id
            self.bb.failure = f"{self.name}: lift {self.lift_id} is out of service"
            self.feedback_message = "out of service"
            return Status.FAILURE
        ours = state.session_id == self.fleet.session_id()
        if not ours:
            self.feedback_message = f"busy (session {state.session_id or 'none'})"
            return Status.RUNNING
        ready = (
            state.current_floor == self.floor
            and state.door_state == LiftDoor.OPEN
            and state.motion_state == LiftMotion.STOPPED
        )
        seen = self._lidar_open() if ready else False
        if ready and seen:
            self.feedback_message = "doors open (lift state and LiDAR)"
            return Status.SUCCESS
        lidar = f", {self.lidar}" if self.door_xy else ""
        self.feedback_message = f"car at {state.current_floor}, doors {state.door_state}{lidar}"
        return Status.RUNNING


class SetFloor(_LiftBehaviour):
    """Tell the localisation the chair is now on ``floor`` (after the ride). SUCCESS at once."""

    def __init__(self, lift_id: str, floor: str) -> None:
        super().__init__(f"SetFloor {floor}", lift_id)
        self.floor = floor

    def update(self) -> Status:
        self.fleet.set_floor(self.floor)
        return Status.SUCCESS


class ReleaseLift(_LiftBehaviour):
    """End our session on the lift. SUCCESS at once; also sent if the ride is pre-empted."""

    def __init__(self, lift_id: str) -> None:
        super().__init__(f"Release {lift_id}", lift_id)

    def update(self) -> Status:
        self.fleet.release_lift(self.lift_id)
        return Status.SUCCESS
