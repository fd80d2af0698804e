"""The navigator's core: one mission at a time, as a plan tree and then a route tree.

A goal grows a plan tree (ask the planner for a route); when it succeeds, a route tree
built from that route (``behaviours.mission``). A door or lift that fails and is named in
``/mission/blocked`` is marked unavailable, avoided, and the route planned again, at most
``navigator.max_replans`` times. The status (state, the running step, its phase,
progress, the reason) goes out on every change and at ``navigator.status_rate_hz``; a
snapshot of the tree on every change of its statuses.

Every tree stands under a :class:`~behaviours.safety.PauseGate`, which holds the mission
while the emergency stop is active or the rider has paused it (:mod:`holds`): the chair
is stopped, no limit runs, and the mission goes on where it was once the hold ends (the
stop cleared; the pause resumed by request, :meth:`Navigator.on_resume`). Held somewhere
else than where it stopped (the rider drove it more than ``holds.MOVED_M``), outside a
lift car, it plans the route again from there instead.

No Zenoh here: the rest of the fleet is a :class:`MissionFleet` (the behaviours'
:class:`~behaviours.fleet.Fleet` plus the mission's avoid set and lift session) and what
the navigator publishes goes to a :class:`NavigatorOutput`; ``node.py`` implements both
over the bus, the tests with fakes.
"""

from __future__ import annotations

import base64
import logging
import math
from typing import Protocol

import numpy as np
import py_trees
from py_trees.common import Access, Status

from behaviours.fleet import NS, Fleet
from behaviours.mission import EntryParams, create_plan_tree, create_route_tree, route_steps
from behaviours.motion import FollowPath
from behaviours.recovery import create_recovery_tree
from behaviours.safety import RECOVERABLE, PauseGate
from behaviours.snapshot import signature, snapshot
from services.navigator.holds import MOVED_M, Holds, moved_m
from services.navigator.leases import Leases
from services.navigator.resume import IN_A_CAR, MissionRecord
from shared.codec import encode
from shared.config import FleetConfig, NavigatorConfig
from shared.messages import (
    TERMINAL_STATES,
    Availability,
    DriverStatus,
    Event,
    NavGoal,
    NavResume,
    NavStatus,
    Phase,
    Pose2D,
    RouteReply,
    TreeSnapshot,
)

NAME = "navigator"
FASTEST_MPS = 1.0  # faster than the chair drives: a pose that moves faster has jumped
WAY_ON_M = 1.5  # how far along the route a recovery faces, or manoeuvres onto it
# held while following a leg, a recovery marks the leg's stretch from UNTRAVERSED_FROM_M
# ahead of the chair's pose point to UNTRAVERSED_REACH_M beyond its front (the reach of
# the scan points it marks), a point every UNTRAVERSED_STEP_M: the gap it could not enter
UNTRAVERSED_FROM_M = 0.5
UNTRAVERSED_REACH_M = 1.0
UNTRAVERSED_STEP_M = 0.1
# and the scan points on the leg ahead, within the chair's clearance half width of it, up
# to AHEAD_MARK_M beyond its front: what the map lacks on the way, whichever way the chair
# faces (world-differs campaign b7002w.m03: a cupboard 0.9 m behind a chair that had to
# turn round to the path; the band ahead of it marked nothing, and every re-plan went
# through the cupboard for 160 s)
AHEAD_MARK_M = 3.0


def _way_on_index(pts: np.ndarray, i: int) -> int:
    """The index of the first point of ``pts`` (N, 2) at least ``WAY_ON_M`` along them
    from point ``i`` (the last point if they end sooner)."""
    seg = np.linalg.norm(np.diff(pts[i:], axis=0), axis=1)
    return min(i + int(np.searchsorted(np.cumsum(seg), WAY_ON_M)) + 1, len(pts) - 1)


