"""Fleet configuration: every default in one place, loaded from YAML and checked.

One YAML file configures the whole fleet; each service reads its own section plus
``robot`` and ``transport``. Unknown keys, wrong types and out-of-range values fail with
one line naming the dotted path, e.g. ``controller.lookahead_m: must be > 0, got -0.2``.
"""

from __future__ import annotations

import dataclasses
import ipaddress
import logging
import math
import re
import typing
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml


class ConfigError(ValueError):
    """A configuration value that is missing, unknown or out of range."""


def _positive(v: float) -> str | None:
    return None if v > 0 else "must be > 0"


def _fraction(v: float) -> str | None:
    return None if 0.0 <= v <= 1.0 else "must be in [0, 1]"


def _non_negative(v: float) -> str | None:
    return None if v >= 0 else "must be >= 0"


def _at_least(n: int):
    return lambda v: None if v >= n else f"must be >= {n}"


def check(rule):
    """Field metadata attaching a validation rule (returns an error text or None)."""
    return {"check": rule}


def check_fields(section: Any, prefix: str = "") -> None:
    """Run the field rules of ``section`` (a dataclass built or changed in code); a
    ConfigError naming the first bad key, ``prefix`` before it (``whill.port: empty``)."""
    for f in dataclasses.fields(section):
        rule = f.metadata.get("check")
        value = getattr(section, f.name)
        problem = rule(value) if rule else None
        if problem:
            raise ConfigError(f"{prefix}{f.name}: {problem}, got {value!r}")


def _one_of(*choices: str):
    return check(
        lambda v: None if v in choices else f"must be one of {', '.join(map(repr, choices))}"
    )


@dataclass
class Footprint:
    """The chair's rectangle around the rear-axle point (the pose reference), metres."""

    width: float = field(default=0.65, metadata=check(_positive))
    rear: float = field(default=0.35, metadata=check(_non_negative))
    front: float = field(default=0.76, metadata=check(_positive))


@dataclass
class RobotConfig:
    """The one robot description every service uses (the seed had two footprints)."""

    name: str = "chair1"
    footprint: Footprint = field(default_factory=Footprint)
    max_speed: float = field(default=0.6, metadata=check(_positive))
    max_reverse_speed: float = field(default=0.25, metadata=check(_non_negative))
    max_turn_rate: float = field(default=1.0, metadata=check(_positive))
    max_accel: float = field(default=0.6, metadata=check(_positive))
    max_turn_accel: float = field(default=2.0, metadata=check(_positive))
    estop_decel: float = field(default=4.0, metadata=check(_positive))
    lidar_height_m: float = field(default=1.5, metadata=check(_positive))
    side_margin_m: float = field(default=0.05, metadata=check(_non_negative))

    @property
    def clearance_half_width_m(self) -> float:
        """Half the width of the strip the chair needs: its body plus ``side_margin_m`` a side.

        The controller's stop zone and the navigator's doorway lane check both use it.
        """
        return self.footprint.width / 2 + self.side_margin_m


def _ip_address(v: str) -> str | None:
    try:
        ipaddress.IPv4Address(v)
    except ValueError:
        return "must be an IPv4 address"
    return None


def _existing_dir(v: str) -> str | None:
    return None if not v or Path(v).is_dir() else "no such directory"


@dataclass
class SecurityConfig:
    """Secured fleet: `dir` is a `wheelnav security init` folder, "" insecure (docs/security.md)."""

    # with a folder, every session is mutual TLS plus user/password, each service joins as
    # the identity of its own name, and the router enforces the access control
    dir: str = field(default="", metadata=check(_existing_dir))


@dataclass
class TransportConfig:
    """How a service reaches the fleet: a Zenoh client of the router by default."""

    mode: str = field(
        default="client",
        metadata=check(
            lambda v: (
                None if v in ("client", "peer", "router") else "must be client, peer or router"
            )
        ),
    )
    connect: list[str] = field(default_factory=lambda: ["tcp/127.0.0.1:7447"])
    listen: list[str] = field(default_factory=list)
    security: SecurityConfig = field(default_factory=SecurityConfig)


@dataclass
class StartPose:
    """Where the chair starts: a named place of the site, or (when ``place`` is empty) a pose."""

    place: str = "room_a"
    x: float = 0.0
    y: float = 0.0
    theta: float = 0.0
    floor: str = ""


@dataclass
class PedestrianConfig:
    """A scripted pedestrian: a cylinder walking a closed loop of waypoints (one waypoint:
    standing there)."""

    waypoints: list[list[float]] = field(default_factory=list)
    speed: float = field(default=1.0, metadata=check(_positive))
    radius: float = field(default=0.25, metadata=check(_positive))
    floor: str = ""
    start_delay_s: float = field(default=0.0, metadata=check(_non_negative))


@dataclass
class KidnapConfig:
    """A kidnapping (issue 15): at the first tick from ``at_s`` on with the chair standing,
    the simulator moves it ``dx`` metres forwards and ``dy`` to its left (its own frame as
    it stands) and turns it by ``dtheta`` radians; its wheels do not feel it."""

    at_s: float = field(default=0.0, metadata=check(_non_negative))
    dx: float = 0.0
    dy: float = 0.0
    dtheta: float = 0.0


def _deflection(v: int) -> str | None:
    return None if -100 <= v <= 100 else "must be in -100..100"


@dataclass
class RiderConfig:
    """The rider takes the joystick (issue 16, on the hardware path only: the joystick is
    the emulated WHILL's): from ``at_s`` (the simulator's clock) for ``for_s`` seconds it
    is deflected ``front`` forwards and ``side`` to the right (-100..100, as the Model CR
    reports it), then let go. The driver hands the chair to the rider; the mission pauses."""

    at_s: float = field(default=0.0, metadata=check(_non_negative))
    for_s: float = field(default=1.0, metadata=check(_positive))
    front: int = field(default=0, metadata=check(_deflection))
    side: int = field(default=0, metadata=check(_deflection))


