"""Navigator service: runs the mission behaviour tree for each goal it receives.

Ticks the tree at ``navigator.rate_hz`` of fleet time (last lockstep stage), publishes
NavStatus on every change and at ``navigator.status_rate_hz``. While a route request is
out, the lockstep answer is held back, so when the route arrives does not depend on
machine load. The mission logic is :mod:`services.navigator.navigator`, the fleet's
state :mod:`services.navigator.fleet_state`; this module only wires them to the bus, and
keeps the mission where a restarted navigator takes it up (:mod:`resume`). It holds the
emergency stop (shared/estop.py), hears the driver's status (the rider's joystick) and
resume requests.
"""

from __future__ import annotations

import base64
import time
from collections.abc import Callable

from services.navigator.fleet_state import FleetState
from services.navigator.navigator import NAME, Navigator
from services.navigator.resume import MissionRecord, in_car, resume_goal
from shared.codec import DecodeError, decode
from shared.config import FleetConfig
from shared.estop import hold_estop
from shared.lockstep import Participant
from shared.messages import (
    Availability,
    Clock,
    DoorState,
    DriverStatus,
    Event,
    FollowStatus,
    LiftState,
    NavGoal,
    NavResume,
    NavStatus,
    Odometry,
    Path,
    PointCloud,
    Pose2D,
    PoseEstimate,
    RouteReply,
    TreeSnapshot,
)
from shared.service import Service
from shared.state_store import StateStore
from shared.topics import Keys
from shared.transport import Bus


class ZenohFleet(FleetState):
    """The :class:`behaviours.fleet.Fleet` interface over the bus: the sending half."""

    def __init__(self, bus: Bus, keys: Keys, cfg: FleetConfig) -> None:
        super().__init__(
            keys.robot,
            cfg.navigator.door_check,
            cfg.robot.lidar_height_m,
            cfg.robot.clearance_half_width_m,
            source=NAME,
            front_m=cfg.robot.footprint.front,
            rear_m=cfg.robot.footprint.rear,
            door_scan=cfg.controller.door_scan,
            restamp=time.time if cfg.clock == "wall" else None,
            state_max_age_s=cfg.navigator.building_state_max_age_s,
        )
        self.bus = bus
        self.keys = keys
        # in lockstep the fleet's clock stands still while a route is out (the answer to the
        # tick is held): a planner slow on a loaded machine must not end the plan, only a
        # hung one, which sim.lockstep_timeout_s bounds as it bounds every stage
        lockstep = cfg.clock != "wall" and cfg.sim.lockstep
        self.route_timeout_s = cfg.navigator.plan_timeout_s
        if lockstep:
            self.route_timeout_s = max(self.route_timeout_s, cfg.sim.lockstep_timeout_s)
        self.participant: Participant | None = None

    def request_route(
        self, goal: Pose2D | None, place: str, on_done: Callable[[RouteReply | None, str], None]
    ) -> None:
        req = self.route_request(goal, place)
        if req is None:
            on_done(None, "no pose estimate yet")
            return
        for lift, why in self.lifts_to_report():
            self.event("fallback", f"avoiding {lift}: lift {lift} is {why}")
        if self.participant is not None:
            self.participant.hold()

        def done(reply: RouteReply | None, error: str) -> None:
            on_done(reply, error)
            if self.participant is not None:
                self.participant.release()

        self.bus.request(self.keys.route, req, RouteReply, self.route_timeout_s, done)

    def send_path(self, path: Path) -> None:
        self.bus.publish(self.keys.path, path)

    def stop(self) -> None:
        self.bus.publish(self.keys.path, self.stop_path())

    def request_lift(self, lift_id: str, floor: str) -> None:
        self.bus.publish(
            self.keys.key("lift_request", lift=lift_id), self.lift_request(lift_id, floor)
        )

    def release_lift(self, lift_id: str) -> None:
        self.bus.publish(self.keys.key("lift_request", lift=lift_id), self.lift_release(lift_id))

    def set_floor(self, floor: str) -> None:
        pose = self.initial_pose(floor)
        if pose is not None:
            self.bus.publish(self.keys.initial_pose, pose)

    def event(self, kind: str, detail: str) -> None:
        self.bus.publish(self.keys.key("events", source=NAME), self.event_message(kind, detail))

    def hold_door_open(self, door_id: str) -> None:
        self.bus.publish(
            self.keys.key("door_request", door=door_id), self.hold_door_open_request(door_id)
        )

    def request_door(self, door_id: str, mode: int) -> None:
        self.bus.publish(
            self.keys.key("door_request", door=door_id), self.door_request(door_id, mode)
        )