def stretch_ahead(
    pts: np.ndarray, xy: tuple[float, float], from_m: float, to_m: float, step_m: float
) -> np.ndarray:
    """Points ``step_m`` apart along the polyline ``pts`` (N, 2), from ``from_m`` to
    ``to_m`` beyond its point nearest ``xy`` (cut at its end; (0, 2) if nothing is left)."""
    a, b = pts[:-1], pts[1:]
    seg = b - a
    length = np.hypot(seg[:, 0], seg[:, 1])
    u = np.clip(((np.asarray(xy) - a) * seg).sum(axis=1) / np.maximum(length**2, 1e-12), 0, 1)
    near = a + seg * u[:, None]
    k = int(np.argmin(np.hypot(near[:, 0] - xy[0], near[:, 1] - xy[1])))
    along = np.concatenate([[0.0], np.cumsum(length)])
    s0 = along[k] + u[k] * length[k]
    s = np.arange(s0 + from_m, min(s0 + to_m, along[-1]) + 1e-9, step_m)
    return np.column_stack([np.interp(s, along, pts[:, 0]), np.interp(s, along, pts[:, 1])])


class NavigatorOutput(Protocol):
    """Where the navigator's own messages go."""

    def publish_status(self, status: NavStatus) -> None:
        """The mission status (on every change and at the status rate)."""

    def publish_tree(self, snapshot: TreeSnapshot) -> None:
        """The behaviour tree after a tick (on every change, feedback alone at 2 Hz)."""

    def publish_route(self, route: RouteReply) -> None:
        """The route about to be driven (after each plan and re-plan)."""

    def mark_unavailable(self, update: Availability) -> None:
        """Tell the planner a door or lift is unavailable (it failed this mission)."""


class MissionFleet(Fleet, Protocol):
    """The behaviours' fleet, plus what only the navigator does to it."""

    def new_mission(self, goal_id: str) -> None:
        """Forget the checkpoints avoided so far; lift requests hold this mission's session."""

    def avoid(self, checkpoint_id: str) -> None:
        """Route requests from now on go around ``checkpoint_id``."""