@dataclass
class SimConfig:
    """The headless pybullet simulator."""

    dt: float = field(default=0.02, metadata=check(_positive))
    seed: int = 0
    # the site the simulator builds its world from, where it differs from the map the
    # stack is given (the top-level ``site``): "" = the same; a door 10 cm off, a wall moved
    world_site: str = ""
    # on wall time (clock: wall) the chair's odom and scan are stamped as a driver would
    # stamp them, with this host's clock plus stamp_offset_s (a driver whose clock is that
    # far off: staleness must not depend on it); on simulation time, with the sim's clock.
    # On the hardware path the drivers stamp them: whill.stamp_offset_s, vlp16.stamp_offset_s
    stamp_offset_s: float = 0.0
    # the hardware path (docs/hardware.md): the chair behind an emulated WHILL on a pseudo
    # terminal linked at whill.port, the LiDAR's scans sent as VLP-16 packets over UDP to
    # vlp16_host:vlp16.port; the drivers take cmd_vel and publish odom and scan, not the
    # sim. Wall time only: clock wall, lockstep false, realtime_factor 1, lidar vlp16
    hardware_path: bool = False
    vlp16_host: str = field(default="127.0.0.1", metadata=check(_ip_address))
    lockstep: bool = True
    # the wall time the simulator waits for a live participant's answer: a bound for one
    # that is alive but hung (a crashed one, its liveliness token gone, is not waited for).
    # Longer than any step's compute on a loaded machine (a manoeuvre search that uses its
    # budget took about 4 s beside two busy loops): a run that goes on without an answer
    # no longer repeats (event lockstep_timeout)
    lockstep_timeout_s: float = field(default=30.0, metadata=check(_positive))
    lockstep_stages: list[list[str]] = field(
        default_factory=lambda: [
            ["localisation", "building", "mission"],
            ["controller"],
            ["navigator"],
        ]
    )
    start_after: list[str] = field(
        default_factory=lambda: ["localisation", "planner", "controller", "navigator", "building"]
    )
    start_wait_s: float = field(default=60.0, metadata=check(_non_negative))
    realtime_factor: float = field(default=1.0, metadata=check(_non_negative))
    # paced to the wall clock, a simulator further behind than this (a starved process)
    # lets the lost time go instead of running it in a burst the services cannot answer
    # (services/sim/pacing.py); shorter lags are caught up
    max_lag_s: float = field(default=0.1, metadata=check(_non_negative))
    watchdog_s: float = field(default=0.3, metadata=check(_positive))
    motor_lag_s: float = field(default=0.1, metadata=check(_non_negative))
    lidar: str = field(default="vlp16", metadata=_one_of("planar", "vlp16"))
    lidar_rate_hz: float = field(default=10.0, metadata=check(_positive))
    lidar_beams: int = field(default=360, metadata=check(_positive))
    lidar_fov_deg: float = field(default=270.0, metadata=check(_positive))
    lidar_range_m: float = field(default=12.0, metadata=check(_positive))
    lidar_noise_m: float = field(default=0.01, metadata=check(_non_negative))
    odom_scale_error: float = 0.01
    odom_turn_bias: float = 0.005
    odom_noise_v: float = field(default=0.01, metadata=check(_non_negative))
    odom_noise_w: float = field(default=0.01, metadata=check(_non_negative))
    caster_disturbance: float = field(default=0.05, metadata=check(_non_negative))
    status_rate_hz: float = field(default=10.0, metadata=check(_positive))
    start: StartPose = field(default_factory=StartPose)
    pedestrians: list[PedestrianConfig] = field(default_factory=list)
    kidnaps: list[KidnapConfig] = field(default_factory=list)
    riders: list[RiderConfig] = field(default_factory=list)


@dataclass
class PlannerConfig:
    """The route planner."""

    inflation_margin_m: float = field(default=0.05, metadata=check(_non_negative))
    # the search pays extra (Nav2-style, falling off from the inflation's edge) within
    # cost_band_m of it, so its path keeps to the middle of a gap; a shortcut of that path
    # keeps the chair's centre shortcut_margin_m further from obstacles than the inflation
    # does, where the search's path kept that far (pulled tight, a path through a 1.0 m
    # gap passed 0.354 m from a jamb and the controller's margins no longer fit)
    cost_band_m: float = field(default=0.3, metadata=check(_non_negative))
    shortcut_margin_m: float = field(default=0.15, metadata=check(_non_negative))
    cruise_speed: float = field(default=0.5, metadata=check(_positive))
    # a leg brakes from cruise_speed to 0 over this much at a constant deceleration
    # (1.0 m at 0.5 m/s: 0.125 m/s^2; 0.5 m saves the demo 1 s, but changed when the
    # pedestrian scenario's chair met the pedestrian: 5 cm from it, not 17)
    goal_speed_radius_m: float = field(default=1.0, metadata=check(_non_negative))
    waypoint_spacing_m: float = field(default=0.5, metadata=check(_positive))
    max_waypoints: int = field(default=50, metadata=check(_positive))
    landmarks: int = field(default=4, metadata=check(_non_negative))
    door_standoff_m: float = field(default=1.0, metadata=check(_positive))
    door_exit_m: float = field(default=1.2, metadata=check(_positive))
    # door poses: kept between the chair (and its stop zone at the exit) and what is around
    door_pose_margin_m: float = field(default=0.05, metadata=check(_non_negative))
    # before a manual leaf that opens towards it the chair waits behind the leaf's sweep
    # only where the strip there has this much more room a side (docking ends within
    # 0.15 m of a pose; squeezed between a table and a wall, it was never reached), or
    # a map cell more than it has beside the open leaf in the sweep (an 0.80 m door: 1.25
    # cm), else at door_standoff_m, in the sweep: a manual leaf moves only by hand
    door_leaf_wait_side_m: float = field(default=0.15, metadata=check(_non_negative))
    # legs to a door's or a lift's pose end with a straight run-in this long along it
    run_in_m: float = field(default=1.0, metadata=check(_non_negative))
    door_speed: float = field(default=0.2, metadata=check(_positive))
    door_slow_radius_m: float = field(default=1.5, metadata=check(_non_negative))
    elevator_standoff_m: float = field(default=1.5, metadata=check(_positive))
    elevator_ride_cost_m: float = field(default=10.0, metadata=check(_non_negative))
    # a door or lift marked unavailable (stuck, out of service) is tried again this long
    # after the mark, by the clock of the navigator's requests
    unavailable_retry_s: float = field(default=300.0, metadata=check(_positive))
    unknown_is_occupied: bool = True


@dataclass
class LocalisationConfig:
    """Where the chair is: ``map`` mode matches scans to the floor map, ``odometry`` does not."""

    mode: str = field(
        default="map",
        metadata=check(lambda v: None if v in ("map", "odometry") else "must be map or odometry"),
    )
    min_inlier_ratio: float = field(default=0.5, metadata=check(_positive))
    max_correction_m: float = field(default=0.5, metadata=check(_positive))
    max_correction_rad: float = field(default=0.3, metadata=check(_positive))
    lost_after_scans: int = field(default=5, metadata=check(_positive))
    # a scan below min_inlier_ratio that still has clutter_inlier_ratio of its points on
    # the map's walls and whose match moves the pose at most clutter_correction_m and
    # clutter_correction_rad is cluttered (what the map lacks hides the walls), not a miss:
    # it corrects the pose that little (those bounds grow by the drift below with what it
    # drove and turned on odometry alone since its last correction)
    clutter_inlier_ratio: float = field(default=0.25, metadata=check(_fraction))
    clutter_correction_m: float = field(default=0.05, metadata=check(_non_negative))
    clutter_correction_rad: float = field(default=0.035, metadata=check(_non_negative))
    match_cutoff_m: float = field(default=0.4, metadata=check(_positive))
    scan_band_m: float = field(default=0.5, metadata=check(_positive))
    rate_hz: float = field(default=50.0, metadata=check(_positive))
    # restarted by the launcher, it resumes from the pose it saved (every save_every_s of
    # its clock, with the odometry of then) if that save is at most resume_within_s old
    save_every_s: float = field(default=0.5, metadata=check(_positive))
    resume_within_s: float = field(default=30.0, metadata=check(_positive))
    # issue 15 (services/localisation/localiser.py): a scan of fewer points sees nothing to
    # match (a hall wider than twice the LiDAR's reach) and is no miss; the pose goes on on
    # odometry, and after reacquire_after_m of that the first scan seeing walls again is
    # matched by a search around it, drift_per_m (m) and drift_rad_per_m (rad) wider for
    # each metre so driven, and drift_rad_per_rad (rad) for each radian turned (wheel
    # odometry turns a few per cent short or long)
    min_scan_points: int = field(default=20, metadata=check(_positive))
    reacquire_after_m: float = field(default=0.5, metadata=check(_non_negative))
    drift_per_m: float = field(default=0.1, metadata=check(_non_negative))
    drift_rad_per_m: float = field(default=0.02, metadata=check(_non_negative))
    drift_rad_per_rad: float = field(default=0.05, metadata=check(_non_negative))
    # tracking (the last scan matched), a scan point first counts in the match within
    # track_gate_m plus that drift of a wall instead of match_cutoff_m, so a wall the
    # world has a little off the map does not pull the pose onto itself; 0 = off (the
    # default until the campaigns have been run with it)
    track_gate_m: float = field(default=0.0, metadata=check(_non_negative))
    # lost, the pose is searched for on every relocalise_every_scans-th scan, widening to
    # the whole floor, each search at most relocalise_budget evaluations (about 2 s on the
    # development machine); after relocalise_attempts failures it stays lost and says why
    relocalise: bool = True
    relocalise_every_scans: int = field(default=10, metadata=check(_positive))
    relocalise_attempts: int = field(default=5, metadata=check(_positive))
    relocalise_budget: int = field(default=500_000, metadata=check(_at_least(1000)))


