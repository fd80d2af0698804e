"""Door behaviours: ask a powered door to open, trigger an automatic one, verify it open.

Door verification trusts neither source alone: the building's DoorState must say OPEN and
the LiDAR (the seed's ROI method, services/navigator/door_check.py) must agree in several
consecutive scans. "Unknown" is never open (the seed took it for open).
"""

from __future__ import annotations

import math

import py_trees
from py_trees.common import Status

from behaviours.door_fix import DoorFix, DoorSightings
from behaviours.fleet import FleetBehaviour, OpenInScans
from behaviours.motion import dock_path
from shared.messages import DoorMode, Path, Phase


class RequestDoor(FleetBehaviour):
    """Send a DoorRequest (OPEN or CLOSED) for ``door_id``. Always SUCCESS at once."""

    def __init__(self, door_id: str, mode: int, early: bool = False) -> None:
        word = "OPEN" if mode == DoorMode.OPEN else "CLOSED"
        super().__init__(f"Request {door_id} {word}" + (" early" if early else ""))
        self.door_id, self.mode = door_id, mode

    def update(self) -> Status:
        self.fleet.request_door(self.door_id, self.mode)
        self.feedback_message = "requested"
        return Status.SUCCESS


class ReleaseDoor(FleetBehaviour):
    """Let a powered door close behind the chair. Always SUCCESS at once.

    The close is sent when the door's leaf can no longer reach the chair, not now: a pass
    ends a short way past the door plane, inside a hinged leaf's sweep, and a leaf closing
    then swings through the chair.
    """

    def __init__(
        self, door_id: str, floor: str, centre: tuple[float, float, float], width_m: float
    ) -> None:
        super().__init__(f"Release {door_id}")
        self.door_id, self.floor, self.centre, self.width_m = door_id, floor, centre, width_m

    def update(self) -> Status:
        self.fleet.close_door_when_clear(self.door_id, self.floor, self.centre, self.width_m)
        self.feedback_message = "to close when clear"
        return Status.SUCCESS


class WaitForDoorOpen(FleetBehaviour):
    """RUNNING until the door is open by both accounts, then SUCCESS.

    The building must report ``door_id`` OPEN and, when ``centre`` is given, the LiDAR
    check (of a door ``width_m`` wide, 0 if unknown) must have said "open" in ``scans``
    consecutive new scans (``building`` False: a door without a controller, the LiDAR
    alone decides; it must then have a ``centre``). CLOSED, MOVING, OFFLINE, UNKNOWN, no
    report, and a LiDAR "unknown" are all "not open". The timeout above it bounds the
    wait. ``stop_on_start`` (default) stops the chair first; idle motion running beside
    it sets it False. ``fix``: the centre is moved onto the door the scans showed.
    """

    phase = Phase.VERIFY

    def __init__(
        self,
        door_id: str,
        centre: tuple[float, float] | None = None,
        scans: int = 3,
        stop_on_start: bool = True,
        width_m: float = 0.0,
        building: bool = True,
        fix: DoorFix | None = None,
    ) -> None:
        super().__init__(f"WaitForDoorOpen {door_id}")
        self.building = building
        self.door_id = door_id
        self.centre = centre
        self.width_m = width_m
        self.stop_on_start = stop_on_start
        self.lidar = OpenInScans(scans)
        self.fix = fix

    def _centre(self) -> tuple[float, float] | None:
        if self.centre is None or self.fix is None:
            return self.centre
        return self.fix.at(*self.centre)

    def initialise(self) -> None:
        self.bb.phase = self.phase
        self.lidar.reset()
        if self.stop_on_start:
            self.fleet.stop()

    def update(self) -> Status:
        mode = self.fleet.door_mode(self.door_id) if self.building else DoorMode.OPEN
        centre = self._centre()
        lidar_ok = centre is None or self.lidar.update(
            *self.fleet.lidar_door_state(*centre, self.width_m)
        )
        if mode == DoorMode.OPEN and lidar_ok:
            self.feedback_message = "open"
            return Status.SUCCESS
        names = {0: "closed", 1: "moving", 3: "offline", 4: "unknown"}
        seen = f", {self.lidar}" if self.centre else ""
        self.feedback_message = f"door {names.get(mode, 'not reported')}{seen}, waiting"
        return Status.RUNNING


