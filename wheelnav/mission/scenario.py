"""Mission scenarios and reports, without processes or Zenoh.

:func:`load_scenario` reads a scenario YAML (docs/scenarios.md) into the fleet config it
implies; :class:`Recorder` turns the stream of statuses a run produces into the report.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from shared import config as config_mod
from shared.config import ConfigError, FleetConfig
from shared.geometry import wrap_angle
from shared.messages import NavStatus, Pose2D, SimStatus
from shared.site import load_site
from wheelnav.mission.checkpoints import CheckpointLog, PoseHistory

SCENARIO_KEYS = {
    "name",
    "site",
    "seed",
    "time_limit_s",
    "start",
    "goal",
    "config",
    "description",
    "expect",
}
TERMINAL = ("succeeded", "failed", "cancelled")


@dataclass
class Scenario:
    """A mission to run: the fleet config, the goal and the time limit."""

    name: str
    config: FleetConfig
    goal: Pose2D | None
    place: str
    time_limit_s: float
    path: Path
    expect: str = "success"  # or "failure": the scenario shows a safe stop


def load_scenario(path: str | Path, overrides: list[str] = ()) -> Scenario:
    """Read a scenario; relative site paths are taken from the scenario's folder."""
    path = Path(path)
    data = config_mod.read_yaml(path)
    unknown = sorted(set(data) - SCENARIO_KEYS)
    if unknown:
        raise ConfigError(
            f"{path}: unknown key {unknown[0]!r} (known: {', '.join(sorted(SCENARIO_KEYS))})"
        )
    for key in ("site", "start", "goal"):
        if key not in data:
            raise ConfigError(f"{path}: missing key {key!r}")
    start = data["start"]
    if isinstance(start, dict) and "place" not in start:
        start = {**start, "place": ""}  # a pose given: it replaces the default start place
    site = Path(data["site"])
    if not site.is_absolute():
        site = (path.parent / site).resolve()
    fleet = config_mod.merge(
        data.get("config") or {},
        {
            "site": str(site),
            "sim": {
                "start": start,
                "seed": data.get("seed", 0),
                "realtime_factor": 0.0,
                "start_after": [
                    "localisation",
                    "planner",
                    "controller",
                    "navigator",
                    "building",
                    "mission",
                ],
            },
        },
    )
    cfg = config_mod.from_dict(FleetConfig, config_mod.apply_overrides(fleet, list(overrides)))
    goal_data = data["goal"]
    if not isinstance(goal_data, dict):
        raise ConfigError(f"{path}: goal: expected {{place: NAME}} or {{x, y, theta, floor}}")
    place = str(goal_data.get("place", ""))
    goal = None
    if not place:
        try:
            goal = Pose2D(
                float(goal_data["x"]),
                float(goal_data["y"]),
                float(goal_data.get("theta", 0.0)),
                str(goal_data.get("floor", "")),
            )
        except (KeyError, TypeError, ValueError):
            raise ConfigError(
                f"{path}: goal: expected {{place: NAME}} or {{x, y, theta, floor}}"
            ) from None
    limit = data.get("time_limit_s", 300.0)
    if not isinstance(limit, int | float) or limit <= 0:
        raise ConfigError(f"{path}: time_limit_s: must be > 0, got {limit!r}")
    expect = data.get("expect", "success")
    if expect not in ("success", "failure"):
        raise ConfigError(f"{path}: expect: must be success or failure, got {expect!r}")
    load_site(site)  # a missing or malformed site fails here, in one line, not in 5 services
    name = str(data.get("name", path.stem))
    return Scenario(name, cfg, goal, place, float(limit), path, expect)


@dataclass
class Phase:
    name: str
    start_s: float
    end_s: float | None = None