class BusOutput:
    """The navigator's :class:`~services.navigator.navigator.NavigatorOutput` on the bus."""

    def __init__(self, bus: Bus, keys: Keys) -> None:
        self.bus = bus
        self.keys = keys

    def publish_status(self, status: NavStatus) -> None:
        self.bus.publish(self.keys.nav_status, status)

    def publish_tree(self, snapshot: TreeSnapshot) -> None:
        self.bus.publish(self.keys.tree, snapshot)

    def publish_route(self, route: RouteReply) -> None:
        self.bus.publish(self.keys.nav_route, route)

    def mark_unavailable(self, update: Availability) -> None:
        self.bus.publish(self.keys.planner_updates, update)


class Saver:
    """Keeps the navigator's mission in its state store as it changes (and once a second
    of fleet time while it runs), and takes a saved one up once after a restart."""

    def __init__(self, nav: Navigator, store: StateStore, within_s: float, log) -> None:
        self.nav, self.store, self.within_s, self.log = nav, store, within_s, log
        self._last: tuple | None = None
        self._saved_at = -1e9
        self._pending: MissionRecord | None = None
        try:
            raw = store.load()
            self._pending = None if raw is None else MissionRecord.from_dict(raw)
        except ValueError as exc:
            store.problem = str(exc)
        if store.problem:
            log.warning("no mission to take up: %s", store.problem)

    @property
    def pending(self) -> bool:
        return self._pending is not None

    def take_up(self, now: float) -> None:
        """Once the controller has ended the leg it had: take the saved mission up (ride on
        in a car, else plan again) if it is to be resumed."""
        record, self._pending = self._pending, None
        if self.nav.status.goal_id:  # a goal came in meanwhile: it wins over the saved one
            self.log.info("not taking up the saved mission: a new goal came first")
            return
        goal, why = resume_goal(record, now, self.within_s)
        if goal is None:
            if record is not None:
                self.log.info("not taking up the saved mission: %s", why)
            return
        how = "planning again from where it stands"
        route = None
        if in_car(record):
            try:
                route = decode(base64.b64decode(record.route), RouteReply)
            except (ValueError, DecodeError) as exc:
                self.log.warning("saved route unreadable (%s): planning again", exc)
        if route is not None:
            self.nav.ride_on(goal, route, record.step)
            how = "riding on in the lift car"
        else:
            self.nav.on_goal(goal)
        for checkpoint in record.avoided:
            self.nav.avoid(checkpoint)
        if record.paused:  # a restart is no request to resume
            self.nav.holds.paused = record.paused
            how += f", still paused ({record.paused})"
        text = f"took up mission {goal.goal_id} (it was in {record.phase or 'plan'}): {how}"
        self.log.warning("%s", text)
        self.nav.fleet.event("resumed", text)

    def save(self, now: float) -> None:
        record = self.nav.record()
        if record is None:
            return
        key = (record.goal_id, record.state, record.phase, tuple(record.avoided), record.paused)
        if key != self._last or (record.state == "running" and now - self._saved_at >= 1.0):
            self.store.save(record.to_dict())
            self._last, self._saved_at = key, now


def main(argv: list[str] | None = None) -> None:
    with Service(NAME, __doc__.splitlines()[0], argv) as svc:
        keys, bus = svc.keys, svc.bus
        fleet = ZenohFleet(bus, keys, svc.cfg)
        nav = Navigator.from_config(svc.cfg, fleet, BusOutput(bus, keys), svc.log)
        saver = Saver(nav, StateStore.from_env(NAME), svc.cfg.navigator.resume_within_s, svc.log)

        estop = hold_estop(bus, keys, NAME, svc.log)

        def step(clock: Clock) -> None:
            fleet.on_clock(clock)
            nav.set_estop(estop.reason())
            follow = fleet.follow_status()
            # a saved mission waits for the pose and for the controller to end the leg it
            # had (a pass through a door, a drive out of a car)
            leg_done = follow is None or follow.state != "following"
            if saver.pending and fleet.pose() is not None and leg_done:
                saver.take_up(clock.stamp)
            nav.step(clock.stamp)
            saver.save(clock.stamp)
            for req in nav.leases.doors_clear_to_close():
                bus.publish(keys.key("door_request", door=req.door_name), req)

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
        bus.subscribe(
            svc.declare("subscribes", keys.driver_status), DriverStatus, nav.on_driver_status
        )
        bus.subscribe(svc.declare("subscribes", keys.nav_resume), NavResume, nav.on_resume)
        bus.subscribe(
            svc.declare("subscribes", keys.key("events", source="localisation")),
            Event,
            nav.on_localisation_event,
        )
        svc.declare("publishes", keys.nav_status)
        svc.declare("publishes", keys.tree)
        svc.declare("publishes", keys.nav_route)
        svc.declare("publishes", keys.path)
        svc.declare("queries", keys.route)
        fleet.participant = svc.every(svc.cfg.navigator.rate_hz, step)
        svc.wait()


if __name__ == "__main__":
    main()