class LocateDoor(FleetBehaviour):
    """Find the door in the scans and set ``fix`` to its shift from the map, along the wall.

    Watches ``scans`` new scans (or ``timeout_s`` of fleet time, whichever ends first) for
    an open doorway within ``reach_m`` of the mapped centre, its wall parallel to the
    mapped one and at least ``min_width_m`` wide. With a sighting in more than half of
    them, ``fix`` is their median offset when that is at least ``min_shift_m`` (less, the
    pass's own tracking takes it up), else zero. Always SUCCESS: a door not seen is
    passed where the map puts it, as before. Reports what it found as an event.
    """

    phase = Phase.VERIFY

    def __init__(
        self,
        door_id: str,
        fix: DoorFix,
        centre: tuple[float, float],
        heading: float,
        reach_m: float = 0.3,
        min_width_m: float = 0.0,
        scans: int = 5,
        min_shift_m: float = 0.03,
        timeout_s: float = 2.0,
    ) -> None:
        super().__init__(f"Locate {door_id}")
        self.door_id = door_id
        self.fix = fix
        self.centre, self.heading = centre, heading
        self.reach_m, self.min_width_m = reach_m, min_width_m
        self.scans, self.min_shift_m, self.timeout_s = scans, min_shift_m, timeout_s
        self._seen = DoorSightings(centre, heading, reach_m, min_width_m)
        self._count = 0
        self._last = -1.0
        self._started = 0.0

    def initialise(self) -> None:
        self.bb.phase = self.phase
        self.fix.reset()
        self._seen = DoorSightings(self.centre, self.heading, self.reach_m, self.min_width_m)
        self._count, self._last, self._started = 0, -1.0, self.fleet.now()

    def update(self) -> Status:
        stamp, seen = self.fleet.doorways_seen()
        if stamp > self._last:
            self._last = stamp
            self._count += 1
            self._seen.add(seen)
        if self._count < self.scans and self.fleet.now() - self._started < self.timeout_s:
            self.feedback_message = f"{len(self._seen.offsets)} sightings in {self._count} scans"
            return Status.RUNNING
        shift = self._seen.shift(self._count // 2 + 1)
        if shift is None:
            self.feedback_message = (
                f"not seen ({len(self._seen.offsets)} of {self._count} scans): as mapped"
            )
        elif math.hypot(*shift) < self.min_shift_m:
            self.feedback_message = f"seen {math.hypot(*shift):.3f} m from the map: as mapped"
        else:
            self.fix.shift = shift
            self.feedback_message = (
                f"seen ({shift[0]:+.3f}, {shift[1]:+.3f}) m from the map: lining up on it"
            )
            self.fleet.event("door_located", f"{self.door_id}: {self.feedback_message}")
        return Status.SUCCESS


class DoorAsMapped(py_trees.behaviour.Behaviour):
    """SUCCESS if ``fix`` leaves the door where the map has it (nothing to line up again),
    else FAILURE."""

    def __init__(self, door_id: str, fix: DoorFix) -> None:
        super().__init__(f"{door_id} as mapped")
        self.fix = fix

    def update(self) -> Status:
        return Status.SUCCESS if self.fix.shift == (0.0, 0.0) else Status.FAILURE


class IdleMotion(FleetBehaviour):
    """Rock slowly back and forth in front of an automatic door so its sensor sees motion.

    The seed's idle motion: +-0.05 m/s, about 25 cm. Alternates docking manoeuvres between
    ``pose`` and a point ``amplitude_m`` behind it (same heading). Never finishes: it runs
    beside :class:`WaitForDoorOpen` in a parallel that ends when the door is open, and
    stops the chair when it is stopped.
    """

    phase = Phase.VERIFY

    def __init__(
        self,
        door_id: str,
        floor: str,
        pose: tuple[float, float, float],
        speed: float,
        amplitude_m: float,
    ) -> None:
        super().__init__(f"IdleMotion {door_id}")
        self.floor = floor
        self.pose = pose
        self.speed = speed
        self.amplitude_m = amplitude_m
        self._back = False
        self._moves = 0
        self._path_id = ""

    def initialise(self) -> None:
        self._back, self._moves = False, 0
        self._send()

    def _send(self) -> None:
        x, y, h = self.pose
        self._back = not self._back
        self._moves += 1
        if self._back:
            x, y = x - self.amplitude_m * math.cos(h), y - self.amplitude_m * math.sin(h)
        self._path_id = f"{self.name} #{self._moves}"
        self.fleet.send_path(dock_path(self._path_id, self.floor, x, y, h, self.speed))

    def update(self) -> Status:
        status = self.fleet.follow_status()
        if status is not None and status.path_id == self._path_id and status.state == "arrived":
            self._send()
        self.feedback_message = f"{'back' if self._back else 'forward'} (move {self._moves})"
        return Status.RUNNING

    def terminate(self, new_status: Status) -> None:
        if new_status == Status.INVALID and self.fleet is not None:
            self.fleet.stop()


class SmoothDoorPass(FleetBehaviour):
    """Pass a door without stopping (issue 14; services/controller/smooth_pass.py).

    Sends the smooth pass at once, from wherever the leg before handed over at speed, and
    checks the door while the chair closes in: open by the building (where the door has a
    controller) and by the LiDAR in ``scans`` scans in a row. FAILURE, the chair stopped,
    when the door is not seen open by the time the chair's front is ``commit_m`` before
    the door plane, when it is seen closing before the front reaches the plane, or when
    the controller gives up (facing away from the door: "fallback"; "blocked"), or when
    its safety stop holds the chair for ``hold_s`` before the plane (a curve from the side
    that swings a corner at an open leaf: waiting for the navigator's recovery took 8 s
    and a back-up): the stop-turn-go steps beside it in a selector take over. SUCCESS
    once through, still moving: its rear ``commit_m`` past the plane, the next leg takes
    over.
    """

    phase = Phase.PASS

    def __init__(
        self,
        door_id: str,
        path: Path,
        centre: tuple[float, float],
        heading: float,
        width_m: float,
        front_m: float,
        rear_m: float,
        scans: int = 3,
        building: bool = True,
        commit_m: float = 0.5,
        hold_s: float = 1.0,
    ) -> None:
        super().__init__(f"Smooth pass {door_id}")
        self.door_id = door_id
        self.path = path
        self.centre = centre
        self.normal = (math.cos(heading), math.sin(heading))
        self.width_m = width_m
        self.front_m = front_m
        self.rear_m = rear_m
        self.building = building
        self.commit_m = commit_m
        self.hold_s = hold_s
        self.lidar = OpenInScans(scans)
        self.verified = False
        self._quit = ""

    def initialise(self) -> None:
        self.bb.phase = self.phase
        self.lidar.reset()
        self.verified = False
        self._quit = ""
        self.fleet.send_path(self.path)

    def _front_to_plane(self) -> float | None:
        """How far the chair's front still is before the door plane (negative: past it)."""
        est = self.fleet.pose()
        if est is None:
            return None
        p = est.pose
        nose = (p.x + self.front_m * math.cos(p.theta), p.y + self.front_m * math.sin(p.theta))
        return -(
            (nose[0] - self.centre[0]) * self.normal[0]
            + (nose[1] - self.centre[1]) * self.normal[1]
        )

    def quits_when_held(self, cause: str, held_s: float) -> bool:
        """Asked by the safety gate while it holds the chair: True (and FAILURE at the next
        update) once the safety stop has held it ``hold_s`` before the door plane."""
        ahead = self._front_to_plane()
        if cause == "obstacle" and held_s >= self.hold_s and ahead is not None and ahead > 0:
            self._quit = f"held by the safety stop for {held_s:.1f} s"
            return True
        return False

    def _out(self, to_go: float) -> bool:
        """True once the chair's rear is ``commit_m`` past the door plane (``to_go`` of the
        pass left): the next leg takes over at speed, as the leg before handed over."""
        through = self.path.door[5] if len(self.path.door) >= 6 else 0.0
        return to_go <= through - self.rear_m - self.commit_m

    def _give_up(self, why: str) -> Status:
        self.fleet.stop()
        self.feedback_message = f"{why}: stop-turn-go instead"
        return Status.FAILURE

    def update(self) -> Status:
        status = self.fleet.follow_status()
        mine = status is not None and status.path_id == self.path.path_id
        if mine and (status.state == "arrived" or self._out(status.distance_to_goal)):
            self.feedback_message = "through"
            return Status.SUCCESS
        if mine and status.state in ("fallback", "blocked"):
            return self._give_up(f"controller: {status.state}")
        if self._quit:
            return self._give_up(self._quit)
        mode = self.fleet.door_mode(self.door_id) if self.building else DoorMode.OPEN
        ahead = self._front_to_plane()
        if not self.verified:
            seen = self.lidar.update(*self.fleet.lidar_door_state(*self.centre, self.width_m))
            self.verified = mode == DoorMode.OPEN and seen
            if not self.verified and ahead is not None and ahead <= self.commit_m:
                return self._give_up(f"door {self.door_id} not seen open in time ({self.lidar})")
        elif mode != DoorMode.OPEN and ahead is not None and ahead > 0:
            return self._give_up(f"door {self.door_id} no longer open")
        self.feedback_message = (
            f"{'open' if self.verified else 'checking'}, front "
            f"{ahead if ahead is not None else float('nan'):.2f} m before the plane"
        )
        return Status.RUNNING

    def terminate(self, new_status: Status) -> None:
        self.stop_if_driving(new_status)