@dataclass
class MPCConfig:
    """Sampling-MPC tuning (services/controller/mpc.py); costs are means over the horizon.

    Being means, the weights hold for any horizon length. Each ``w_*`` weight scales one
    cost term of the table in services/controller/mpc_costs.py, which says what it charges.
    Field checks run when the fleet config loads; ``validate`` runs them again for a config
    built in code and adds the rules between fields (the controller calls it).
    """

    # sampling: candidates per cycle, horizon, model step (s; the warm start is shifted by
    # the real loop period), noise (m/s, rad/s; wider in w on a cold start), its AR(1)
    # correlation from one step to the next
    samples: int = field(default=1000, metadata=check(_at_least(2)))
    steps: int = field(default=21, metadata=check(_positive))
    dt: float = field(default=0.2, metadata=check(_positive))
    sigma_v: float = field(default=0.10, metadata=check(_non_negative))
    sigma_w: float = field(default=0.08, metadata=check(_non_negative))
    sigma_w_cold: float = field(default=0.3, metadata=check(_non_negative))
    noise_corr: float = field(
        default=0.0, metadata=check(lambda v: None if 0.0 <= v < 1.0 else "must be in [0, 1)")
    )
    # guides: a share of the samples is drawn around pure-pursuit rollouts that steer to
    # the path point guide_lookahead_m ahead, one per lane (offsets left of the path, m)
    guide_fraction: float = field(default=0.1, metadata=check(_fraction))
    guide_lookahead_m: float = field(default=0.8, metadata=check(_positive))
    guide_offsets_m: list[float] = field(default_factory=lambda: [0.0, -0.4, 0.4, -0.8, 0.8])
    # selection: "mppi" (softmax-weighted mean; lower temperature trusts the best samples
    # more) or "cluster" (the seed's rule: the best top_fraction, mean of the cluster
    # within cluster_radius_m mean gap of the best)
    selection: str = field(default="mppi", metadata=_one_of("mppi", "cluster"))
    temperature: float = field(default=0.01, metadata=check(_positive))
    top_fraction: float = field(default=0.05, metadata=check(_fraction))
    cluster_radius_m: float = field(default=0.15, metadata=check(_non_negative))
    # cost weights (mpc_costs.TERMS) and the shape of their terms: tracking is squared up
    # to track_huber_m, linear beyond; progress_running of the progress shortfall is charged
    # at every step, the rest at the end; the speed window is [v_window_min, v_window_max]
    # (m/s); walls and LiDAR points cost nothing beyond their influence distances; the goal
    # term starts within goal_radius_m of the last waypoint
    w_track: float = field(default=10.0, metadata=check(_non_negative))
    track_huber_m: float = field(default=0.2, metadata=check(_non_negative))
    w_progress: float = field(default=1.0, metadata=check(_non_negative))
    progress_running: float = field(default=0.3, metadata=check(_fraction))
    w_heading: float = field(default=0.5, metadata=check(_non_negative))
    w_speed_ref: float = field(default=0.5, metadata=check(_non_negative))
    w_speed_window: float = field(default=10.0, metadata=check(_non_negative))
    v_window_min: float = -0.25
    v_window_max: float = 0.55
    w_turn: float = field(default=0.1, metadata=check(_non_negative))
    w_smooth: float = field(default=1.0, metadata=check(_non_negative))
    w_wall: float = field(default=1.0, metadata=check(_non_negative))
    wall_influence_m: float = field(default=0.3, metadata=check(_positive))
    w_obstacle: float = field(default=1.0, metadata=check(_non_negative))
    obstacle_influence_m: float = field(default=0.5, metadata=check(_positive))
    w_goal: float = field(default=1.0, metadata=check(_non_negative))
    goal_radius_m: float = field(default=1.5, metadata=check(_non_negative))
    # collision: a footprint closer than safety_margin_m to a wall or a point collides;
    # check points at most footprint_spacing_m apart; cell size of the per-cycle LiDAR field
    # (its readings are lowered by a cell diagonal: at 5 cm a 0.92 m gap was impassable)
    safety_margin_m: float = field(default=0.05, metadata=check(_non_negative))
    footprint_spacing_m: float = field(default=0.1, metadata=check(_positive))
    obstacle_resolution_m: float = field(default=0.025, metadata=check(_positive))
    # computation: "numba" (fast kernel) or "numpy" (vectorised reference); kernel threads
    # (0 = as many cores as the machine's load average leaves free, 1 on a busy machine;
    # results never depend on it); noise seed (same seed, same inputs: same commands)
    backend: str = field(default="numba", metadata=_one_of("numba", "numpy"))
    threads: int = field(default=0, metadata=check(_non_negative))
    seed: int = 0

    def validate(self) -> None:
        """Raise ConfigError (a ValueError) on a setting the controller cannot run with."""
        check_fields(self, "")
        if self.guide_fraction > 0 and not self.guide_offsets_m:
            raise ConfigError("guide_offsets_m: needs a lane when guide_fraction > 0")


@dataclass
class DoorScanConfig:
    """How doorways are found in one LiDAR scan (shared/door_scan.py; the smooth door pass
    steers by them). Defaults suit a VLP-16 and indoor walls."""

    # the planar scan: nearest return per azimuth bin (a VLP-16 turns 0.2 deg per
    # return), within the height band around the sensor (walls and jambs, not the floor)
    bin_deg: float = field(default=0.25, metadata=check(_positive))
    band_m: float = field(default=0.5, metadata=check(_positive))
    # the breakpoint detector: worst incidence angle on a surface, and range noise (it
    # adds three of it to a jump a beam can explain)
    breakpoint_angle_deg: float = field(default=10.0, metadata=check(_positive))
    range_sigma_m: float = field(default=0.01, metadata=check(_non_negative))
    # Iterative End-Point Fit splits a stretch at a return this far from its chord; a
    # stretch of wall has at least min_points returns and min_length_m
    split_m: float = field(default=0.03, metadata=check(_positive))
    min_points: int = field(default=5, metadata=check(_at_least(2)))
    min_length_m: float = field(default=0.15, metadata=check(_positive))
    # a doorway's free width lies in [min_width_m, max_width_m]
    min_width_m: float = field(default=0.6, metadata=check(_positive))
    max_width_m: float = field(default=1.6, metadata=check(_positive))
    # a return this near a wall's line is on it; the two stretches of one wall differ in
    # direction by at most parallel_deg
    on_line_m: float = field(default=0.04, metadata=check(_positive))
    parallel_deg: float = field(default=8.0, metadata=check(_positive))
    # returns within jamb_m of a jamb (its corner, the reveal behind it) are the jamb's; a
    # reveal's returns lie within reveal_m of its jamb's line; returns of one wall face
    # are closer together than step_m; a reveal is looked for up to max_depth_m deep
    jamb_m: float = field(default=0.1, metadata=check(_positive))
    reveal_m: float = field(default=0.02, metadata=check(_positive))
    step_m: float = field(default=0.06, metadata=check(_positive))
    max_depth_m: float = field(default=0.5, metadata=check(_positive))
    # a hinged leaf standing open shows at least leaf_min_m of its face, within leaf_deg
    # of the wall's normal, its nearer end at most leaf_reach_m from the wall's line (the
    # part by the hinge may be hidden or too edge-on to make a stretch); returns within
    # leaf_thickness_m of its face along the wall are the leaf's; leaf_side_m is its
    # thickness, added when only its outer face shows
    leaf_min_m: float = field(default=0.3, metadata=check(_positive))
    leaf_deg: float = field(default=15.0, metadata=check(_positive))
    leaf_reach_m: float = field(default=1.3, metadata=check(_positive))
    leaf_thickness_m: float = field(default=0.06, metadata=check(_positive))
    leaf_side_m: float = field(default=0.04, metadata=check(_non_negative))
    # beams crossing the wall's line this far inside a jamb must pass free (else the jamb
    # is the edge of a shadow, and the wall may go on behind what casts it)
    shadow_m: float = field(default=0.15, metadata=check(_positive))
    # sightings this near one another are one doorway (in a scan, and fused over scans)
    join_m: float = field(default=0.3, metadata=check(_positive))
    distinct_m: float = field(default=0.2, metadata=check(_positive))
    # fused over scans, a sighting counts by 1 / range^2 (nearer than near_m: as at
    # near_m): a jamb seen from afar is placed less well (beams spread, incidence grazes),
    # and the latest, nearest sightings share the frame the chair now steers in
    near_m: float = field(default=0.5, metadata=check(_positive))

    def __post_init__(self) -> None:
        if self.min_width_m > self.max_width_m:
            raise ConfigError("min_width_m: must not exceed max_width_m")


