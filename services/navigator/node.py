"""Navigator service: runs the mission behaviour tree for each goal it receives.

Ticks the tree at ``navigator.rate_hz`` of fleet time (last lockstep stage), publishes
NavStatus on every change and at ``navigator.status_rate_hz``. While a route request is
out, the lockstep answer is held back, so when the route arrives does not depend on
machine load.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import py_trees
from py_trees.common import Access, Status

from behaviours.fleet import NS
from behaviours.mission import EntryParams, create_plan_tree, create_route_tree
from behaviours.snapshot import signature, snapshot
from services.navigator.door_check import door_state_from_scan, lane_blocked
from shared.lockstep import Participant
from shared.messages import (
    Availability,
    Clock,
    DoorRequest,
    DoorState,
    Event,
    FollowStatus,
    LiftDoor,
    LiftRequest,
    LiftRequestType,
    LiftState,
    NavGoal,
    NavStatus,
    Odometry,
    Path,
    PointCloud,
    Pose2D,
    PoseEstimate,
    RouteReply,
    RouteRequest,
)
from shared.service import Service
from shared.topics import Keys
from shared.transport import Bus

NAME = "navigator"


class ZenohFleet:
    """The :class:`behaviours.fleet.Fleet` interface over the bus."""

    def __init__(self, bus: Bus, keys: Keys, route_timeout_s: float) -> None:
        self.bus = bus
        self.keys = keys
        self.route_timeout_s = route_timeout_s
        self.clock: Clock | None = None
        self.participant: Participant | None = None
        self._pose: PoseEstimate | None = None
        self._odom: Odometry | None = None
        self.half_width_m = 0.375
        self._follow: FollowStatus | None = None
        self._doors: dict[str, int] = {}
        self._scan: PointCloud | None = None
        self.sensor_height_m = 1.5
        self._lifts: dict[str, LiftState] = {}
        self.avoid: set[str] = set()
        self.session = ""

    def now(self) -> float:
        return self.clock.stamp if self.clock else 0.0

    def request_route(
        self, goal: Pose2D | None, place: str, on_done: Callable[[RouteReply | None, str], None]
    ) -> None:
        if self._pose is None:
            on_done(None, "no pose estimate yet")
            return
        if self.participant is not None:
            self.participant.hold()

        def done(reply: RouteReply | None, error: str) -> None:
            on_done(reply, error)
            if self.participant is not None:
                self.participant.release()

        req = RouteRequest(start=self._pose.pose, goal=goal, place=place, avoid=list(self.avoid))
        self.bus.request(self.keys.route, req, RouteReply, self.route_timeout_s, done)

    def send_path(self, path: Path) -> None:
        self.bus.publish(self.keys.path, path)

    def stop(self) -> None:
        empty = Path(self.now(), "", "", np.zeros((0, 2)), np.zeros(0))
        self.bus.publish(self.keys.path, empty)

    def on_pose(self, msg: PoseEstimate) -> None:
        self._pose = msg

    def on_follow(self, msg: FollowStatus) -> None:
        self._follow = msg

    def follow_status(self) -> FollowStatus | None:
        return self._follow

    def pose(self) -> PoseEstimate | None:
        return self._pose

    def on_odom(self, msg: Odometry) -> None:
        self._odom = msg

    def odometry(self) -> Odometry | None:
        return self._odom

    def on_door_state(self, msg: DoorState) -> None:
        self._doors[msg.door_name] = msg.current_mode

    def door_mode(self, door_id: str) -> int | None:
        return self._doors.get(door_id)

    def on_scan(self, msg: PointCloud) -> None:
        self._scan = msg

    def lidar_door_state(self, x: float, y: float) -> tuple[float, str]:
        if self._scan is None or self._pose is None:
            return -1.0, "unknown"
        p = self._pose.pose
        return self._scan.stamp, door_state_from_scan(
            self._scan.points, (p.x, p.y, p.theta), (x, y), self.sensor_height_m
        )

    def lane_blocked(
        self, door_xy: tuple[float, float], direction: float, lead_m: float
    ) -> tuple[float, bool]:
        if self._scan is None or self._pose is None:
            return -1.0, False
        p = self._pose.pose
        return self._scan.stamp, lane_blocked(
            self._scan.points,
            (p.x, p.y, p.theta),
            door_xy,
            direction,
            self.sensor_height_m,
            self.half_width_m,
            lead_m,
        )

    def on_lift_state(self, msg: LiftState) -> None:
        self._lifts[msg.lift_name] = msg

    def lift_state(self, lift_id: str) -> LiftState | None:
        return self._lifts.get(lift_id)

    def session_id(self) -> str:
        return self.session

    def request_lift(self, lift_id: str, floor: str) -> None:
        req = LiftRequest(
            self.now(), lift_id, self.session, LiftRequestType.AGV_MODE, floor, LiftDoor.OPEN
        )
        self.bus.publish(self.keys.key("lift_request", lift=lift_id), req)

    def release_lift(self, lift_id: str) -> None:
        req = LiftRequest(
            self.now(), lift_id, self.session, LiftRequestType.END_SESSION, "", LiftDoor.CLOSED
        )
        self.bus.publish(self.keys.key("lift_request", lift=lift_id), req)

    def set_floor(self, floor: str) -> None:
        if self._pose is None:
            return
        p = self._pose.pose
        pose = Pose2D(p.x, p.y, p.theta, floor)
        self.bus.publish(
            self.keys.initial_pose, PoseEstimate(self.now(), pose, self._pose.covariance)
        )

    def event(self, kind: str, detail: str) -> None:
        level = "warning" if kind in ("safety_stop", "fallback") else "info"
        key = self.keys.key("events", source=NAME)
        self.bus.publish(key, Event(self.now(), NAME, kind, detail, level))

    def request_door(self, door_id: str, mode: int) -> None:
        req = DoorRequest(self.now(), self.keys.robot, door_id, mode)
        self.bus.publish(self.keys.key("door_request", door=door_id), req)


class Navigator:
    """One mission at a time: a fresh tree per goal, status on change."""

    def __init__(self, svc: Service, fleet: ZenohFleet) -> None:
        self.svc = svc
        self.fleet = fleet
        self.cfg = svc.cfg.navigator
        self.tree: py_trees.trees.BehaviourTree | None = None
        self.status = NavStatus(0.0, "", "idle")
        self._last_sent: tuple | None = None
        self._tree_sig: tuple | None = None
        self._tree_sent_at = -1e9
        self._last_sent_at = -1e9
        self.bb = py_trees.blackboard.Client(name=NAME, namespace=NS)
        for key in ("goal", "place", "failure", "phase", "route", "blocked", "action"):
            self.bb.register_key(key, access=Access.WRITE)
        self.stage = "plan"

    def on_goal(self, msg: NavGoal) -> None:
        if msg.cancel:
            if self.tree is not None and self.status.state == "running":
                self.tree.interrupt()
                self.fleet.stop()
                self._set("cancelled", reason="cancelled by request")
            return
        if msg.goal is None and not msg.place:
            self.svc.log.warning("goal %s ignored: give a goal pose or a place", msg.goal_id)
            return
        if self.tree is not None and self.status.state == "running":
            self.tree.interrupt()
        self.bb.goal, self.bb.place, self.bb.failure, self.bb.phase = msg.goal, msg.place, "", ""
        self.bb.blocked = ""
        self.fleet.avoid.clear()
        self.fleet.session = f"{self.svc.keys.robot}-{msg.goal_id}"
        self.replans = 0
        self.fallbacks: list[str] = []
        self.stage = "plan"
        self._grow(create_plan_tree(self.fleet.now, self.cfg.plan_timeout_s))
        target = msg.place or f"({msg.goal.x:.2f}, {msg.goal.y:.2f})"
        self.svc.log.info("mission %s to %s", msg.goal_id, target)
        self.status = NavStatus(self.fleet.now(), msg.goal_id, "running")

    def _grow(self, root: py_trees.behaviour.Behaviour) -> None:
        self.tree = py_trees.trees.BehaviourTree(root)
        # setup only stores the fleet handle (never blocks); a finite timeout would need
        # signals, which only work on the main thread, and goals arrive on Zenoh threads
        self.tree.setup(timeout=py_trees.common.Duration.INFINITE, fleet=self.fleet)

    def step(self, clock: Clock) -> None:
        self.fleet.clock = clock
        if self.tree is not None and self.status.state == "running":
            self.tree.tick()
            self._stream_tree(clock.stamp)
            result = self.tree.root.status
            if result == Status.SUCCESS and self.stage == "plan":
                self.stage = "route"
                self.svc.bus.publish(self.svc.keys.nav_route, self.bb.route)
                fp = self.svc.cfg.robot.footprint
                params = EntryParams(
                    self.cfg,
                    self.svc.cfg.planner.door_speed,
                    fp.front,
                    fp.rear,
                    self.fleet.half_width_m,
                )
                self._grow(create_route_tree(self.bb.route, self.fleet.now, params))
                self.tree.tick()  # start the first step now: its phase is the status's
                self._set("running", phase=self.bb.phase, action=self._action())
            elif result == Status.SUCCESS:
                self._set("succeeded", reason="arrived")
            elif result == Status.FAILURE and self._replan():
                pass
            elif result == Status.FAILURE:
                failure = self.bb.failure or "mission failed"
                self._set("failed", reason="; then ".join([*self.fallbacks, failure]))
            else:
                tip = self.tree.tip()
                self._set(
                    "running",
                    phase=self.bb.phase,
                    action=self._action(),
                    reason=tip.feedback_message if tip else "",
                )
        self._publish(clock.stamp)

    def _stream_tree(self, now: float) -> None:
        """Publish a snapshot when the tree's statuses change (feedback alone: at 2 Hz)."""
        snap = snapshot(self.tree.root, now, self.status.goal_id)
        sig = signature(snap)
        if sig != self._tree_sig or now - self._tree_sent_at >= 0.5:
            self.svc.bus.publish(self.svc.keys.tree, snap)
            self._tree_sig, self._tree_sent_at = sig, now

    def _replan(self) -> bool:
        """After a door or lift failed: avoid it and plan again (bounded). False if not."""
        blocked = self.bb.blocked
        if self.stage != "route" or not blocked or self.replans >= self.cfg.max_replans:
            return False
        self.replans += 1
        self.fleet.avoid.add(blocked)
        self.svc.log.warning(
            "%s failed (%s): planning around it (re-plan %d of %d)",
            blocked,
            self.bb.failure,
            self.replans,
            self.cfg.max_replans,
        )
        self.fleet.event("fallback", f"avoiding {blocked}: {self.bb.failure}")
        self.svc.bus.publish(
            self.svc.keys.planner_updates,
            Availability(self.fleet.now(), blocked, False, self.bb.failure),
        )
        self.fallbacks.append(self.bb.failure)
        self.bb.blocked = ""
        self.bb.failure = ""
        self.stage = "plan"
        self._grow(create_plan_tree(self.fleet.now, self.cfg.plan_timeout_s))
        self._set("running", phase="plan", action="re-plan")
        return True

    def _set(self, state: str, **fields) -> None:
        s = self.status
        self.bb.action = fields.get("action", "")
        self.status = NavStatus(
            self.fleet.now(),
            s.goal_id,
            state,
            fields.get("action", s.action if state == "running" else ""),
            fields.get("phase", s.phase),
            fields.get("reason", ""),
            self._progress(),
        )
        if state in ("failed", "succeeded", "cancelled"):
            self.svc.log.info("mission %s %s: %s", s.goal_id, state, self.status.reason)

    def _steps(self) -> tuple[int, int, str]:
        """(index of the route step running, number of steps, its name): a step is a
        child of the route tree's Drive sequence (a leg, a door, an elevator)."""
        if self.tree is None or self.stage != "route":
            return 0, 0, ""
        drive = self.tree.root.children[0].decorated  # Route -> Safety -> Drive
        for i, child in enumerate(drive.children):
            if child.status == Status.RUNNING:
                return i, len(drive.children), child.name
        done = sum(c.status == Status.SUCCESS for c in drive.children)
        return done, len(drive.children), ""

    def _action(self) -> str:
        """The running step, e.g. "Door d1_room_1a (2/5)"; "plan" while planning."""
        if self.stage != "route":
            return "plan"
        i, n, name = self._steps()
        return f"{name} ({i + 1}/{n})" if name else ""

    def _progress(self) -> float:
        """Route steps done, plus the controller's progress along the running one."""
        i, n, name = self._steps()
        if n == 0:
            return 0.0
        follow = self.fleet.follow_status()
        part = follow.progress if follow and name.startswith("Leg") else 0.0
        return min(1.0, (i + part) / n)

    def _publish(self, now: float) -> None:
        s = self.status
        signature = (s.goal_id, s.state, s.action, s.phase)
        due = now - self._last_sent_at >= 1.0 / self.cfg.status_rate_hz
        if signature != self._last_sent or due:
            self.status.stamp = now
            self.svc.bus.publish(self.svc.keys.nav_status, self.status)
            self._last_sent, self._last_sent_at = signature, now


