"""Recoveries for a chair held by an obstacle or boxed in ("blocked"), as Nav2 has them.

After the safety gate has waited ``navigator.recovery_wait_s`` (the first recovery) the
navigator runs :func:`create_recovery_tree`: back up along the way it came, then turn to
face the way on (on the spot when nothing stands within the chair's turning radius, else
by the controller's docking manoeuvre: turns and short drives forwards and back that fit
the room its LiDAR shows), each bounded by ``navigator.recovery_move_timeout_s`` and
each reported as a ``recovery`` event; a move that cannot be made is reported and
skipped. Where the turn cannot be made (the chair stands at the mouth of a corridor as
narrow as itself is long, its walls beside it), it docks instead at a pose on the route
ahead, facing along it: the docker's manoeuvre (turns and short drives) takes it into
the corridor where neither the MPC nor a turn on the spot can, bounded by that limit
plus ``navigator.manoeuvre_allowance_s``. Held again after a recovery, it docks there
whether or not the turn worked (a gap between furniture that the MPC's margins do not
fit, entered off its middle: the turn is done at once and the re-plan gives the same
path). The navigator then re-plans with the points that blocked the chair marked as
obstacles.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import py_trees
from py_trees.common import Access, Status

from behaviours.fleet import FleetBehaviour
from behaviours.motion import DockAt
from behaviours.timeouts import Timeout
from shared.config import NavigatorConfig
from shared.messages import Path, Phase


class HandToRecoveries(FleetBehaviour):
    """The fallback of a docking before a door or a lift (Phase 0) that failed: where the
    world differs from the map (a cupboard the map lacks beside the approach pose, a door
    that stands 0.2 m from where the map puts it), moving away and planning again may
    clear what a docking on the spot cannot.

    Marks the scan points in the way of the docking's pose (its footprint grown by
    ``margin_m``: the position tolerance it was checked against), names the failure in
    ``/mission/recover`` and fails, so the navigator runs its recoveries (back up, turn,
    re-plan with the points marked: the planner fits the door's poses to the space they
    leave) instead of ending the mission; bounded by the navigator's recovery counts.
    """

    def __init__(self, name: str, dock: DockAt, margin_m: float) -> None:
        super().__init__(name)
        self.dock, self.margin_m = dock, margin_m
        self.bb.register_key("recover", access=Access.WRITE)

    def update(self) -> Status:
        failure = self.bb.failure or f"{self.dock.name} failed"
        marked = self.fleet.mark_in_footprint(self.dock.goal, self.margin_m)
        self.fleet.event("fallback", f"{failure}: recover ({marked} points in the way marked)")
        self.feedback_message = f"handed to the recoveries: {failure}"
        self.bb.recover = failure
        return Status.FAILURE


class BackUp(FleetBehaviour):
    """Drive ``distance_m`` straight back from where the chair stands (reverse, slowly):
    the way it came, for the short distance a recovery needs.

    The controller's stop zone looks behind while reversing, so an obstacle there stops
    the move (it is then reported as not possible). SUCCESS on arrival; FAILURE when the
    controller holds it (obstacle, blocked)."""

    phase = Phase.RECOVER

    def __init__(self, distance_m: float, speed: float, name: str = "Back up") -> None:
        super().__init__(name)
        self.distance_m, self.speed = distance_m, speed
        self._path_id = ""

    def initialise(self) -> None:
        self.bb.phase = self.phase
        est = self.fleet.pose()
        if est is None:
            self._path_id = ""
            return
        p = est.pose
        back = np.array([-math.cos(p.theta), -math.sin(p.theta)])
        start = np.array([p.x, p.y])
        pts = start + back * np.linspace(0.0, self.distance_m, 3)[:, None]
        self._path_id = f"{self.name} @{self.fleet.now():.1f}"
        v = np.array([self.speed, self.speed, 0.0])
        self.fleet.send_path(Path(0.0, self._path_id, p.floor, pts, v, reverse=True))
        self.fleet.event(
            "recovery", f"back up: {self.distance_m:.2f} m from ({p.x:.2f}, {p.y:.2f})"
        )

    def update(self) -> Status:
        if not self._path_id:
            return self.fail("back up: no pose estimate")
        status = self.fleet.follow_status()
        if status is None or status.path_id != self._path_id:
            return Status.RUNNING
        if status.state == "arrived":
            return Status.SUCCESS
        if status.state in ("obstacle", "blocked"):
            self.fleet.event("recovery", f"back up not possible: {status.state} behind")
            return self.fail(f"back up held: {status.state}")
        return Status.RUNNING

    def terminate(self, new_status: Status) -> None:
        self.stop_if_driving(new_status)


class TurnToward(FleetBehaviour):
    """Turn to face ``target`` (x, y): on the spot if nothing is within ``radius_m``, else
    by a docking manoeuvre (the controller's docker plans one where a turn on the spot
    would sweep into a point: in the room between two doors in series the campaign's
    chairs stood wedged, "no room to turn", until every recovery had run out)."""

    phase = Phase.TURN

    def __init__(self, target: tuple[float, float], radius_m: float, nav: NavigatorConfig) -> None:
        super().__init__("Turn in place")
        self.target, self.radius_m, self.nav = target, radius_m, nav
        self._dock: DockAt | None = None

    def initialise(self) -> None:
        self.bb.phase = self.phase
        self._dock = None
        est = self.fleet.pose()
        if est is None:
            self.fleet.event("recovery", "turn in place skipped: no pose estimate")
            return
        how = "" if self.fleet.room_to_turn(self.radius_m) else " (no room on the spot: manoeuvre)"
        self.fleet.event(
            "recovery",
            f"turn in place: towards ({self.target[0]:.1f}, {self.target[1]:.1f}){how}",
        )
        self._dock = DockAt(
            "Turn in place",
            Phase.TURN,
            est.pose.floor,
            (est.pose.x, est.pose.y),
            None,
            self.nav.correction_speed,
            self.nav.position_tolerance_m,
            self.nav.turn_tolerance_deg,
            1,
            self.nav.correction_stall_s,
            face=self.target,
        )
        self._dock.fleet = self.fleet
        self._dock.initialise()

    def update(self) -> Status:
        if self._dock is None:
            return Status.SUCCESS  # skipped: nothing to do
        status = self._dock.update()
        if status == Status.FAILURE:
            self.fleet.event("recovery", f"turn in place failed: {self._dock.feedback_message}")
        return status

    def terminate(self, new_status: Status) -> None:
        self.stop_if_driving(new_status)


class OntoRoute(DockAt):
    """Dock at ``pose`` (x, y, heading) on the route ahead, reported as a recovery: where
    no turn on the spot fits, the docker's manoeuvre gets the chair onto its way."""

    def __init__(self, floor: str, pose: tuple[float, float, float], nav: NavigatorConfig) -> None:
        super().__init__(
            "Onto the route",
            Phase.RECOVER,
            floor,
            pose[:2],
            pose[2],
            nav.correction_speed,
            nav.position_tolerance_m,
            nav.turn_tolerance_deg,
            1,
            nav.correction_stall_s,
        )

    def initialise(self) -> None:
        x, y = self.target
        self.fleet.event(
            "recovery",
            f"manoeuvre onto the route: to ({x:.2f}, {y:.2f}) facing "
            f"{math.degrees(self.heading):.0f} deg",
        )
        super().initialise()

    def update(self) -> Status:
        status = super().update()
        if status == Status.FAILURE:
            self.fleet.event(
                "recovery", f"manoeuvre onto the route failed: {self.feedback_message}"
            )
        return status