@dataclass
class ControllerConfig:
    """The path-tracking controller."""

    rate_hz: float = field(default=25.0, metadata=check(_positive))
    mode: str = field(default="mpc", metadata=_one_of("pursuit", "mpc"))
    obstacle_range_m: float = field(default=4.0, metadata=check(_positive))
    final_approach_m: float = field(default=0.5, metadata=check(_non_negative))
    lookahead_m: float = field(default=0.6, metadata=check(_positive))
    heading_gain: float = field(default=2.0, metadata=check(_positive))
    # on a precise pass (door, lift car) the turn rate is this gain times the angle to the
    # lookahead point, not pure pursuit's 2 v sin(a) / d (0.67 per rad at 0.2 m/s): a
    # caster's yaw kick at set-off is taken out before the nose reaches the jambs
    pass_heading_gain: float = field(default=3.0, metadata=check(_positive))
    goal_tolerance_m: float = field(default=0.15, metadata=check(_positive))
    start_align_deg: float = field(default=5.0, metadata=check(_positive))
    start_align_m: float = field(default=0.3, metadata=check(_non_negative))
    pose_timeout_s: float = field(default=0.5, metadata=check(_positive))
    scan_timeout_s: float = field(default=0.5, metadata=check(_positive))
    # stop zone beyond the footprint: stop_distance_m at robot.max_speed, shorter in
    # proportion when slower, never under stop_min_distance_m (controller/safety.py)
    stop_distance_m: float = field(default=0.25, metadata=check(_non_negative))
    stop_min_distance_m: float = field(default=0.05, metadata=check(_non_negative))
    # and never shorter than the braking distance (this long at the speed, one command
    # period and the motors' lag, then robot.max_accel) plus stop_min_distance_m; the
    # MPC's command may lead the measured speed by this lag's worth of acceleration too
    brake_latency_s: float = field(default=0.1, metadata=check(_non_negative))
    # the strip's margin a side of the chair in a precise pass or docking, instead of
    # robot.side_margin_m: an open leaf beside an 0.80 m door leaves 3-5 cm a side
    precise_side_margin_m: float = field(default=0.02, metadata=check(_non_negative))
    # in a smooth door pass that narrow margin holds only for points near the door: within
    # its width (an open leaf's length) plus precise_near_door_m of a jamb; anything else
    # keeps robot.side_margin_m (campaign b9103.m05: turning in the lead-in, 1.9 m from the
    # door, a front corner stopped 4.3 cm from a wall)
    precise_near_door_m: float = field(default=0.1, metadata=check(_non_negative))
    # the scan points those checks see are averaged per azimuth bin of guard_bin_deg (0:
    # every point as read), over the bin's nearest cluster (split where the ranges in order
    # jump by more than guard_gap_m, about three times the LiDAR's range noise): that noise
    # (1 cm in the simulator) read a jamb 4.1 cm away as 1.8 cm, inside the precise margin
    guard_bin_deg: float = field(default=0.5, metadata=check(_non_negative))
    guard_gap_m: float = field(default=0.03, metadata=check(_non_negative))
    # turning on the spot (slower than turn_check_below_mps): the footprint turned as far
    # as the chair turns in turn_check_s, at most turn_check_deg (and no further than a
    # docking turn has left, plus braking), must stay clear of scan points (a slow turn
    # was checked 15 degrees ahead and held beside an open leaf)
    turn_check_deg: float = field(default=15.0, metadata=check(_positive))
    turn_check_s: float = field(default=1.0, metadata=check(_positive))
    turn_check_below_mps: float = field(default=0.05, metadata=check(_non_negative))
    # an MPC leg whose distance to go has not shrunk by stall_progress_m for stall_s
    # (following all the while) reports "blocked", so the navigator's recoveries start
    stall_s: float = field(default=15.0, metadata=check(_non_negative))
    stall_progress_m: float = field(default=0.1, metadata=check(_positive))
    dock_tolerance_m: float = field(default=0.05, metadata=check(_positive))
    dock_heading_tolerance_deg: float = field(default=1.0, metadata=check(_positive))
    dock_speed: float = field(default=0.15, metadata=check(_positive))
    dock_turn_rate: float = field(default=0.5, metadata=check(_positive))
    dock_speed_gain: float = field(default=0.8, metadata=check(_positive))
    dock_turn_gain: float = field(default=2.0, metadata=check(_positive))
    dock_near_m: float = field(default=0.1, metadata=check(_positive))
    # before a door the error across the goal heading left after docking is taken out by
    # a sidestep (back up slantwise onto the line, drive along it) when over this: the
    # chair enters a doorway within 3 cm of its centre only from a pose near the line
    dock_lateral_tolerance_m: float = field(default=0.015, metadata=check(_positive))
    dock_reverse_reach_m: float = field(default=1.0, metadata=check(_non_negative))
    # a smooth door pass (navigator.door_procedure "smooth"): the speed is cut where the
    # Bézier's curvature asks more lateral acceleration than this; the curve ends on the
    # door's centre line this far before the approach line (aligned before the front
    # nears the door or its open leaf), or this far ahead of the chair once it is there
    smooth_lateral_accel: float = field(default=0.3, metadata=check(_positive))
    smooth_lookahead_m: float = field(default=0.5, metadata=check(_positive))
    # in the doorway (any of the chair within smooth_zone_m of the door plane) at most
    # smooth_gap_rate x the gap a side: the seed's 0.2 m/s at the paper's 0.80 m door and
    # 0.65 m chair (7.5 cm a side) is 2.67 /s, a 1.0 m door allows 0.47 m/s; a door of
    # unknown width is passed at smooth_doorway_speed; braking into it at smooth_decel
    smooth_gap_rate: float = field(default=2.67, metadata=check(_positive))
    smooth_doorway_speed: float = field(default=0.2, metadata=check(_positive))
    smooth_zone_m: float = field(default=0.3, metadata=check(_non_negative))
    smooth_decel: float = field(default=0.3, metadata=check(_positive))
    # a smooth pass turns at most at robot.max_turn_rate, and slowly enough to stop turning
    # at this (rad/s^2; under the chair's max_turn_accel: the motors lag) by a bend's end
    smooth_turn_accel: float = field(default=1.0, metadata=check(_positive))
    # a pass is not driven (stop-turn-go instead) where, followed from where the chair is,
    # it would bring a point of the footprint, within the jamb, more than
    # smooth_corner_excess_m beyond its half width off the door's line while the
    # footprint's centre is in the jamb, or nearer than smooth_outline_clearance_m to a
    # jamb while only its outline is (the campaign's limits: 3 cm short of the gap a side
    # while passing, 5 cm away from doors): handed over late, beside the door or facing
    # well off it, the chair would still be turning in the doorway. The jamb is taken as
    # smooth_jamb_depth_m either side of the door plane until the scan shows the reveal
    smooth_corner_excess_m: float = field(default=0.03, metadata=check(_non_negative))
    smooth_outline_clearance_m: float = field(default=0.05, metadata=check(_non_negative))
    smooth_jamb_depth_m: float = field(default=0.1, metadata=check(_non_negative))
    # until the controller's own scans show the doorway open the pass stops the front this
    # far before the door plane (the navigator verifies the door before its
    # smooth_commit_m; a navigator that died in between cannot send the chair into it)
    smooth_open_by_m: float = field(default=0.3, metadata=check(_non_negative))
    mpc: MPCConfig = field(default_factory=MPCConfig)
    door_scan: DoorScanConfig = field(default_factory=DoorScanConfig)


