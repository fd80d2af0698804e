"""Which tracker drives the chair: the sampling MPC, or pure pursuit where the MPC does not go.

``controller.mode: mpc`` uses :class:`~services.controller.mpc.SamplingMPC` (tuned by the
``controller.mpc`` section) for forward paths (walls from the floor map's distance field,
obstacles from the live LiDAR). Pure pursuit takes reverse paths (backing out of a lift
car), precise passes (through a door, into a car: the MPC's safety margins leave no room
in a 1.0 m door) and the last ``controller.final_approach_m`` of a path (the MPC's costs
flatten out where v_ref falls to 0; pure pursuit docks on the approach pose). ``pursuit``
uses pure pursuit throughout. A path with ``dock_heading`` set is a docking manoeuvre
(:mod:`services.controller.docking`) whatever the mode; one with ``door`` set is a smooth
door pass (:mod:`services.controller.smooth_pass`, steered onto the door the scans show).
Pure: the node hands in poses, speeds and points.
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import distance_transform_edt

from services.controller import door_bezier, manoeuvre, mpc_scene, safety, scan_frame
from services.controller.command import Command
from services.controller.docking import Docker, DockLimits
from services.controller.mpc import SamplingMPC
from services.controller.pure_pursuit import PathFollower
from services.controller.smooth_pass import FALLBACK, THROUGH, PassSettings, SmoothPass
from shared import door_scan, geometry
from shared.config import ConfigError, ControllerConfig, RobotConfig
from shared.site import Site

MIN_SMOOTH_SPEED = 0.05  # m/s: a smooth pass without a usable v_ref[0] crawls at this


class StallWatch:
    """Calls a leg blocked when its distance to go has not shrunk by ``progress_m`` for
    ``after_s`` of following: a sampling MPC boxed in by a tight turn keeps "following"
    without moving, and the mission would otherwise wait out the leg's long limit instead
    of starting its recoveries."""

    def __init__(self, after_s: float, progress_m: float) -> None:
        self.after_s, self.progress_m = after_s, progress_m
        self.reset()

    def reset(self) -> None:
        self.best = float("inf")
        self.since = 0.0
        self.stalled = False

    def update(self, distance_to_goal: float, period_s: float) -> bool:
        """Account one cycle; True once the leg is stalled (until the next path)."""
        if distance_to_goal < self.best - self.progress_m:
            self.best, self.since = distance_to_goal, 0.0
        else:
            self.since += period_s
        self.stalled = self.stalled or (self.after_s > 0 and self.since >= self.after_s)
        return self.stalled


class Tracker:
    """Follows one path at a time with the configured tracker."""

    def __init__(self, cfg: ControllerConfig, robot: RobotConfig, site: Site | None) -> None:
        self.cfg = cfg
        self.robot = robot
        self.pursuit = PathFollower(cfg, robot)
        self.docker = Docker(
            DockLimits.from_config(cfg, robot), robot.footprint, robot.side_margin_m
        )
        self.mpc: SamplingMPC | None = None
        self.fields: dict[str, tuple[np.ndarray, float, tuple[float, float]]] = {}
        self.floor = ""
        self.use_mpc = False
        self._precise = False
        self.smooth: SmoothPass | None = None
        self.stall = StallWatch(cfg.stall_s, cfg.stall_progress_m)
        manoeuvre.warm_up()
        geometry.warm_up()
        door_scan.warm_up()
        door_bezier.warm_up()
        scan_frame.warm_up()  # the node places each scan with it
        mpc_scene.warm_up()
        safety.warm_up()  # the node bins each scan for the guard with it
        if cfg.mode == "mpc":
            try:
                self.mpc = SamplingMPC(cfg.mpc, robot, cfg.goal_tolerance_m, cfg.brake_latency_s)
            except ConfigError as exc:  # a rule between fields: name the section's key
                raise ConfigError(f"controller.mpc.{exc}") from None
            for name, floor in site.floors.items() if site else []:
                g = floor.map
                dist = distance_transform_edt(~g.occupied(True), sampling=g.resolution)
                self.fields[name] = (dist, g.resolution, (g.origin[0], g.origin[1]))
            self._warm_up()

    def _warm_up(self) -> None:
        """Compile the MPC kernel now, not in the first control cycle of a mission."""
        if not self.fields:
            return
        name = next(iter(self.fields))
        self._floor(name)
        dist, res, origin = self.fields[name]
        r, c = np.unravel_index(int(np.argmax(dist)), dist.shape)
        x, y = origin[0] + (c + 0.5) * res, origin[1] + (r + 0.5) * res
        self.mpc.set_path(np.array([[x, y], [x + 0.5, y]]), np.array([0.3, 0.0]))
        self.mpc.step(x, y, 0.0, 0.0, 0.0, None, 0.04)
        # and with LiDAR points, as every real cycle has them: numba compiles per signature
        near = np.array([[x + 1.5, y], [x + 1.5, y + 0.2]])
        self.mpc.step(x, y, 0.0, 0.1, 0.0, near, 0.04)
        self.mpc.set_path(np.zeros((0, 2)), np.zeros(0))

    def _floor(self, floor: str) -> None:
        if self.mpc is not None and floor in self.fields and floor != self.floor:
            self.floor = floor
            self.mpc.set_distance_field(*self.fields[floor])

    @property
    def path_id(self) -> str:
        return self.pursuit.path_id

    @property
    def precise(self) -> bool:
        """True while following a precise pass or docking (not a leg)."""
        return self.docker.active or self._precise

    def precise_near(self, x: float, y: float, theta: float) -> tuple[np.ndarray, float] | None:
        """Where the guard keeps the precise margin, for the chair at (x, y, theta): in a
        smooth pass, near the door (its jambs in the robot frame, and the door's width plus
        ``precise_near_door_m``: an open leaf is as long as its door is wide); None (no
        limit) in any other precise pass or docking, which knows no door."""
        if self.smooth is None:
            return None
        sm = self.smooth
        reach = max(sm.width, sm.settings.door_width) + self.cfg.precise_near_door_m
        return geometry.into_frame(sm.jambs(), x, y, theta), reach

    def turn_margin(self) -> float:
        """The margin the safety check of a turn on the spot keeps now (see the docker)."""
        return self.docker.turn_margin(self.robot.side_margin_m, self.cfg.precise_side_margin_m)

    def set_path(
        self,
        path_id: str,
        waypoints: np.ndarray,
        v_ref: np.ndarray,
        reverse: bool = False,
        precise: bool = False,
        dock_heading: float | None = None,
        keep_out: np.ndarray | None = None,
        door: list[float] | None = None,
    ) -> None:
        """Follow a path; reverse and precise (door, lift car) passes use pure pursuit,
        a path with ``dock_heading`` is a docking manoeuvre to its last waypoint, whose
        manoeuvres count the ``keep_out`` segments (N, 4) as walls; one with ``door``
        ([x, y, heading, width, lead_m, through_m]) is a smooth pass through that door."""
        self.docker.clear()
        self.stall.reset()
        self._precise = precise
        self.smooth = None
        if door and len(waypoints) > 0:
            cx, cy, heading, width, lead, through = door[:6]
            offset = door[6] if len(door) > 6 else 0.0
            speed = float(v_ref[0]) if len(v_ref) and v_ref[0] > 0 else MIN_SMOOTH_SPEED
            cfg, fp = self.cfg, self.robot.footprint
            settings = PassSettings(
                door_speed=max(speed, MIN_SMOOTH_SPEED),
                lateral_accel=cfg.smooth_lateral_accel,
                lead_m=lead,
                through_m=through,
                lookahead_m=cfg.smooth_lookahead_m,
                door_width=width,
                chair_width=fp.width,
                front_m=fp.front,
                rear_m=fp.rear,
                gap_rate=cfg.smooth_gap_rate,
                doorway_speed=cfg.smooth_doorway_speed,
                zone_m=cfg.smooth_zone_m,
                decel=cfg.smooth_decel,
                max_turn_rate=self.robot.max_turn_rate,
                turn_accel=cfg.smooth_turn_accel,
                offset_m=offset,
                corner_excess_m=cfg.smooth_corner_excess_m,
                outline_clearance_m=cfg.smooth_outline_clearance_m,
                jamb_depth_m=cfg.smooth_jamb_depth_m,
                open_by_m=cfg.smooth_open_by_m,
            )
            self.smooth = SmoothPass((cx, cy), heading, settings, cfg.door_scan)
            self._precise = True
        if dock_heading is not None and len(waypoints) > 0:
            cap = float(v_ref[0]) if len(v_ref) and v_ref[0] > 0 else None
            gx, gy = float(waypoints[-1][0]), float(waypoints[-1][1])
            self.docker.set_goal(gx, gy, dock_heading, cap, keep_out)
            waypoints, v_ref = np.zeros((0, 2)), np.zeros(0)
        self.pursuit.set_path(path_id, waypoints, v_ref, reverse, precise)
        self.use_mpc = self.mpc is not None and not reverse and not precise and len(waypoints) > 0
        if self.mpc is not None:
            self.mpc.set_path(
                waypoints if self.use_mpc else np.zeros((0, 2)),
                v_ref if self.use_mpc else np.zeros(0),
            )

    def step(
        self,
        x: float,
        y: float,
        theta: float,
        floor: str,
        v: float,
        w: float,
        obstacles: np.ndarray | None,
        fresh: bool,
        period_s: float,
        scan: np.ndarray | None = None,
    ) -> Command:
        """The command for this cycle (zero when the pose is stale or everything collides).
        ``scan``: a scan not seen before (sensor frame), for a smooth pass's door."""
        if self.smooth is not None:
            return self._smooth_step(x, y, theta, fresh, scan)
        if self.docker.active:
            return self.docker.step(x, y, theta, fresh, obstacles, period_s)
        if not self.use_mpc:
            return self.pursuit.step(x, y, theta, fresh)
        if not fresh:
            return Command(0.0, 0.0, "stale")
        self._floor(floor)
        pursuit = self.pursuit.step(x, y, theta, fresh)  # keeps its progress in step too
        if pursuit.state == "arrived" or pursuit.distance_to_goal < self.cfg.final_approach_m:
            return pursuit
        cmd = self.mpc.step(x, y, theta, v, w, obstacles, period_s)
        if cmd.state == "following" and self.stall.update(cmd.distance_to_goal, period_s):
            return Command(0.0, 0.0, "blocked", cmd.progress, cmd.distance_to_goal, cmd.cross_track)
        return cmd

    def _smooth_step(
        self, x: float, y: float, theta: float, fresh: bool, scan: np.ndarray | None
    ) -> Command:
        """A smooth door pass: "arrived" once through, "fallback" where it cannot (facing
        away from the door: the navigator turns to stop-turn-go)."""
        smooth = self.smooth
        to_go = smooth.to_go((x, y, theta))
        if not fresh:
            return Command(0.0, 0.0, "stale", 0.0, to_go, 0.0)
        v, w, state = smooth.step((x, y, theta), scan)
        total = smooth.settings.lead_m + smooth.settings.through_m
        progress = max(0.0, min(1.0, 1.0 - to_go / total))
        if state == THROUGH:
            return Command(0.0, 0.0, "arrived", 1.0, 0.0, 0.0)
        if state == FALLBACK:
            return Command(0.0, 0.0, "fallback", progress, to_go, 0.0)
        return Command(v, w, "following", progress, to_go, 0.0)