def create_recovery_tree(
    face: tuple[float, float],
    turn_radius_m: float,
    back_speed: float,
    nav: NavigatorConfig,
    clock: Callable[[], float],
    onto: tuple[str, tuple[float, float, float]] | None = None,
    always_onto: bool = False,
) -> py_trees.behaviour.Behaviour:
    """Back up, then turn in place towards ``face`` or, where that fails (or always, with
    ``always_onto``: held again after a recovery), dock at the route's pose ``onto``
    (floor, (x, y, heading)); each bounded, a failure skipped."""
    limit = nav.recovery_move_timeout_s

    def bounded(child: py_trees.behaviour.Behaviour) -> py_trees.behaviour.Behaviour:
        return py_trees.decorators.FailureIsSuccess(
            f"{child.name} (or skip)", Timeout(child.name, child, limit, clock)
        )

    turn: py_trees.behaviour.Behaviour = Timeout(
        "Turn in place", TurnToward(face, turn_radius_m, nav), limit, clock
    )
    if onto is not None:
        manoeuvre = Timeout(
            "Onto the route",
            OntoRoute(onto[0], onto[1], nav),
            limit + nav.manoeuvre_allowance_s,
            clock,
        )
        if always_onto:
            turn = py_trees.composites.Sequence(
                "Turn and manoeuvre",
                memory=True,
                children=[py_trees.decorators.FailureIsSuccess("Turn (or skip)", turn), manoeuvre],
            )
        else:
            turn = py_trees.composites.Selector(
                "Turn or manoeuvre", memory=True, children=[turn, manoeuvre]
            )
    return py_trees.composites.Sequence(
        "Recover",
        memory=True,
        children=[
            bounded(BackUp(nav.backup_m, back_speed)),
            py_trees.decorators.FailureIsSuccess(f"{turn.name} (or skip)", turn),
        ],
    )