def main(argv: list[str] | None = None) -> None:
    with Service(NAME, __doc__.splitlines()[0], argv) as svc:
        keys, bus = svc.keys, svc.bus
        fleet = ZenohFleet(bus, keys, svc.cfg.navigator.plan_timeout_s)
        nav = Navigator(svc, fleet)

        bus.subscribe(svc.declare("subscribes", keys.pose), PoseEstimate, fleet.on_pose)
        bus.subscribe(svc.declare("subscribes", keys.follow_status), FollowStatus, fleet.on_follow)
        bus.subscribe(svc.declare("subscribes", keys.nav_goal), NavGoal, nav.on_goal)
        bus.subscribe(
            svc.declare("subscribes", keys.key("door_state")), DoorState, fleet.on_door_state
        )
        bus.subscribe(
            svc.declare("subscribes", keys.key("lift_state")), LiftState, fleet.on_lift_state
        )
        bus.subscribe(svc.declare("subscribes", keys.scan), PointCloud, fleet.on_scan)
        bus.subscribe(svc.declare("subscribes", keys.odom), Odometry, fleet.on_odom)
        fleet.sensor_height_m = svc.cfg.robot.lidar_height_m
        fleet.half_width_m = svc.cfg.robot.footprint.width / 2 + 0.05
        svc.declare("publishes", keys.nav_status)
        svc.declare("publishes", keys.tree)
        svc.declare("publishes", keys.nav_route)
        svc.declare("publishes", keys.path)
        svc.declare("queries", keys.route)
        fleet.participant = svc.every(svc.cfg.navigator.rate_hz, nav.step)
        svc.wait()


if __name__ == "__main__":
    main()