@dataclass
class DoorCheckConfig:
    """The LiDAR doorway checks (services/navigator/door_check.py)."""

    band_m: list[float] = field(  # [low, high] above the floor: the points looked at
        default_factory=lambda: [0.5, 1.7],
        metadata=check(
            lambda v: (
                None if len(v) == 2 and 0 <= v[0] < v[1] else "must be [low, high], 0 <= low < high"
            )
        ),
    )
    cone_deg: float = field(default=30.0, metadata=check(_positive))
    window_deg: float = field(default=4.0, metadata=check(_positive))
    margin_m: float = field(default=0.3, metadata=check(_non_negative))
    min_points: int = field(default=5, metadata=check(_positive))
    lane_margin_m: float = field(default=0.3, metadata=check(_non_negative))
    lane_min_points: int = field(default=3, metadata=check(_positive))
    # how far inside each jamb a point still counts as the jamb (or an open leaf's face,
    # which stands half the leaf's thickness inside the opening), allowing for pose error
    jamb_allowance_m: float = field(default=0.07, metadata=check(_non_negative))


@dataclass
class NavigatorConfig:
    """The mission behaviour tree."""

    rate_hz: float = field(default=10.0, metadata=check(_positive))
    plan_timeout_s: float = field(default=10.0, metadata=check(_positive))
    follow_timeout_s: float = field(default=600.0, metadata=check(_positive))
    door_timeout_s: float = field(default=60.0, metadata=check(_positive))
    lift_timeout_s: float = field(default=120.0, metadata=check(_positive))
    # a door's or a lift's state older than this (judged on arrival, on the navigator's
    # clock) counts as none: the building sends each at least every second
    # (building.state_rate_hz), so a silent building (a cut link) leaves no OPEN behind
    # and a door step waits and times out as when nobody answers (docs/building-bridge.md)
    building_state_max_age_s: float = field(default=5.0, metadata=check(_positive))
    # how a door is passed: "smooth" (issue 14: a manual door seen open from the leg
    # before it is passed without stopping, on a Bézier onto the door the scan shows;
    # stop-turn-go stays its fallback and the way for a closed door, an automatic or a
    # powered one) or "stop_turn_go" (the seed's: correct, turn, verify, pass at every
    # door, for comparison)
    door_procedure: str = field(default="smooth", metadata=_one_of("stop_turn_go", "smooth"))
    # smooth: the leg before the door hands over this far before its end, at speed; the
    # door must be seen open (building and LiDAR) before the chair's front is
    # smooth_commit_m before the door plane, or the chair stops and does stop-turn-go
    smooth_handover_m: float = field(default=1.5, metadata=check(_non_negative))
    # ... and only once the chair faces within this of the door's heading (facing away
    # there is no curve onto the door's line: the leg goes on turning the chair)
    smooth_handover_deg: float = field(default=60.0, metadata=check(_positive))
    smooth_commit_m: float = field(default=0.5, metadata=check(_non_negative))
    # smooth: held by the controller's safety stop this long before the door plane (the
    # curve swung a corner at an open leaf), the pass gives up for stop-turn-go at once
    # instead of waiting out the hold that starts a recovery
    smooth_hold_s: float = field(default=1.0, metadata=check(_positive))
    # while a mission holds a lift or a powered door it asked open, it asks again this
    # often (the building's sessions are leases, building.lift_session_lease_s and
    # building.door_session_lease_s); keep it well under those leases
    lease_renew_s: float = field(default=10.0, metadata=check(_positive))
    # restarted by the launcher, it takes up the mission it saved if that save is at most
    # this old (services/navigator/resume.py)
    resume_within_s: float = field(default=30.0, metadata=check(_positive))
    max_replans: int = field(default=3, metadata=check(_non_negative))
    safety_timeout_s: float = field(default=60.0, metadata=check(_positive))
    # recoveries: held (obstacle, blocked) this long, back up, turn in place, re-plan
    recovery_wait_s: float = field(default=8.0, metadata=check(_positive))
    max_recoveries: int = field(default=3, metadata=check(_non_negative))
    # held this far from where the recoveries so far began, the chair has got past that
    # place: the count starts again (a mission gives up after max_recoveries in one place,
    # and after max_recoveries * recovery_places in all)
    recovery_reset_m: float = field(default=1.5, metadata=check(_positive))
    recovery_places: int = field(default=3, metadata=check(_positive))
    backup_m: float = field(default=0.4, metadata=check(_positive))
    recovery_move_timeout_s: float = field(default=10.0, metadata=check(_positive))
    min_follow_speed: float = field(default=0.1, metadata=check(_positive))
    status_rate_hz: float = field(default=2.0, metadata=check(_positive))
    position_tolerance_m: float = field(default=0.15, metadata=check(_positive))
    heading_tolerance_deg: float = field(default=5.0, metadata=check(_positive))
    turn_tolerance_deg: float = field(default=2.0, metadata=check(_positive))
    correction_speed: float = field(default=0.15, metadata=check(_positive))
    correction_timeout_s: float = field(default=20.0, metadata=check(_positive))
    correction_attempts: int = field(default=3, metadata=check(_positive))
    correction_stall_s: float = field(default=4.0, metadata=check(_positive))
    correction_reach_m: float = field(default=1.0, metadata=check(_non_negative))
    # doors in series: a nearly straight leg from a door's exit to the next checkpoint no
    # longer than this is docked (turn, drive, turn), as one passage with both doors
    series_reach_m: float = field(default=2.5, metadata=check(_non_negative))
    # a leg docked instead of followed may need a manoeuvre in a tight room (turns where
    # the room allows, drives forwards and back): its Phase 0 limit allows this much more
    manoeuvre_allowance_s: float = field(default=25.0, metadata=check(_non_negative))
    idle_motion: bool = True
    idle_speed: float = field(default=0.05, metadata=check(_positive))
    idle_amplitude_m: float = field(default=0.12, metadata=check(_positive))
    door_scans: int = field(default=3, metadata=check(_positive))
    # stop-turn-go lines up on the door the scans show (a map or a pose a few cm off at an
    # 0.80 m door stops the pass at a jamb): once the door is seen open, an open doorway
    # within locate_reach_m of the mapped one, seen in most of locate_scans scans (or as
    # many as come in locate_timeout_s), moves the second alignment and the pass by its
    # offset along the wall when that is at least locate_min_shift_m
    locate_door: bool = True
    locate_reach_m: float = field(default=0.3, metadata=check(_positive))
    locate_scans: int = field(default=5, metadata=check(_positive))
    locate_min_shift_m: float = field(default=0.03, metadata=check(_non_negative))
    locate_timeout_s: float = field(default=2.0, metadata=check(_positive))
    pass_overrun_m: float = field(default=0.2, metadata=check(_non_negative))
    door_check: DoorCheckConfig = field(default_factory=DoorCheckConfig)


