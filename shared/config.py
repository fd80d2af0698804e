"""Fleet configuration: every default in one place, loaded from YAML and checked.

One YAML file configures the whole fleet; each service reads its own section plus
``robot`` and ``transport``. Unknown keys, wrong types and out-of-range values fail with
one line naming the dotted path, e.g. ``controller.lookahead_m: must be > 0, got -0.2``.
"""

from __future__ import annotations

import dataclasses
import math
import typing
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml


class ConfigError(ValueError):
    """A configuration value that is missing, unknown or out of range."""


def _positive(v: float) -> str | None:
    return None if v > 0 else "must be > 0"


def _non_negative(v: float) -> str | None:
    return None if v >= 0 else "must be >= 0"


def check(rule):
    """Field metadata attaching a validation rule (returns an error text or None)."""
    return {"check": rule}


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
    """A scripted pedestrian: a cylinder walking a closed loop of waypoints."""

    waypoints: list[list[float]] = field(default_factory=list)
    speed: float = field(default=1.0, metadata=check(_positive))
    radius: float = field(default=0.25, metadata=check(_positive))
    floor: str = ""
    start_delay_s: float = field(default=0.0, metadata=check(_non_negative))


@dataclass
class SimConfig:
    """The headless pybullet simulator."""

    dt: float = field(default=0.02, metadata=check(_positive))
    seed: int = 0
    lockstep: bool = True
    lockstep_timeout_s: float = field(default=5.0, metadata=check(_positive))
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


@dataclass
class PlannerConfig:
    """The route planner."""

    inflation_margin_m: float = field(default=0.05, metadata=check(_non_negative))
    cost_band_m: float = field(default=0.0, metadata=check(_non_negative))
    cruise_speed: float = field(default=0.5, metadata=check(_positive))
    goal_speed_radius_m: float = field(default=1.0, metadata=check(_non_negative))
    waypoint_spacing_m: float = field(default=0.5, metadata=check(_positive))
    max_waypoints: int = field(default=50, metadata=check(_positive))
    landmarks: int = field(default=4, metadata=check(_non_negative))
    door_standoff_m: float = field(default=1.0, metadata=check(_positive))
    door_exit_m: float = field(default=1.2, metadata=check(_positive))
    door_speed: float = field(default=0.2, metadata=check(_positive))
    door_slow_radius_m: float = field(default=1.5, metadata=check(_non_negative))
    elevator_standoff_m: float = field(default=1.5, metadata=check(_positive))
    elevator_ride_cost_m: float = field(default=10.0, metadata=check(_non_negative))
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
    match_cutoff_m: float = field(default=0.4, metadata=check(_positive))
    scan_band_m: float = field(default=0.5, metadata=check(_positive))


@dataclass
class ControllerConfig:
    """The path-tracking controller."""

    rate_hz: float = field(default=25.0, metadata=check(_positive))
    mode: str = field(default="mpc", metadata=_one_of("pursuit", "mpc"))
    mpc_samples: int = field(default=1000, metadata=check(_positive))
    mpc_steps: int = field(default=21, metadata=check(_positive))
    mpc_dt: float = field(default=0.2, metadata=check(_positive))
    mpc_threads: int = field(default=1, metadata=check(_non_negative))
    mpc_track_weight: float = field(default=10.0, metadata=check(_non_negative))
    mpc_safety_margin_m: float = field(default=0.05, metadata=check(_non_negative))
    obstacle_range_m: float = field(default=4.0, metadata=check(_positive))
    final_approach_m: float = field(default=0.5, metadata=check(_non_negative))
    lookahead_m: float = field(default=0.6, metadata=check(_positive))
    heading_gain: float = field(default=2.0, metadata=check(_positive))
    goal_tolerance_m: float = field(default=0.15, metadata=check(_positive))
    start_align_deg: float = field(default=5.0, metadata=check(_positive))
    start_align_m: float = field(default=0.3, metadata=check(_non_negative))
    pose_timeout_s: float = field(default=0.5, metadata=check(_positive))
    scan_timeout_s: float = field(default=0.5, metadata=check(_positive))
    stop_distance_m: float = field(default=0.25, metadata=check(_non_negative))
    dock_tolerance_m: float = field(default=0.05, metadata=check(_positive))
    dock_heading_tolerance_deg: float = field(default=1.0, metadata=check(_positive))
    dock_speed: float = field(default=0.15, metadata=check(_positive))
    dock_turn_rate: float = field(default=0.5, metadata=check(_positive))


@dataclass
class NavigatorConfig:
    """The mission behaviour tree."""

    rate_hz: float = field(default=10.0, metadata=check(_positive))
    plan_timeout_s: float = field(default=10.0, metadata=check(_positive))
    follow_timeout_s: float = field(default=600.0, metadata=check(_positive))
    door_timeout_s: float = field(default=60.0, metadata=check(_positive))
    lift_timeout_s: float = field(default=120.0, metadata=check(_positive))
    max_replans: int = field(default=3, metadata=check(_non_negative))
    safety_timeout_s: float = field(default=60.0, metadata=check(_positive))
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
    idle_motion: bool = True
    idle_speed: float = field(default=0.05, metadata=check(_positive))
    idle_amplitude_m: float = field(default=0.12, metadata=check(_positive))
    door_scans: int = field(default=3, metadata=check(_positive))
    pass_overrun_m: float = field(default=0.2, metadata=check(_non_negative))


@dataclass
class DoorEvent:
    """A scheduled manual door action: at ``at_s`` seconds, ``open`` or ``close``."""

    at_s: float = field(default=0.0, metadata=check(_non_negative))
    action: str = field(default="open", metadata=_one_of("open", "close"))


@dataclass
class DoorBehaviour:
    """How the building emulator plays one door (scenarios set these per door id)."""

    motion: str = field(default="sliding", metadata=_one_of("hinged", "sliding"))
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
    manual_doors_open: bool = True  # a manual door with no schedule and no behaviour: open
    doors: dict[str, DoorBehaviour] = field(default_factory=dict)
    lifts: dict[str, LiftBehaviour] = field(default_factory=dict)

    def starts_open(self, door_id: str, door_type: str) -> bool:
        """Whether a door starts open: its behaviour says so, or it is an unscripted manual one."""
        if door_id in self.doors:
            return self.doors[door_id].start_open
        return door_type == "manual" and self.manual_doors_open


@dataclass
class LauncherConfig:
    """``wheelnav up``: the in-process router and the restart policy."""

    router_listen: str = "tcp/127.0.0.1:7447"
    restart_backoff_s: float = field(default=0.5, metadata=check(_positive))
    restart_backoff_max_s: float = field(default=10.0, metadata=check(_positive))
    restart_reset_after_s: float = field(default=30.0, metadata=check(_positive))
    ready_timeout_s: float = field(default=60.0, metadata=check(_positive))


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


# --------------------------------------------------------------------------------------
# Loading and validation
# --------------------------------------------------------------------------------------


def from_dict(cls: type, data: Any, path: str = "") -> Any:
    """Build dataclass ``cls`` from plain data, naming the first bad key in a ConfigError."""
    where = path or "config"
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise ConfigError(f"{where}: expected a mapping, got {type(data).__name__}")
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
