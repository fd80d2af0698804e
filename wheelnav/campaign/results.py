"""One campaign mission's result row, judged against what its building's generator expected.

A row is written as soon as its mission ends (one JSON file per mission), so a stopped
campaign resumes where it stopped and never runs, drops or relabels a mission twice.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path
from typing import Any

from wheelnav.mission.scenario import Scenario

CRUISE_SPEED_M_S = 0.5  # the ideal time is the planned length at this speed (issue 13)
AWAY_CLEARANCE_M = 0.05  # min clearance away from door openings
DOOR_SLACK_M = 0.03  # inside an opening: (free width - chair width) / 2 less this


def door_requirement_m(width_m: float, chair_width_m: float, entered: bool = True) -> float:
    """The least clearance accepted inside an opening ``width_m`` wide (its clear width:
    a hinged leaf standing open takes half its thickness from it) while the chair's centre
    stands in its doorway. While only the chair's outline is in it (``entered`` False:
    approaching it, or turning beside a door it does not pass) the chair is away from
    openings, and the limit away from doors holds, or the opening's own where that is
    less (a front already in a narrow door is centred in it, not 5 cm from its jambs)."""
    inside = (width_m - chair_width_m) / 2 - DOOR_SLACK_M
    return inside if entered else min(AWAY_CLEARANCE_M, inside)


def _judge_door(d: dict[str, Any], chair_w: float) -> dict[str, Any]:
    """A report's door entry with its limits: while passing it (``required_m``) and while
    only the outline was in it (``outline_required_m``)."""
    free = d.get("free_width_m") or d["width_m"]
    return {
        **d,
        "required_m": round(door_requirement_m(free, chair_w, d.get("entered", True)), 4),
        "outline_required_m": round(door_requirement_m(free, chair_w, False), 4),
    }


def _below(d: dict[str, Any], value: str, limit: str) -> bool:
    return d.get(value) is not None and d[value] < d[limit]


def judge(scenario: Scenario, report: dict[str, Any]) -> dict[str, Any]:
    """The row for one run: outcome against expectation, clearances against the limits."""
    chair_w = scenario.config.robot.footprint.width
    expected = scenario.expect
    outcome = "success" if report["success"] else report.get("state", "failed")
    reason = report.get("reason", "")
    if expected == "success":
        as_expected = bool(report["success"])
    else:
        matches = not scenario.expect_reason or bool(
            re.search(scenario.expect_reason, reason, re.IGNORECASE)
        )
        as_expected = not report["success"] and report.get("state") == "failed" and matches
    as_expected = as_expected and report.get("collisions", 0) == 0
    doors = [_judge_door(d, chair_w) for d in report.get("door_clearance", [])]
    tight_doors = [d["door"] for d in doors if _below(d, "min_clearance_m", "required_m")]
    tight_doors += [
        d["door"]
        for d in doors
        if d["door"] not in tight_doors and _below(d, "outline_clearance_m", "outline_required_m")
    ]
    away = report.get("min_clearance_away_m")
    planned = report.get("first_planned_length_m") or report.get("planned_length_m")
    ratio = None
    if report["success"] and planned:
        ratio = round(report["sim_time_s"] / (planned / CRUISE_SPEED_M_S), 3)
    return {
        "mission": scenario.name,
        "kind": scenario.kind,
        "expected": expected,
        "expect_reason": scenario.expect_reason,
        "outcome": outcome,
        "as_expected": as_expected,
        "collisions": report.get("collisions", 0),
        "min_clearance_away_m": away,
        "min_clearance_away_nearest": report.get("min_clearance_away_nearest", ""),
        "min_clearance_away_at": report.get("min_clearance_away_at", []),
        "clearance_ok": (away is None or away >= AWAY_CLEARANCE_M) and not tight_doors,
        "tight_doors": tight_doors,
        "door_clearance": doors,
        "sim_time_s": report["sim_time_s"],
        "wall_time_s": report.get("wall_time_s"),
        "planned_length_m": planned,
        "time_ratio": ratio,
        "reason": reason,
        "scenario": str(scenario.path),
        "replay": f"wheelnav mission {scenario.path}",
        "phase_s": phase_seconds(report),
        **localisation(report),
    }


def clearance_note(row: dict[str, Any]) -> str:
    """A row's clearance in a few words for the progress line: the least away from doors,
    and, when a limit is missed, which (a miss should show as the mission ends, not only in
    the table at the end)."""
    away = row.get("min_clearance_away_m")
    note = "clearance -" if away is None else f"clearance {away:.3f} m"
    if row.get("clearance_ok", True):
        return note
    missed = []
    if away is not None and away < AWAY_CLEARANCE_M:
        missed.append(f"under {AWAY_CLEARANCE_M:.2f} m away from doors")
    if row.get("tight_doors"):
        missed.append("tight in " + " ".join(row["tight_doors"]))
    return f"{note}, BELOW A LIMIT: {'; '.join(missed)}"


def phase_seconds(report: dict[str, Any]) -> dict[str, float]:
    """Sim seconds the mission spent in each phase of its tree (follow, correct, pass,
    ride...), summed over its phases of that name: what its time went on."""
    spent: dict[str, float] = {}
    for p in report.get("phases", []):
        if p.get("end_s") is not None and p.get("start_s") is not None:
            spent[p["name"]] = spent.get(p["name"], 0.0) + p["end_s"] - p["start_s"]
    return {name: round(s, 2) for name, s in sorted(spent.items())}


def localisation(report: dict[str, Any]) -> dict[str, Any]:
    """Issue 15's figures of one run: the localisation's error at each door crossed (on the
    ground truth), how often the pose was lost and searched for, and whether the mission was
    lost to it (the localisation gave its pose up, or a stale pose ended it)."""
    kinds = [e.get("kind") for e in report.get("events", []) if e.get("source") == "localisation"]
    reason = report.get("reason", "")
    gave_up = "relocalise_failed" in kinds or "localisation lost" in reason
    return {
        "door_loc_errors_m": [
            c["loc_error_m"]
            for c in report.get("checkpoints", [])
            if c.get("kind") == "door" and c.get("loc_error_m") is not None
        ],
        "times_lost": kinds.count("lost"),
        "relocalised": kinds.count("relocalised"),
        "lost_to_localisation": not report.get("success") and (gave_up or "stale_pose" in reason),
    }


class ResultStore:
    """Rows on disk, one file per mission, under ``folder``."""

    def __init__(self, folder: Path) -> None:
        self.folder = folder
        folder.mkdir(parents=True, exist_ok=True)

    def _path(self, mission: str) -> Path:
        return self.folder / f"{mission}.json"

    def get(self, mission: str) -> dict[str, Any] | None:
        """The stored row of ``mission``, None if it has not run (or its file is damaged)."""
        path = self._path(mission)
        try:
            return json.loads(path.read_text())
        except (OSError, ValueError):
            return None

    def put(self, row: dict[str, Any]) -> None:
        """Store a row atomically (a stop mid-write leaves the old state, not half a file)."""
        path = self._path(row["mission"])
        tmp = path.with_suffix(".tmp")
        tmp.write_text(json.dumps(row, indent=1, default=_plain))
        tmp.replace(path)


def _plain(value: Any) -> Any:
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return str(value)