@dataclass
class DoorEvent:
    """A scheduled manual door action: at ``at_s`` seconds, ``open`` or ``close``."""

    at_s: float = field(default=0.0, metadata=check(_non_negative))
    action: str = field(default="open", metadata=_one_of("open", "close"))


@dataclass
class DoorBehaviour:
    """How the building emulator plays one door (scenarios set these per door id)."""

    # "" = as the site's door says (its ``motion`` key); set here to override it
    motion: str = field(default="", metadata=_one_of("", "hinged", "sliding"))
    start_open: bool = False
    schedule: list[DoorEvent] = field(default_factory=list)
    fault: str = field(
        default="", metadata=_one_of("", "stuck_closed", "stuck_half_open", "offline")
    )


@dataclass
class LiftBehaviour:
    """How the building emulator plays one lift."""

    start_floor: str = ""
    fault: str = field(default="", metadata=_one_of("", "out_of_service", "door_slow"))
    busy_until_s: float = field(default=0.0, metadata=check(_non_negative))


@dataclass
class BuildingConfig:
    """The building emulator: doors and lifts of the site, with per-id behaviours."""

    rate_hz: float = field(default=50.0, metadata=check(_positive))
    state_rate_hz: float = field(default=1.0, metadata=check(_positive))
    hold_open_s: float = field(default=5.0, metadata=check(_positive))
    sensor_range_m: float = field(default=1.5, metadata=check(_positive))
    # a lift session is a lease: it ends this long after its holder's last request (a
    # navigator renews it while it holds the lift; a dead one lets the lift go)
    lift_session_lease_s: float = field(default=30.0, metadata=check(_positive))
    # a powered door's open request is a lease too: the door closes (when its doorway is
    # clear) this long after the requester's last OPEN
    door_session_lease_s: float = field(default=30.0, metadata=check(_positive))
    manual_doors_open: bool = True  # a manual door with no schedule and no behaviour: open
    doors: dict[str, DoorBehaviour] = field(default_factory=dict)
    lifts: dict[str, LiftBehaviour] = field(default_factory=dict)

    def motion_of(self, door_id: str, site_motion: str) -> str:
        """How a door's leaf moves: the scenario's override, else the site's ``motion``."""
        b = self.doors.get(door_id)
        return b.motion if b is not None and b.motion else site_motion

    def starts_open(self, door_id: str, door_type: str) -> bool:
        """Whether a door starts open: its behaviour says so, or it is an unscripted manual one."""
        if door_id in self.doors:
            return self.doors[door_id].start_open
        return door_type == "manual" and self.manual_doors_open


def _endpoints(v: list[str]) -> str | None:
    bad = next((e for e in v if not re.fullmatch(r"[a-z0-9]+/\S+", e)), None)
    return None if bad is None else f"{bad!r} is not an endpoint such as tcp/192.168.1.20:7447"


def _identity(v: str) -> str | None:
    return None if re.fullmatch(r"[A-Za-z0-9_-]+", v) else "use letters, digits, '_' or '-'"


@dataclass
class LauncherConfig:
    """``wheelnav up``: the in-process router and the restart policy."""

    router_listen: str = "tcp/127.0.0.1:7447"
    # the routers of other hosts this host's router links to (a building server's or a
    # laptop's router to the chair's, e.g. tcp/192.168.1.20:7447); kept up, and made again
    # after a cut. Empty: this host's router only listens (the chair's)
    router_connect: list[str] = field(default_factory=list, metadata=check(_endpoints))
    # secured (transport.security.dir): whose credentials this host's router holds. The
    # chair's router is "router"; the router of another host links to it as a `wheelnav
    # security add NAME --role host` identity, allowed what the identities it carries may do
    router_identity: str = field(default="router", metadata=check(_identity))
    restart_backoff_s: float = field(default=0.5, metadata=check(_positive))
    restart_backoff_max_s: float = field(default=10.0, metadata=check(_positive))
    restart_reset_after_s: float = field(default=30.0, metadata=check(_positive))
    # how long `wheelnav up` and a mission wait for every service's liveliness token: a first
    # start on a fresh install compiles the numba kernels (24 s on an idle 2-core machine,
    # over 60 s beside a loaded CI run; `wheelnav warm` does it ahead)
    ready_timeout_s: float = field(default=120.0, metadata=check(_positive))
    # a mission run (`wheelnav mission`, the campaign, the benches) with the services as
    # threads of the runner on one Zenoh session instead of processes around a router
    # (wheelnav/launcher/in_process.py): the same messages and lockstep, so the same
    # report, with less time spent on messaging; no restarts. `wheelnav up` never does
    in_process: bool = False


# ---- the real chair's drivers (the hardware profile) ----------------------------------


def _sign(v: int) -> str | None:
    return None if v in (-1, 1) else "must be 1 or -1"


def _interval(v: int) -> str | None:
    # the chair accepts 10 ms and more; the SDK can tell time stamps apart below 100 ms
    return None if 10 <= v < 100 else "must be in [10, 100) ms"


def _percent(v: int) -> str | None:
    return None if 0 <= v <= 100 else "must be in [0, 100]"


@dataclass
class WhillConfig:
    """The WHILL Model CR base driver (services/whill_driver)."""

    port: str = field(default="/dev/ttyUSB0", metadata=check(lambda v: None if v else "empty"))
    # send SetPower on when the port opens (and when the chair stops sending)
    power_on: bool = True
    # data set 1 from the chair every data_interval_ms; odom and status to the fleet
    data_interval_ms: int = field(default=20, metadata=check(_interval))
    odom_rate_hz: float = field(default=50.0, metadata=check(_positive))
    status_rate_hz: float = field(default=2.0, metadata=check(_positive))
    # the contract: no cmd_vel for this long (receiver's clock) and the chair is stopped
    command_timeout_s: float = field(default=0.3, metadata=check(_positive))
    # no data set 1 for this long: the link is down (no odom published, stream restarted)
    data_timeout_s: float = field(default=0.5, metadata=check(_positive))
    reconnect_s: float = field(default=1.0, metadata=check(_positive))
    # the driver's clamp of cmd_vel, inside the chair's own range (-0.56..1.67 m/s, and
    # 0.83 m/s of wheel-speed difference); keep them >= robot.max_* or the chair is
    # slower than the controller plans (the node warns)
    max_speed: float = field(default=0.6, metadata=check(_positive))
    max_reverse_speed: float = field(default=0.25, metadata=check(_non_negative))
    max_turn_rate: float = field(default=1.0, metadata=check(_positive))
    # the chair's build (WHILL's figures for the Model CR)
    wheel_radius_m: float = field(default=0.1325, metadata=check(_positive))
    track_m: float = field(default=0.496, metadata=check(_positive))
    # for tests only (0 on a chair): the driver's stamps are its host's clock plus this, a
    # host whose clock is that far off (receivers judge staleness by arrival)
    stamp_offset_s: float = 0.0
    # which way each motor counts when the chair drives forwards (check at bring-up)
    left_wheel_sign: int = field(default=1, metadata=check(_sign))
    right_wheel_sign: int = field(default=-1, metadata=check(_sign))
    # the rider holds the joystick when it is deflected beyond this (of 100); the driver
    # hands the chair over and takes it back after joystick_release_s at rest
    joystick_deadband: int = field(default=5, metadata=check(_percent))
    joystick_release_s: float = field(default=1.0, metadata=check(_non_negative))

    def validate(self) -> None:
        """Run the field rules on a section built or changed in code; ConfigError naming
        the key (``whill.port: empty, got ''``)."""
        check_fields(self, "whill.")


