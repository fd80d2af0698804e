"""Controller service: turns the current path and pose into velocity commands.

Steps at ``controller.rate_hz`` of fleet time (a lockstep participant after the
localisation), publishes a Twist and a FollowStatus every step. ``controller.mode``
picks pure pursuit or the sampling MPC (services/controller/tracking.py); the MPC sees
walls in the floor map and obstacles in the latest LiDAR scan. A pose older than
``controller.pose_timeout_s`` or flagged lost gives a zero command. While the emergency
stop is active (shared/estop.py) the command is zero whatever the path, the tracker is
not stepped and the status says ``estop``; a zero command goes out as soon as the stop
arrives, without waiting for the next step.
"""

from __future__ import annotations

import dataclasses
import math
from collections import deque
from collections.abc import Callable

import numpy as np

from services.controller.safety import describe_hold, guard, guard_points, obstacle_check
from services.controller.scan_frame import place_points
from services.controller.tracking import Tracker
from shared.arrivals import Arrivals
from shared.estop import EstopLatch, hold_estop
from shared.messages import (
    Clock,
    Event,
    FollowStatus,
    Odometry,
    Path,
    PointCloud,
    PoseEstimate,
    Twist,
)
from shared.service import Service
from shared.site import SiteError, load_site

NAME = "controller"
SCAN_POSE_WINDOW_S = 1.0  # pose estimates kept to place a scan with its own pose


def scan_to_world(
    scan: PointCloud, pose: PoseEstimate, band_m: float, range_m: float
) -> np.ndarray:
    """Scan points within ``band_m`` of the sensor height and ``range_m`` of it, in the map
    frame (the floor returns of a 3-D LiDAR are not obstacles)."""
    p = pose.pose
    return place_points(scan.points, band_m, range_m, p.x, p.y, p.theta)


class PoseHistory:
    """The pose estimates of the last ``window_s`` seconds, to place a scan on the map with
    the pose the chair had when it was taken: turning at 0.5 rad/s, a scan 0.1 s old put
    down with the newest pose lies 3 degrees round, 4 cm off at the chair's corners."""

    def __init__(self, window_s: float) -> None:
        self.window_s = window_s
        self._poses: deque[PoseEstimate] = deque()

    def add(self, est: PoseEstimate) -> None:
        if self._poses and est.stamp < self._poses[-1].stamp:
            self._poses.clear()  # time went back (a new run): start again
        self._poses.append(est)
        while self._poses and self._poses[0].stamp < est.stamp - self.window_s:
            self._poses.popleft()

    def latest(self) -> PoseEstimate | None:
        return self._poses[-1] if self._poses else None

    def oldest_stamp(self) -> float:
        return self._poses[0].stamp if self._poses else math.inf

    def at(self, stamp: float) -> PoseEstimate | None:
        """The newest estimate not after ``stamp`` (the oldest kept if all are after it)."""
        for est in reversed(self._poses):  # newest first: the scan's pose is near the end
            if est.stamp <= stamp + 1e-9:
                return est
        return self._poses[0] if self._poses else None


class ScanCache:
    """``fn(scan, *poses)`` worked out once per scan (and pose it is placed with): the
    controller steps 2.5 times per scan, and a VLP-16 scan holds 30,000 points."""

    def __init__(self, fn: Callable[..., np.ndarray | None]) -> None:
        self._fn = fn
        self._args: tuple[object, ...] = ()
        self._value: np.ndarray | None = None

    def __call__(self, *args: object) -> np.ndarray | None:
        same = len(args) == len(self._args) and all(
            a is b for a, b in zip(args, self._args, strict=True)
        )
        if not same:
            self._args, self._value = args, self._fn(*args)
        return self._value


def stopped_status(last: FollowStatus | None, stamp: float, path_id: str) -> FollowStatus:
    """The status under the emergency stop: state ``estop``, the path held and the figures
    of the last status about it (zero without one)."""
    if last is None or last.path_id != path_id:
        return FollowStatus(stamp, path_id, "estop", 0.0, 0.0, 0.0)
    return dataclasses.replace(last, stamp=stamp, state="estop")