@dataclass
class Recorder:
    """Collects what a run shows into the mission report."""

    goal_id: str
    state: str = "pending"
    reason: str = ""
    sim_time_s: float = 0.0
    collisions: int = 0
    min_clearance_m: float = math.inf
    path_length_m: float = 0.0
    phases: list[Phase] = field(default_factory=list)
    events: list[dict[str, Any]] = field(default_factory=list)
    _last_xy: tuple[float, float] | None = None
    _truth: PoseHistory = field(default_factory=PoseHistory)
    _loc_sq: list[tuple[float, float]] = field(default_factory=list)
    _track_sq: list[float] = field(default_factory=list)
    checkpoints: CheckpointLog = field(default_factory=CheckpointLog)

    @property
    def finished(self) -> bool:
        return self.state in TERMINAL or self.state == "timeout"

    def on_status(self, msg: NavStatus) -> None:
        if msg.goal_id != self.goal_id or self.finished:
            return
        phase = msg.phase if msg.state == "running" else ""
        current = self.phases[-1] if self.phases and self.phases[-1].end_s is None else None
        if phase and (current is None or current.name != phase):
            if current is not None:
                current.end_s = msg.stamp
            self.phases.append(Phase(phase, msg.stamp))
        if msg.state in TERMINAL:
            if current is not None:
                current.end_s = msg.stamp
            self.state, self.reason, self.sim_time_s = msg.state, msg.reason, msg.stamp
        elif self.state == "pending":
            self.state = "running"

    def on_sim_status(self, msg: SimStatus) -> None:
        if self.finished:
            return  # the report covers the mission, not the shutdown after it
        self.collisions = max(self.collisions, msg.collisions)
        self.min_clearance_m = min(self.min_clearance_m, msg.min_clearance_m)

    def on_truth(self, x: float, y: float, theta: float = 0.0, stamp: float | None = None) -> None:
        if self.finished:
            return
        if stamp is not None:
            self._truth.add(stamp, (x, y, theta))
        if self._last_xy is not None:
            self.path_length_m += math.hypot(x - self._last_xy[0], y - self._last_xy[1])
        self._last_xy = (x, y)

    def on_pose(self, stamp: float, x: float, y: float, theta: float) -> None:
        """A pose estimate: compared with the ground truth of the same tick."""
        truth = self._truth.at(stamp)
        if truth is None or self.finished:
            return
        dth = wrap_angle(theta - truth[2])
        self._loc_sq.append(((x - truth[0]) ** 2 + (y - truth[1]) ** 2, dth**2))

    def on_follow(self, state: str, cross_track: float, precise: bool) -> None:
        """The controller's cross-track error while following a leg (not door passes)."""
        if state == "following" and not precise and not self.finished:
            self._track_sq.append(cross_track**2)

    def localisation_error(self) -> dict[str, float | None]:
        """RMS and max position error (m) and RMS heading error (deg) of the pose estimates."""
        if not self._loc_sq:
            return {"rms_m": None, "max_m": None, "rms_deg": None, "samples": 0}
        sq = np.asarray(self._loc_sq)
        return {
            "rms_m": round(float(np.sqrt(sq[:, 0].mean())), 4),
            "max_m": round(float(np.sqrt(sq[:, 0].max())), 4),
            "rms_deg": round(float(np.degrees(np.sqrt(sq[:, 1].mean()))), 3),
            "samples": len(sq),
        }

    def on_time(self, stamp: float, limit_s: float) -> None:
        if self.finished:
            return
        self.sim_time_s = stamp
        if stamp >= limit_s and not self.finished:
            self.state = "timeout"
            self.reason = f"time limit of {limit_s:g} s reached"
            for phase in self.phases:
                phase.end_s = phase.end_s if phase.end_s is not None else stamp

    def report(self, scenario: str, wall_time_s: float) -> dict[str, Any]:
        success = self.state == "succeeded" and self.collisions == 0
        reason = self.reason or self.state
        if self.state == "succeeded" and self.collisions:
            reason = f"arrived, but with {self.collisions} collision(s)"
        return {
            "scenario": scenario,
            "success": success,
            "reason": reason,
            "state": self.state,
            "collisions": self.collisions,
            "min_clearance_m": round(self.min_clearance_m, 4)
            if math.isfinite(self.min_clearance_m)
            else None,
            "sim_time_s": round(self.sim_time_s, 3),
            "wall_time_s": round(wall_time_s, 3),
            "path_length_m": round(self.path_length_m, 3),
            "localisation_error": self.localisation_error(),
            "cross_track_rms_m": round(float(np.sqrt(np.mean(self._track_sq))), 4)
            if self._track_sq
            else None,
            "checkpoints": self.checkpoints.rows(self.sim_time_s),
            "fallbacks": [e["detail"] for e in self.events if e["kind"] == "fallback"],
            "phases": [
                {
                    "name": p.name,
                    "start_s": round(p.start_s, 3),
                    "end_s": None if p.end_s is None else round(p.end_s, 3),
                }
                for p in self.phases
            ],
            "events": self.events,
        }