def _port(v: int) -> str | None:
    return None if 0 <= v <= 65535 else "must be a UDP port in [0, 65535] (0: any free port)"


def _ipv4(v: str) -> str | None:
    return _ip_address(v) and "must be an IPv4 address (0.0.0.0: every interface)"


def _frame_name(v: str) -> str | None:
    return None if v.strip() and v == v.strip() else "must be a name without spaces around it"


@dataclass
class Vlp16Config:
    """The VLP-16 LiDAR driver (services/vlp16_driver): UDP packets in, ``scan`` out."""

    # where the sensor's data packets arrive: its data port (2368 unless reconfigured on the
    # sensor's web page) on the address of the interface it is wired to (0.0.0.0: any,
    # which also takes the sensor's default broadcast)
    port: int = field(default=2368, metadata=check(_port))
    bind_address: str = field(default="0.0.0.0", metadata=check(_ipv4))
    # the socket's receive buffer (the kernel caps it at net.core.rmem_max): room for the
    # packets of a few revolutions while the decoder is busy
    receive_buffer_bytes: int = field(default=4 << 20, metadata=check(_at_least(65536)))
    # the published PointCloud's frame, and the returns kept (m, from the laser)
    frame: str = field(default="lidar", metadata=check(_frame_name))
    min_range_m: float = field(default=0.4, metadata=check(_non_negative))
    max_range_m: float = field(default=100.0, metadata=check(_positive))
    # for tests only (0 on a chair): the scans' stamps are this host's clock plus this, a
    # host whose clock is that far off (receivers judge staleness by arrival)
    stamp_offset_s: float = 0.0

    def validate(self) -> None:
        """Raise ConfigError naming the key on a setting the driver cannot run with."""
        check_fields(self, "vlp16.")
        if self.min_range_m >= self.max_range_m:
            raise ConfigError(
                f"vlp16.min_range_m: must be < max_range_m ({self.max_range_m}), "
                f"got {self.min_range_m!r}"
            )


# ---- the building bridge to Open-RMF (the hardware profile) ----------------------------


def _ros_name_token(token: str) -> bool:
    return bool(token) and all(c.isascii() and (c.isalnum() or c == "_") for c in token)


def _ros_namespace(v: str) -> str | None:
    if v == "" or all(map(_ros_name_token, v.removeprefix("/").split("/"))):
        return None
    return "must be a ROS namespace such as building1 or /site/building1 (empty: none)"


def _ros_domain(v: int) -> str | None:
    return None if 0 <= v <= 232 else "must be a ROS domain id in [0, 232]"


def _one_to_one(v: dict[str, str]) -> str | None:
    seen: dict[str, str] = {}
    for ours, theirs in v.items():
        if not theirs:
            return f"{ours!r} maps to an empty name"
        if theirs in seen:
            return f"{seen[theirs]!r} and {ours!r} both map to {theirs!r}"
        seen[theirs] = ours
    return None


@dataclass
class RmfBridgeConfig:
    """The building bridge (services/rmf_bridge): doors and lifts of an Open-RMF building."""

    # how the building's ROS 2 topics are named on Zenoh: "ros2dds" as zenoh-bridge-ros2dds
    # routes them (<namespace>/<topic>), "rmw_zenoh" as ROS 2 nodes on rmw_zenoh_cpp
    # publish them (<domain_id>/<namespace>/<topic>/<type>/<type hash>); docs/building-bridge.md
    key_format: str = field(default="ros2dds", metadata=_one_of("ros2dds", "rmw_zenoh"))
    # the ROS namespace the building's topics carry on Zenoh (zenoh-bridge-ros2dds's
    # `namespace`, e.g. /building1; empty: none) and, for rmw_zenoh, its ROS_DOMAIN_ID
    namespace: str = field(default="", metadata=check(_ros_namespace))
    domain_id: int = field(default=0, metadata=check(_ros_domain))
    # with key_format rmw_zenoh, the attachment (sequence number, source timestamp, GID)
    # each request carries, as the building's rmw_zenoh_cpp release reads it: "positional"
    # (Humble 0.1.2+, Jazzy 0.2.4+, Kilted, Rolling 0.6.0+), "keyed" (Humble 0.1.0-0.1.1,
    # Jazzy 0.2.0-0.2.3), "none"; services/rmf_bridge/attachment.py, docs/building-bridge.md
    rmw_zenoh_attachment: str = field(
        default="positional", metadata=_one_of("positional", "keyed", "none")
    )
    # the building's names where they differ from the site's (site id -> Open-RMF name):
    # doors, lifts, and floors (the building's level names, in lift states and requests)
    door_names: dict[str, str] = field(default_factory=dict, metadata=check(_one_to_one))
    lift_names: dict[str, str] = field(default_factory=dict, metadata=check(_one_to_one))
    floor_names: dict[str, str] = field(default_factory=dict, metadata=check(_one_to_one))
    # how often the requests this chair holds are checked against their leases
    # (building.door_session_lease_s, building.lift_session_lease_s): an Open-RMF
    # supervisor keeps a session until it is ended, so the bridge ends a silent one
    lease_check_hz: float = field(default=1.0, metadata=check(_positive))

    def validate(self) -> None:
        """Run the field rules on a section built or changed in code; ConfigError naming
        the key (``rmf_bridge.domain_id: must be ...``)."""
        check_fields(self, "rmf_bridge.")


@dataclass
class FleetConfig:
    """The whole fleet's configuration."""

    site: str = "sites/two_rooms"
    clock: str = field(
        default="sim",
        metadata=check(lambda v: None if v in ("sim", "wall") else "must be sim or wall"),
    )
    robot: RobotConfig = field(default_factory=RobotConfig)
    transport: TransportConfig = field(default_factory=TransportConfig)
    sim: SimConfig = field(default_factory=SimConfig)
    planner: PlannerConfig = field(default_factory=PlannerConfig)
    localisation: LocalisationConfig = field(default_factory=LocalisationConfig)
    building: BuildingConfig = field(default_factory=BuildingConfig)
    controller: ControllerConfig = field(default_factory=ControllerConfig)
    navigator: NavigatorConfig = field(default_factory=NavigatorConfig)
    launcher: LauncherConfig = field(default_factory=LauncherConfig)
    whill: WhillConfig = field(default_factory=WhillConfig)
    vlp16: Vlp16Config = field(default_factory=Vlp16Config)
    rmf_bridge: RmfBridgeConfig = field(default_factory=RmfBridgeConfig)


# --------------------------------------------------------------------------------------
# Loading and validation
# --------------------------------------------------------------------------------------


# Keys that moved (old dotted key -> new), from the fleet config's root. A file or an
# override that still uses an old key works: its value moves to the new key before the
# checks, with one warning naming both. Giving both keys is an error (which one is meant?).
DEPRECATED_KEYS: dict[str, str] = {
    "controller.mpc_samples": "controller.mpc.samples",
    "controller.mpc_steps": "controller.mpc.steps",
    "controller.mpc_dt": "controller.mpc.dt",
    "controller.mpc_threads": "controller.mpc.threads",
    "controller.mpc_track_weight": "controller.mpc.w_track",
    "controller.mpc_safety_margin_m": "controller.mpc.safety_margin_m",
}

