"""Mission scenarios, without processes or Zenoh.

:func:`load_scenario` reads a scenario YAML (docs/scenarios.md) into the fleet config it
implies (the report of a run is :mod:`wheelnav.mission.report`).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

from shared import config as config_mod
from shared.config import ConfigError, FleetConfig
from shared.messages import Pose2D
from shared.site import load_site

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
    "expect_reason",
    "kind",
    "world_site",
}


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
    expect_reason: str = ""  # a regex the failure's reason must match (case-insensitive)
    kind: str = ""  # what the mission tests (a campaign's mission kind), free text


def _resolved(scenario: Path, site: str) -> Path:
    """A site path of the scenario, relative ones taken from its folder."""
    p = Path(site)
    return p if p.is_absolute() else (scenario.parent / p).resolve()


def load_scenario(path: str | Path, overrides: list[str] = ()) -> Scenario:
    """Read a scenario; relative site paths are taken from the scenario's folder.
    ``world_site`` (optional): the site the simulator builds its world from, where the
    world differs from the map the stack is given (``site``)."""
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
    site = _resolved(path, data["site"])
    world = _resolved(path, data["world_site"]) if data.get("world_site") else None
    fleet = config_mod.merge(
        data.get("config") or {},
        {
            "site": str(site),
            "sim": {
                **({"world_site": str(world)} if world else {}),
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
    expect_reason = str(data.get("expect_reason", ""))
    try:
        re.compile(expect_reason)
    except re.error as exc:
        raise ConfigError(f"{path}: expect_reason: not a regular expression ({exc})") from None
    for one in (site, world) if world else (site,):
        load_site(one)  # a missing or malformed site fails here, in one line, not in 5 services
    name = str(data.get("name", path.stem))
    return Scenario(
        name, cfg, goal, place, float(limit), path, expect, expect_reason, str(data.get("kind", ""))
    )