class Navigator:
    """One mission at a time: a fresh tree per goal, status on change.

    Not thread-safe: the node calls ``on_goal`` and ``step`` from its bus's one dispatcher
    thread (under the bus lock), never at the same time.
    """

    def __init__(
        self,
        cfg: NavigatorConfig,
        entry: EntryParams,
        fleet: MissionFleet,
        out: NavigatorOutput,
        log: logging.Logger | None = None,
    ) -> None:
        self.cfg = cfg
        self.entry = entry
        self.fleet = fleet
        self.leases = Leases(fleet, cfg.lease_renew_s)  # the trees' fleet
        self.out = out
        self.log = log or logging.getLogger(f"wheelnav.{NAME}")
        self.tree: py_trees.trees.BehaviourTree | None = None
        self.status = NavStatus(0.0, "", "idle")
        self.driving = False  # False: the plan tree runs; True: the route tree
        self.replans = 0
        self.recoveries = 0  # in the place where they began (recovery_reset_m)
        self.recoveries_in_all = 0
        self.recovery_place: tuple[float, float, str] | None = None
        self.recovering = False  # the recovery tree runs (between a hold and a re-plan)
        self.around_marks = False  # the plan tree runs a re-plan around marked points
        self.fallbacks: list[str] = []
        self.avoided: list[str] = []  # checkpoints given up on in this mission
        self._route_saved = ""  # the route being driven, as a restarted navigator reads it
        self._steps_of: list[py_trees.behaviour.Behaviour] = []
        self._last_sent: tuple | None = None
        self._last_sent_at = -1e9
        self._tree_sig: tuple | None = None
        self._tree_sent_at = -1e9
        self.holds = Holds()
        self._gate: PauseGate | None = None  # the running tree's root
        self._held = False  # the mission was held at the last step
        self._held_at: Pose2D | None = None  # where the chair stood when the hold began
        # the pose estimate at the last step, its time, whether it was lost
        self._last_pose: tuple[Pose2D | None, float, bool] = (None, 0.0, False)
        self.bb = py_trees.blackboard.Client(name=NAME, namespace=NS)
        for key in ("goal", "place", "failure", "phase", "route", "blocked", "action", "recover"):
            self.bb.register_key(key, access=Access.WRITE)

    @classmethod
    def from_config(
        cls,
        cfg: FleetConfig,
        fleet: MissionFleet,
        out: NavigatorOutput,
        log: logging.Logger | None = None,
    ) -> Navigator:
        """A navigator with the fleet config's navigator section, door speed and footprint."""
        return cls(cfg.navigator, EntryParams.from_config(cfg), fleet, out, log)

    def avoid(self, checkpoint_id: str) -> None:
        """Plan around ``checkpoint_id`` (a door or lift that failed) for this mission."""
        self.fleet.avoid(checkpoint_id)
        if checkpoint_id not in self.avoided:
            self.avoided.append(checkpoint_id)

    def record(self) -> MissionRecord | None:
        """The mission as a restarted navigator would take it up (None: none yet)."""
        s = self.status
        if not s.goal_id:
            return None
        g = self.bb.goal
        goal = None if g is None else (g.x, g.y, g.theta, g.floor)
        step = self._running_step()[0] if self.driving else -1
        return MissionRecord(
            self.fleet.now(),
            s.goal_id,
            goal,
            self.bb.place or "",
            s.state,
            str(s.phase),
            list(self.avoided),
            self._route_saved if self.driving else "",
            step,
            self.holds.paused,
        )

    def ride_on(self, msg: NavGoal, route: RouteReply, step: int) -> None:
        """Take up a mission whose chair is in the car of the lift at route step ``step``
        (a restarted navigator): send the car to the floor again, wait for it, go on."""
        self.on_goal(msg)
        self.bb.route = route
        self._drive(route, riding_at=step)

    @property
    def running(self) -> bool:
        return self.tree is not None and self.status.state == "running"

    def on_goal(self, msg: NavGoal) -> None:
        """Start a mission (ending the running one), or cancel the running one."""
        if msg.cancel:
            if self.running:
                self._set("cancelled", reason="cancelled by request")  # progress so far
                self.tree.root.stop(Status.INVALID)  # every running behaviour terminates
                self.fleet.stop()
            return
        if msg.goal is None and not msg.place:
            self.log.warning("goal %s ignored: give a goal pose or a place", msg.goal_id)
            return
        # a running mission's tree is dropped as it stands: the controller keeps its path
        # until the new route's first path replaces it (a plan that fails stops the chair)
        self.bb.goal, self.bb.place, self.bb.failure = msg.goal, msg.place, ""
        self.bb.phase, self.bb.blocked, self.bb.recover = Phase.IDLE, "", ""
        self._release_held()  # a mission replaced: its session ends before the next
        self.fleet.new_mission(msg.goal_id)
        self.avoided = []
        self.replans = 0
        self.recoveries = self.recoveries_in_all = 0
        self.recovery_place = None
        self.fallbacks = []
        self.around_marks = False
        self.holds.paused = ""  # a new goal is asked for: the rider's pause (if any) ends
        self._held, self._held_at = False, None
        self._plan()
        target = msg.place or f"({msg.goal.x:.2f}, {msg.goal.y:.2f})"
        self.log.info("mission %s to %s", msg.goal_id, target)
        self.status = NavStatus(self.fleet.now(), msg.goal_id, "running")

    def set_estop(self, reason: str) -> None:
        """The emergency stop in words ("" when there is none): held while there is."""
        self.holds.estop = reason

    def on_driver_status(self, msg: DriverStatus) -> None:
        """The driver's report: the rider taking the joystick pauses a running mission."""
        self.holds.rider = msg.joystick_active
        self._pause_for_rider()

    def on_localisation_event(self, msg: Event) -> None:
        """The localisation gave its pose up (``relocalise_failed``: no search found one that
        fits unambiguously): nothing more will come of waiting, so a running mission stops
        the chair and fails now, saying why, instead of at the end of the safety limit."""
        # in a lift car the map is not the car's: the floor change sets the pose anew
        if msg.kind != "relocalise_failed" or not self.running or self.bb.phase in IN_A_CAR:
            return
        self.tree.root.stop(Status.INVALID)
        self.fleet.stop()
        self._set("failed", reason=f"localisation lost: {msg.detail}")

    def on_resume(self, msg: NavResume) -> None:
        """Resume the mission the rider paused (refused, saying why, if it cannot be)."""
        who = msg.source or "?"
        if not self.running:
            why = "no mission is running"
        elif msg.goal_id and msg.goal_id != self.status.goal_id:
            why = f"mission {msg.goal_id} is not the running one ({self.status.goal_id})"
        else:
            why = self.holds.resume()
        if why:
            self.log.warning("resume asked by %s refused: %s", who, why)
            self.fleet.event("resume_refused", f"asked by {who}: {why}")
            return
        still = f"; still {self.holds.reason()}" if self.holds.reason() else ""
        self.log.warning("mission %s resumed by %s%s", self.status.goal_id, who, still)
        self.fleet.event("resume", f"mission {self.status.goal_id} resumed by {who}{still}")

    def _pause_for_rider(self) -> None:
        if self.running and self.holds.pause_for_rider():
            self.log.warning("mission %s paused: %s", self.status.goal_id, self.holds.paused)

    def step(self, now: float) -> None:
        """Tick the running tree once (``now``: the fleet clock), then publish the status."""
        self.leases.renew(now)  # doors passed are held open until clear, mission or not
        if self.running:
            self._pause_for_rider()
            self._watch_hold()
            self._watch_jump()
            self.tree.tick()
            self._stream_tree(now)
            result = self.tree.root.status
            if self.recovering and result in (Status.SUCCESS, Status.FAILURE):
                self._after_recovery()
            elif result == Status.FAILURE and self.bb.recover:
                self._recover()
            elif result == Status.SUCCESS and not self.driving:
                self._drive(self.bb.route)
            elif result == Status.SUCCESS:
                self._set("succeeded", reason="arrived")
            elif result == Status.FAILURE and (self._unmark() or self._replan()):
                pass
            elif result == Status.FAILURE:
                self._set("failed", reason=self._failure_reason())
            else:
                tip = self._gate if self._gate.holding else self.tree.tip()
                self._set(
                    "running",
                    phase=self.bb.phase,
                    action=self._action(),
                    reason=tip.feedback_message if tip else "",
                )
        self._publish(now)

    def _watch_hold(self) -> None:
        """Where a hold begins, remember the pose; where it ends with the chair moved
        more than ``MOVED_M`` (outside a lift car), plan the route again from there."""
        held = bool(self.holds.reason())
        est = self.fleet.pose()
        here = est.pose if est is not None else None
        if held and not self._held:
            self._held, self._held_at = True, here
            return
        if held or not self._held:
            return
        self._held = False
        moved = moved_m(self._held_at, here)
        if moved > MOVED_M:
            self._plan_again("hold_over", f"moved {moved:.1f} m while held")

    def _watch_jump(self) -> None:
        """A pose found again after it was lost, more than ``MOVED_M`` from where it was
        (beyond what the chair can drive in the time, ``FASTEST_MPS``) on one floor: the
        localisation found the chair elsewhere (relocalised after a kidnapping), and the
        route no longer starts where it stands; plan again from there (outside a lift
        car)."""
        est = self.fleet.pose()
        now = self.fleet.now()
        here = None if est is None else est.pose
        lost = est is not None and est.lost
        (before, then, was_lost), self._last_pose = self._last_pose, (here, now, lost)
        if not was_lost or lost or before is None or here is None:
            return
        moved = moved_m(before, here)
        if math.isfinite(moved) and moved - FASTEST_MPS * max(0.0, now - then) > MOVED_M:
            self._plan_again("pose_jump", f"the pose was found {moved:.1f} m from where it was")

    def _plan_again(self, kind: str, why: str) -> None:
        """Stop what runs and plan the route again from where the chair stands (not in a
        lift car, and only while a route or a recovery runs)."""
        if self.bb.phase in IN_A_CAR or not (self.driving or self.recovering):
            return
        self.tree.root.stop(Status.INVALID)
        self.recovering = False
        self.fleet.event(kind, f"{why}: planning again from here")
        self._plan()
        self._set("running", phase=Phase.PLAN, action="re-plan")

    # ---- the two trees ------------------------------------------------------------------

    def _grow(self, root: py_trees.behaviour.Behaviour) -> None:
        """Run ``root`` (a plan, route or recovery tree) as the mission's tree, under the
        pause gate."""
        self._gate = PauseGate("Pause", root, self.holds.reason, self.fleet.now)
        self.tree = py_trees.trees.BehaviourTree(self._gate)
        # setup only stores the fleet handle (never blocks); a finite timeout would need
        # signals, which only work on the main thread, and goals arrive on Zenoh threads
        self.tree.setup(timeout=py_trees.common.Duration.INFINITE, fleet=self.leases)
        self._steps_of = route_steps(root)

    def _plan(self) -> None:
        self.driving = False
        self._grow(create_plan_tree(self.fleet.now, self.cfg.plan_timeout_s))

    def _drive(self, route: RouteReply, riding_at: int = -1) -> None:
        """The plan tree got ``route``: drive it, starting its first step now (its phase is
        the status's); ``riding_at``: from that lift step, the chair in its car."""
        self.driving, self.around_marks = True, False
        self._route_saved = base64.b64encode(encode(route)).decode("ascii")
        self.out.publish_route(route)
        self._grow(create_route_tree(route, self.fleet.now, self.entry, riding_at))
        self.tree.tick()
        self._set("running", phase=self.bb.phase, action=self._action())

    def _stream_tree(self, now: float) -> None:
        """Publish a snapshot when the tree's statuses change (feedback alone: at 2 Hz)."""
        snap = snapshot(self.tree.root, now, self.status.goal_id)
        sig = signature(snap)
        if sig != self._tree_sig or now - self._tree_sent_at >= 0.5:
            self.out.publish_tree(snap)
            self._tree_sig, self._tree_sent_at = sig, now

    def _replan(self) -> bool:
        """After a door or lift failed: avoid it and plan again (bounded). False if not."""
        blocked = self.bb.blocked
        if not self.driving or not blocked or self.replans >= self.cfg.max_replans:
            return False
        self.replans += 1
        self.avoid(blocked)
        self.leases.release(blocked)  # not held open (or the car kept) for the rest
        self.log.warning(
            "%s failed (%s): planning around it (re-plan %d of %d)",
            blocked,
            self.bb.failure,
            self.replans,
            self.cfg.max_replans,
        )
        self.fleet.event("fallback", f"avoiding {blocked}: {self.bb.failure}")
        self.out.mark_unavailable(Availability(self.fleet.now(), blocked, False, self.bb.failure))
        self.fallbacks.append(self.bb.failure)
        self.bb.blocked = ""
        self.bb.failure = ""
        self._plan()
        self._set("running", phase=Phase.PLAN, action="re-plan")
        return True

    def _recover(self) -> None:
        """A hold the safety gate handed over: back up and turn (the recovery tree), then
        re-plan around what blocked the chair; a safe stop once the recoveries run out."""
        cause, self.bb.recover = self.bb.recover, ""
        est = self.fleet.pose()
        where = f" at ({est.pose.x:.2f}, {est.pose.y:.2f})" if est is not None else ""
        self._new_place(est)
        here = self.recoveries >= self.cfg.max_recoveries
        in_all = self.recoveries_in_all >= self.cfg.max_recoveries * self.cfg.recovery_places
        if here or in_all:
            self.fleet.stop()
            self.fleet.event("recovery", f"given up: {cause}{where}")
            tried = (
                f"{self.recoveries} recoveries"
                if here
                else f"{self.recoveries_in_all} recoveries in this mission"
            )
            failure = (
                f"blocked ({cause}){where}: {tried} (back up, turn in place, re-plan) did not "
                f"clear it"
            )
            self._set("failed", reason="; then ".join([*self.fallbacks, failure]))
            return
        self.recoveries += 1
        self.recoveries_in_all += 1
        # a hold marks what stands in the band ahead and behind; a step's hand-over (a
        # docking that failed) has marked what stood in its way itself, and the band ahead
        # of a chair docking before a door holds the door's jambs and open leaf, which
        # would shut the door's approach (world-differs campaign b7002w.m05)
        held = cause in RECOVERABLE
        marked = self.fleet.mark_blocking() if held else 0
        # the phase the hold came in (the failed tree's stop step has set its own since)
        stretch = 0
        if held and self.status.phase == Phase.FOLLOW:
            stretch, seen = self._mark_the_leg_ahead(est)
            marked += seen
        what = (
            f"held ({cause}){where} for {self.cfg.recovery_wait_s:g} s" if held else cause + where
        )
        self.log.warning("%s: recovery %d of %d", what, self.recoveries, self.cfg.max_recoveries)
        self.fleet.event(
            "recovery",
            f"{what}: recovery {self.recoveries} of {self.cfg.max_recoveries}, "
            f"{marked} blocking points marked"
            + (f", {stretch} of the leg ahead marked untraversed" if stretch else ""),
        )
        self.recovering, self.driving = True, False
        self._grow(
            create_recovery_tree(
                self._way_on(),
                self.entry.turn_radius_m,
                self.entry.nav.correction_speed,
                self.cfg,
                self.fleet.now,
                self._onto(),
                always_onto=self.recoveries >= 2,  # held again: the plain ones did not do
            )
        )
        self._set("running", phase=Phase.RECOVER, action="recover")

    def _new_place(self, est) -> None:
        """Start the recovery count again if the chair is held ``recovery_reset_m`` or more
        from where the recoveries so far began (campaign b1011.m03: three spent threading a
        gap between two cupboards, then none left for a hold 2 m further on); the first
        hold's place is where a count begins."""
        if est is None:
            return
        here = (est.pose.x, est.pose.y, est.pose.floor)
        place = self.recovery_place
        if place is not None and place[2] == here[2]:
            away = math.hypot(here[0] - place[0], here[1] - place[1])
            if away < self.cfg.recovery_reset_m:
                return
            if self.recoveries:
                self.fleet.event(
                    "recovery", f"held {away:.1f} m on from the last recoveries: count anew"
                )
        self.recovery_place, self.recoveries = here, 0

    def _mark_the_leg_ahead(self, est) -> tuple[int, int]:
        """Mark the stretch of the leg being followed just ahead of the held chair as
        untraversed (campaign b3003.m08: a gap it could not enter from the diagonal, on the
        map and so taken by every re-plan), and the scan points on the leg up to
        ``AHEAD_MARK_M`` beyond its front as blocking; how many of each were marked."""
        nearest = self._nearest_leg(est)
        if nearest is None:
            return 0, 0
        pts, floor = nearest
        here = (est.pose.x, est.pose.y)
        front = self.entry.front_m
        stretch = stretch_ahead(
            pts, here, UNTRAVERSED_FROM_M, front + UNTRAVERSED_REACH_M, UNTRAVERSED_STEP_M
        )
        way = stretch_ahead(pts, here, 0.0, front + AHEAD_MARK_M, UNTRAVERSED_STEP_M)
        untraversed = (
            self.fleet.mark_untraversed(est.pose.floor or floor, stretch) if len(stretch) else 0
        )
        return untraversed, self.fleet.mark_near(way) if len(way) else 0

    def _nearest_leg(self, est) -> tuple[np.ndarray, str] | None:
        """The waypoints (N >= 2) and floor of the route's leg nearest the chair on its
        floor; None without a route or a pose."""
        route = self.bb.route
        if est is None or route is None:
            return None
        p = est.pose
        best: tuple[float, np.ndarray, str] | None = None
        for leg in route.legs:
            pts = np.asarray(leg.waypoints, float)
            if (p.floor and leg.floor not in ("", p.floor)) or len(pts) < 2:
                continue
            d = float(np.min(np.hypot(pts[:, 0] - p.x, pts[:, 1] - p.y)))
            if best is None or d < best[0]:
                best = (d, pts, leg.floor)
        return None if best is None else (best[1], best[2])

    def _after_recovery(self) -> None:
        self.recovering = False
        self.fleet.event("recovery", "re-plan: around the marked points, from here")
        self._plan()
        self.around_marks = True
        self._set("running", phase=Phase.PLAN, action="re-plan")

    def _unmark(self) -> bool:
        """A re-plan around marked points found no path: the marks (scan points ahead of
        a hold, a doorway's jambs among them) are a hint, not a wall; forget them and plan
        once more. False if the failed plan was not such a re-plan."""
        if self.driving or not self.around_marks or "NO_PATH" not in self.bb.failure:
            return False
        self.around_marks = False
        self.fleet.forget_blocking()
        self.fleet.event("recovery", "re-plan without the marked points: they shut every way")
        self.bb.failure = ""
        self._plan()
        self._set("running", phase=Phase.PLAN, action="re-plan")
        return True

    def _way_on(self) -> tuple[float, float]:
        """The point to face after backing up: ``WAY_ON_M`` on along the route being driven from
        its point nearest the chair (the route's end if nearer; the chair's front without a
        route or pose)."""
        est = self.fleet.pose()
        route = self.bb.route
        if est is None:
            return (0.0, 0.0)
        p = est.pose
        ahead = (p.x + WAY_ON_M * math.cos(p.theta), p.y + WAY_ON_M * math.sin(p.theta))
        if route is None or not route.legs:
            return ahead
        legs = [leg for leg in route.legs if leg.floor in ("", p.floor)] or route.legs
        pts = np.concatenate([np.asarray(leg.waypoints, float) for leg in legs])
        if len(pts) == 0:
            return ahead
        i = int(np.argmin(np.hypot(pts[:, 0] - p.x, pts[:, 1] - p.y)))
        x, y = pts[_way_on_index(pts, i)]
        return float(x), float(y)

    def _onto(self) -> tuple[str, tuple[float, float, float]] | None:
        """A pose on the leg being driven, ``WAY_ON_M`` on from its point nearest the chair
        (its end if nearer), facing along the leg there (at a door's or a lift's approach
        pose, its heading): where the recovery's manoeuvre docks when no turn on the spot
        fits. None without a route or a pose."""
        est = self.fleet.pose()
        nearest = self._nearest_leg(est)
        if nearest is None:
            return None
        p = est.pose
        pts, floor = nearest
        i = int(np.argmin(np.hypot(pts[:, 0] - p.x, pts[:, 1] - p.y)))
        j = max(_way_on_index(pts, i), 1)
        (ax, ay), (bx, by) = pts[j - 1], pts[j]
        heading = math.atan2(by - ay, bx - ax)
        # the leg's end at a door or a lift: its approach heading
        for cp in self.bb.route.checkpoints:
            if math.hypot(cp.approach.x - bx, cp.approach.y - by) < 0.01:
                heading = cp.approach.theta
        return p.floor or floor, (float(bx), float(by), heading)

    def _failure_reason(self) -> str:
        """Why the mission failed, with the fallbacks tried first. A re-plan that found no
        route after a door or lift was given up reads "<what did not happen>; no other
        route (<the planner's words>)"."""
        failure = self.bb.failure or "mission failed"
        if not self.driving and self.fallbacks and "NO_PATH" in failure:
            detail = failure.split("NO_PATH: ", 1)[-1]
            return "; then ".join(self.fallbacks) + f"; no other route ({detail})"
        return "; then ".join([*self.fallbacks, failure])

    # ---- the status ---------------------------------------------------------------------

    def _set(self, state: str, **fields) -> None:
        s = self.status
        self.bb.action = fields.get("action", "")
        self.status = NavStatus(
            self.fleet.now(),
            s.goal_id,
            state,
            fields.get("action", s.action if state == "running" else ""),
            str(fields.get("phase", s.phase)),  # the wire carries the Phase's plain string
            fields.get("reason", ""),
            self._progress(),
        )
        if state in TERMINAL_STATES:
            self.log.info("mission %s %s: %s", s.goal_id, state, self.status.reason)
            self.holds.paused = ""
            self._release_held()

    def _release_held(self) -> None:
        """End the lift sessions and door requests the mission still holds (it ended, or
        was replaced)."""
        for held in self.leases.release_all():
            self.fleet.event("lease", f"released {held}: the mission ended holding it")

    def _running_step(self) -> tuple[int, int, py_trees.behaviour.Behaviour | None]:
        """(index of the route step running, number of steps, the step): a step is a leg,
        a door or an elevator of the route tree (done steps counted when none runs)."""
        steps = self._steps_of if self.driving else []
        for i, step in enumerate(steps):
            if step.status == Status.RUNNING:
                return i, len(steps), step
        return sum(s.status == Status.SUCCESS for s in steps), len(steps), None

    def _action(self) -> str:
        """The running step, e.g. "Door d1_room_1a (2/5)"; "plan" while planning."""
        if not self.driving:
            return "plan"
        i, n, step = self._running_step()
        return f"{step.name} ({i + 1}/{n})" if step is not None else ""

    def _progress(self) -> float:
        """Route steps done, plus the controller's progress along the running leg."""
        i, n, step = self._running_step()
        if n == 0:
            return 0.0
        return min(1.0, (i + self._leg_progress(step)) / n)

    def _leg_progress(self, step: py_trees.behaviour.Behaviour | None) -> float:
        """The controller's progress along ``step`` if it is a leg and the controller's
        report is about that leg's path (not the step before's)."""
        follow = self.fleet.follow_status()
        if step is None or follow is None or not step.name.startswith("Leg "):
            return 0.0
        ours = any(
            isinstance(b, FollowPath) and b.path_id == follow.path_id for b in step.iterate()
        )
        return follow.progress if ours else 0.0

    def _publish(self, now: float) -> None:
        s = self.status
        sig = (s.goal_id, s.state, s.action, s.phase)
        due = now - self._last_sent_at >= 1.0 / self.cfg.status_rate_hz
        if sig != self._last_sent or due:
            self.status.stamp = now
            self.out.publish_status(self.status)
            self._last_sent, self._last_sent_at = sig, now