_log = logging.getLogger(__name__)
_ABSENT = object()


def upgrade_keys(data: dict[str, Any]) -> dict[str, Any]:
    """Plain fleet config ``data`` with every deprecated key moved to its new place."""
    for old, new in DEPRECATED_KEYS.items():
        old_keys, new_keys = old.split("."), new.split(".")
        value, section = _lookup(data, old_keys), _lookup(data, new_keys[:-1])
        if value is _ABSENT or (section is not _ABSENT and not isinstance(section, dict)):
            continue  # not used, or the new section is no mapping (from_dict will say so)
        if _lookup(data, new_keys) is not _ABSENT:
            raise ConfigError(f"{old}: deprecated and {new} is set too; keep only {new}")
        _log.warning("config key %s is deprecated: use %s (value moved there)", old, new)
        nested: Any = value
        for key in reversed(new_keys):
            nested = {key: nested}
        data = merge(_without(data, old_keys), nested)
    return data


def _lookup(data: Any, keys: list[str]) -> Any:
    for key in keys:
        if not isinstance(data, dict) or key not in data:
            return _ABSENT
        data = data[key]
    return data


def _without(data: dict[str, Any], keys: list[str]) -> dict[str, Any]:
    out = dict(data)
    if len(keys) == 1:
        del out[keys[0]]
    else:
        out[keys[0]] = _without(out[keys[0]], keys[1:])
    return out


def from_dict(cls: type, data: Any, path: str = "") -> Any:
    """Build dataclass ``cls`` from plain data, naming the first bad key in a ConfigError.

    For the fleet config, deprecated keys are moved first (``DEPRECATED_KEYS``).
    """
    where = path or "config"
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise ConfigError(f"{where}: expected a mapping, got {type(data).__name__}")
    if cls is FleetConfig and not path:
        data = upgrade_keys(data)
    fields = {f.name: f for f in dataclasses.fields(cls)}
    for key in data:
        if key not in fields:
            raise ConfigError(f"{_join(path, key)}: unknown key (known: {', '.join(fields)})")
    hints = typing.get_type_hints(cls)
    values = {}
    for name, value in data.items():
        dotted = _join(path, name)
        values[name] = _convert(hints[name], value, dotted)
        rule = fields[name].metadata.get("check")
        problem = rule(values[name]) if rule else None
        if problem:
            raise ConfigError(f"{dotted}: {problem}, got {value!r}")
    return cls(**values)


def _join(path: str, key: Any) -> str:
    return f"{path}.{key}" if path else str(key)


def _convert(hint: Any, value: Any, path: str) -> Any:
    if dataclasses.is_dataclass(hint):
        return from_dict(hint, value, path)
    if hint is float:
        if (
            isinstance(value, bool)
            or not isinstance(value, int | float)
            or not math.isfinite(value)
        ):
            raise ConfigError(f"{path}: expected a finite number, got {value!r}")
        return float(value)
    if hint is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise ConfigError(f"{path}: expected an integer, got {value!r}")
        return value
    if hint is bool:
        if not isinstance(value, bool):
            raise ConfigError(f"{path}: expected true or false, got {value!r}")
        return value
    if hint is str:
        if not isinstance(value, str):
            raise ConfigError(f"{path}: expected text, got {value!r}")
        return value
    if typing.get_origin(hint) is list:
        if not isinstance(value, list):
            raise ConfigError(f"{path}: expected a list, got {value!r}")
        (item,) = typing.get_args(hint)
        return [_convert(item, v, f"{path}[{i}]") for i, v in enumerate(value)]
    if typing.get_origin(hint) is dict:
        if not isinstance(value, dict):
            raise ConfigError(f"{path}: expected a mapping, got {value!r}")
        _key, item = typing.get_args(hint)
        return {str(k): _convert(item, v, f"{path}.{k}") for k, v in value.items()}
    raise ConfigError(f"{path}: unsupported type {hint!r}")


def to_dict(cfg: Any) -> dict[str, Any]:
    """Plain data of a config dataclass (for writing YAML)."""
    return dataclasses.asdict(cfg)


def parse_override(text: str) -> tuple[list[str], Any]:
    """Parse ``a.b.c=value`` (value in YAML syntax) into a key path and a value."""
    if "=" not in text:
        raise ConfigError(f"override {text!r}: expected KEY=VALUE, e.g. sim.seed=3")
    key, raw = text.split("=", 1)
    if not raw.strip():
        return key.strip().split("."), ""  # `--set sim.start.place=` clears a text value
    try:
        value = yaml.safe_load(raw)
    except yaml.YAMLError as exc:
        raise ConfigError(f"override {text!r}: bad value ({exc.problem})") from None
    return key.strip().split("."), value


def merge(base: dict[str, Any], update: dict[str, Any]) -> dict[str, Any]:
    """Deep-merge ``update`` into a copy of ``base``."""
    out = dict(base)
    for key, value in update.items():
        if isinstance(value, dict) and isinstance(out.get(key), dict):
            out[key] = merge(out[key], value)
        else:
            out[key] = value
    return out


def read_yaml(path: str | Path) -> dict[str, Any]:
    """Read a YAML mapping, with one-line errors for a missing or malformed file."""
    path = Path(path)
    if not path.is_file():
        raise ConfigError(f"{path}: no such file")
    try:
        data = yaml.safe_load(path.read_text())
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" line {mark.line + 1}" if mark else ""
        raise ConfigError(
            f"{path}{where}: not valid YAML ({getattr(exc, 'problem', exc)})"
        ) from None
    if data is None:
        return {}
    if not isinstance(data, dict):
        raise ConfigError(f"{path}: expected a mapping at the top level")
    return data


def apply_overrides(data: dict[str, Any], overrides: list[str]) -> dict[str, Any]:
    """``data`` with each ``KEY=VALUE`` override merged in."""
    for text in overrides:
        keys, value = parse_override(text)
        nested: dict[str, Any] = {keys[-1]: value}
        for key in reversed(keys[:-1]):
            nested = {key: nested}
        data = merge(data, nested)
    return data


def load(path: str | Path | None = None, overrides: list[str] = ()) -> FleetConfig:
    """Load the fleet config from ``path`` (defaults if None), then apply overrides."""
    data = read_yaml(path) if path else {}
    return from_dict(FleetConfig, apply_overrides(data, list(overrides)))


def describe(cls: type = FleetConfig, prefix: str = "") -> list[tuple[str, str, str]]:
    """(dotted key, type, default) for every leaf of the config, for docs/configuration.md."""
    rows = []
    hints = typing.get_type_hints(cls)
    defaults = cls()
    for f in dataclasses.fields(cls):
        dotted = f"{prefix}{f.name}"
        hint = hints[f.name]
        if dataclasses.is_dataclass(hint):
            rows.append((dotted, "section", hint.__doc__.strip().splitlines()[0]))
            rows += describe(hint, dotted + ".")
        else:
            name = (
                getattr(hint, "__name__", str(hint))
                if typing.get_origin(hint) is None
                else str(hint)
            )
            rows.append((dotted, name, repr(getattr(defaults, f.name))))
    return rows


def markdown_table() -> str:
    """The key table of docs/configuration.md (a test keeps the two equal)."""
    lines = ["| key | type | default |", "|---|---|---|"]
    for key, kind, default in describe():
        if kind == "section":
            lines.append(f"| **{key}** | | {default} |")
        else:
            lines.append(f"| `{key}` | {kind} | `{default}` |")
    return "\n".join(lines)