def main(argv: list[str] | None = None) -> None:
    with Service(NAME, __doc__.splitlines()[0], argv) as svc:
        cfg, keys, bus = svc.cfg, svc.keys, svc.bus
        cc = cfg.controller
        try:
            site = load_site(cfg.site) if cc.mode == "mpc" else None
        except SiteError as exc:
            svc.log.error("cannot start: %s", exc)
            raise SystemExit(2) from None
        tracker = Tracker(cc, cfg.robot, site)
        # the docker's manoeuvre note, the MPC's blocked note, the guard's hold: logged on change
        noted = ["", "", ""]
        latest: dict[str, object] = {}
        poses = PoseHistory(SCAN_POSE_WINDOW_S)
        arrivals = Arrivals(wall=cfg.clock == "wall")  # staleness on this clock (wall time)

        placed = ScanCache(
            lambda scan, at: scan_to_world(
                scan, at, cfg.localisation.scan_band_m, cc.obstacle_range_m
            )
        )
        near = ScanCache(
            lambda scan: guard_points(scan.points, cfg.robot, cc, cfg.localisation.scan_band_m)
        )

        def on_pose(msg: PoseEstimate) -> None:
            latest["pose"] = msg
            arrivals.arrived("pose")
            poses.add(msg)

        def on_odom(msg: Odometry) -> None:
            latest["odom"] = msg

        def on_scan(msg: PointCloud) -> None:
            latest["scan"] = msg
            arrivals.arrived("scan")

        def on_path(msg: Path) -> None:
            tracker.set_path(
                msg.path_id,
                msg.waypoints,
                msg.v_ref,
                msg.reverse,
                msg.precise,
                msg.dock_heading,
                msg.keep_out,
                msg.door,
            )
            svc.log.info(
                "path %s: %d waypoints%s",
                msg.path_id or "(stop)",
                len(msg.waypoints),
                " (reverse)" if msg.reverse else "",
            )

        def on_estop(latch: EstopLatch) -> None:
            stamp = latest["clock"].stamp if "clock" in latest else 0.0
            detail = "emergency stop cleared: tracking again"
            if latch.stop.active:
                bus.publish(cmd_key, Twist(stamp, 0.0, 0.0))  # at once, not at the next step
                detail = f"{latch.reason()}: command zeroed"
            bus.publish(events_key, Event(stamp, NAME, "emergency_stop", detail, "warning"))

        def step(clock: Clock) -> None:
            latest["clock"] = clock
            if estop.active:
                status = stopped_status(latest.get("status"), clock.stamp, tracker.path_id)
                bus.publish(cmd_key, Twist(clock.stamp, 0.0, 0.0))
                bus.publish(status_key, status)
                return
            pose = latest.get("pose")
            if pose is None:
                cmd_v, cmd_w = 0.0, 0.0
                status = FollowStatus(clock.stamp, tracker.path_id, "no_pose", 0.0, 0.0, 0.0)
            else:
                age = arrivals.age("pose", pose.stamp, clock.stamp)
                fresh = age <= cc.pose_timeout_s and not pose.lost
                odom = latest.get("odom")
                scan = latest.get("scan")
                seen = (poses.at(scan.stamp) or pose) if scan is not None else pose
                obstacles = placed(scan, seen) if scan is not None else None
                p = pose.pose
                new_scan = None
                if scan is not None and scan.stamp != latest.get("scan_used"):
                    latest["scan_used"] = scan.stamp
                    new_scan = scan.points
                cmd = tracker.step(
                    p.x,
                    p.y,
                    p.theta,
                    p.floor,
                    odom.v if odom else 0.0,
                    odom.w if odom else 0.0,
                    obstacles,
                    fresh,
                    1.0 / cc.rate_hz,
                    new_scan,
                )
                if tracker.docker.plan_note != noted[0]:
                    noted[0] = tracker.docker.plan_note
                    svc.log.info("%s: %s", tracker.path_id, noted[0])
                blocked = tracker.mpc.blocked_note if tracker.mpc is not None else ""
                if blocked and blocked != noted[1]:
                    noted[1] = blocked
                    svc.log.info("%s: blocked: %s", tracker.path_id, blocked)
                points = near(scan) if scan is not None else None
                checks = (
                    cfg.robot,
                    cc,
                    cfg.localisation.scan_band_m,
                    tracker.precise,
                    tracker.turn_margin(),
                    cmd.turn_left_rad,
                    # the door's jambs seen from where the guard's points were seen
                    tracker.precise_near(seen.pose.x, seen.pose.y, seen.pose.theta),
                )
                cmd_v, cmd_w, state = guard(
                    cmd.v,
                    cmd.w,
                    cmd.state,
                    clock.stamp,
                    fresh,
                    # the scan's time on this clock (its stamp in lockstep, its arrival on
                    # wall time): the guard judges its age against clock.stamp
                    None
                    if scan is None
                    else clock.stamp - arrivals.age("scan", scan.stamp, clock.stamp),
                    points,
                    *checks,
                )
                if state == "obstacle" and not noted[2]:
                    check = obstacle_check(cmd.v, cmd.w, points, *checks)
                    noted[2] = describe_hold(
                        check, cmd.v, cmd.w, points, cfg.robot, cfg.localisation.scan_band_m
                    )
                    svc.log.info("%s: held: %s", tracker.path_id, noted[2])
                elif state != "obstacle":
                    noted[2] = ""
                status = FollowStatus(
                    clock.stamp,
                    tracker.path_id,
                    state,
                    cmd.progress,
                    cmd.distance_to_goal,
                    cmd.cross_track,
                    tracker.precise,
                )
            latest["status"] = status
            bus.publish(cmd_key, Twist(clock.stamp, cmd_v, cmd_w))
            bus.publish(status_key, status)

        bus.subscribe(svc.declare("subscribes", keys.pose), PoseEstimate, on_pose)
        bus.subscribe(svc.declare("subscribes", keys.path), Path, on_path)
        bus.subscribe(svc.declare("subscribes", keys.odom), Odometry, on_odom)
        bus.subscribe(svc.declare("subscribes", keys.scan), PointCloud, on_scan)
        cmd_key = svc.declare("publishes", keys.cmd_vel)
        status_key = svc.declare("publishes", keys.follow_status)
        events_key = svc.declare("publishes", keys.key("events", source=NAME))
        estop = hold_estop(bus, keys, NAME, svc.log, on_estop)
        svc.log.info("tracking with %s", cc.mode)
        svc.every(cc.rate_hz, step)
        svc.wait()


if __name__ == "__main__":
    main()
