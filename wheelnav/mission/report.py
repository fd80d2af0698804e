"""The mission report, without processes or Zenoh: what a run's statuses add up to.

:class:`Recorder` turns the stream of statuses a run produces into the report (a dict,
written as JSON); :func:`format_report` prints it for people.
"""

from __future__ import annotations

import json
import math
import re
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from shared.geometry import wrap_angle
from shared.messages import (
    TERMINAL_STATES,
    Diagnostics,
    DoorClearance,
    NavStatus,
    RouteReply,
    SimStatus,
)
from wheelnav.mission.checkpoints import CheckpointLog, PoseHistory

MAX_ACTIONS = 2000  # status text changes kept in a report
TRACE_EVERY_S = 0.25  # simulation seconds between the trace's samples, to begin with
MAX_TRACE = 1200  # trace samples kept: 5 minutes at 0.25 s, then the spacing doubles
_FAR_M = 1e5  # clearances from here up mean "nothing seen" (the simulator's 1e6)
_DIGITS = re.compile(r"(?<![\w.])-?\d+(\.\d+)?")  # a number, not the digits of a name (d1_004)


@dataclass
class Phase:
    name: str
    start_s: float
    end_s: float | None = None


@dataclass
class Trace:
    """The chair's true pose, speed and clearance every ``every_s`` of simulation time, for
    the report's plots. Bounded: when a sample would make more than ``cap``, every other
    one is dropped and the spacing doubles, so a long mission keeps an even, coarser trace.
    """

    every_s: float = TRACE_EVERY_S
    cap: int = MAX_TRACE
    samples: list[dict[str, Any]] = field(default_factory=list)
    latest: dict[str, Any] | None = None  # the newest pose: the trace ends where the chair did

    def add(self, sample: dict[str, Any]) -> None:
        """Offer one tick's sample; kept if it opens a new ``every_s`` slot."""
        self.latest = sample
        if self.samples and self._slot(sample["t"]) <= self._slot(self.samples[-1]["t"]):
            return
        if len(self.samples) >= self.cap:
            self.samples = self.samples[::2]
            self.every_s *= 2
            self.add(sample)
            return
        self.samples.append(sample)

    def _slot(self, t: float) -> int:
        return math.floor(t / self.every_s + 1e-9)

    def rows(self) -> list[dict[str, Any]]:
        """The samples, and the newest pose after them if it was not kept."""
        last = self.latest
        if last is not None and (not self.samples or last["t"] > self.samples[-1]["t"]):
            return [*self.samples, last]
        return list(self.samples)


@dataclass
class Recorder:
    """Collects what a run shows into the mission report."""

    goal_id: str
    state: str = "pending"
    reason: str = ""
    sim_time_s: float = 0.0
    collisions: int = 0
    min_clearance_m: float = math.inf
    min_clearance_away_m: float = math.inf
    away_nearest: str = ""
    away_at: list[float] = field(default_factory=list)
    door_clearance: dict[str, DoorClearance] = field(default_factory=dict)
    planned_length_m: float | None = None  # of the route driven last
    first_planned_length_m: float | None = None  # of the first route: the mission's ideal
    path_length_m: float = 0.0
    phases: list[Phase] = field(default_factory=list)
    events: list[dict[str, Any]] = field(default_factory=list)
    actions: list[dict[str, Any]] = field(default_factory=list)  # the status text's changes
    _last_xy: tuple[float, float] | None = None
    _truth: PoseHistory = field(default_factory=PoseHistory)
    _loc_sq: list[tuple[float, float]] = field(default_factory=list)
    _track_sq: list[float] = field(default_factory=list)
    checkpoints: CheckpointLog = field(default_factory=CheckpointLog)
    _action_shape: str = ""
    trace: Trace = field(default_factory=Trace)
    _clearance: float | None = None  # the latest clearance the simulator reported
    diagnostics: dict[str, Diagnostics] = field(default_factory=dict)  # latest per service

    @property
    def finished(self) -> bool:
        return self.state in TERMINAL_STATES or self.state == "timeout"

    def on_status(self, msg: NavStatus) -> None:
        if msg.goal_id != self.goal_id or self.finished:
            return
        phase = msg.phase if msg.state == "running" else ""
        self._note_action(msg.stamp, phase, msg.action)
        current = self.phases[-1] if self.phases and self.phases[-1].end_s is None else None
        if phase and (current is None or current.name != phase):
            if current is not None:
                current.end_s = msg.stamp
            self.phases.append(Phase(phase, msg.stamp))
        if msg.state in TERMINAL_STATES:
            if current is not None:
                current.end_s = msg.stamp
            self.state, self.reason, self.sim_time_s = msg.state, msg.reason, msg.stamp
        elif self.state == "pending":
            self.state = "running"

    def _note_action(self, stamp: float, phase: str, text: str) -> None:
        """Keep the navigator's status text where it changes in more than its numbers
        ("0.06 of 2.25 m" and "1.06 of 2.25 m" are one entry; "Door d1_005 (2/6)" and "Door
        d1_004 (3/6)" are two), and where the phase changes, at most ``MAX_ACTIONS``."""
        shape = f"{phase}:{_DIGITS.sub('#', text)}"
        if not text or len(self.actions) >= MAX_ACTIONS or shape == self._action_shape:
            return
        self._action_shape = shape
        self.actions.append({"t": round(stamp, 3), "phase": phase, "text": text})

    def on_sim_status(self, msg: SimStatus) -> None:
        if self.finished:
            return  # the report covers the mission, not the shutdown after it
        self.collisions = max(self.collisions, msg.collisions)
        self._clearance = msg.clearance_m if msg.clearance_m < _FAR_M else None
        if msg.min_clearance_m < _FAR_M:  # nothing within the simulator's range: none seen
            self.min_clearance_m = min(self.min_clearance_m, msg.min_clearance_m)
        if msg.min_clearance_away_m < min(1e6, self.min_clearance_away_m):
            self.min_clearance_away_m = msg.min_clearance_away_m
            self.away_nearest, self.away_at = msg.away_nearest, list(msg.away_at)
        for d in msg.doors:
            self._see_door(d)

    def _see_door(self, d: DoorClearance) -> None:
        """Keep, per door, the least clearance while passing it (once its doorway was
        entered, only that counts: the first entry replaces an outline-only least) and
        the least while only the outline was in its zone."""
        seen = self.door_clearance.get(d.door_id)
        outline = min(d.outline_clearance_m, d.min_clearance_m if not d.entered else _FAR_M)
        if seen is not None:
            outline = min(outline, seen.outline_clearance_m)
        if (
            seen is None
            or (d.entered and not seen.entered)
            or (d.entered == seen.entered and d.min_clearance_m < seen.min_clearance_m)
        ):
            seen = self.door_clearance[d.door_id] = replace(d)
        seen.outline_clearance_m = outline

    def on_diagnostics(self, msg: Diagnostics) -> None:
        """A service's counters: the latest of each service before the mission ended."""
        if not self.finished:
            self.diagnostics[msg.service] = msg

    def diagnostics_rows(self) -> dict[str, dict[str, Any]]:
        """Per service (by name): messages in, bad messages (and per key where any), restarts.

        Sampled on wall time (each service publishes every second), so unlike the rest of
        the report these counts differ between two runs of one scenario.
        """
        return {
            name: {
                "messages_in": d.messages_in,
                "bad_messages": d.bad_messages,
                "restarts": d.restarts,
                "bad_by_key": {k.key: k.bad_messages for k in d.keys if k.bad_messages},
            }
            for name, d in sorted(self.diagnostics.items())
        }

    def on_route(self, route: RouteReply) -> None:
        """A route about to be driven: its planned length (legs plus door passes).

        The first route's length is kept apart: a re-plan starts wherever the chair stands
        (after a recovery, near the goal), so the last route's length says little about
        how long the mission should have taken.
        """
        if self.finished:
            return
        legs = sum(_polyline_length(leg.waypoints) for leg in route.legs)
        passes = sum(c.pass_distance_m for c in route.checkpoints if c.kind == "door")
        self.planned_length_m = legs + passes
        if self.first_planned_length_m is None:
            self.first_planned_length_m = self.planned_length_m

    def on_truth(
        self,
        x: float,
        y: float,
        theta: float = 0.0,
        stamp: float | None = None,
        v: float = 0.0,
        floor: str = "",
    ) -> None:
        """A true pose (and speed, floor): path length, localisation truth, the trace."""
        if self.finished:
            return
        if stamp is not None:
            self._truth.add(stamp, (x, y, theta))
            self.trace.add(self._sample(stamp, x, y, theta, v, floor))
        if self._last_xy is not None:
            self.path_length_m += math.hypot(x - self._last_xy[0], y - self._last_xy[1])
        self._last_xy = (x, y)

    def _sample(
        self, t: float, x: float, y: float, theta: float, v: float, floor: str
    ) -> dict[str, Any]:
        clearance = None if self._clearance is None else round(self._clearance, 3)
        return {
            "t": round(t, 3),
            "x": round(x, 3),
            "y": round(y, 3),
            "theta": round(theta, 3),
            "floor": floor,
            "speed": round(v, 3),
            "clearance": clearance,
        }

    def on_pose(self, stamp: float, x: float, y: float, theta: float) -> None:
        """A pose estimate: compared with the ground truth of the same tick."""
        truth = self._truth.at(stamp)
        if truth is None or self.finished:
            return
        dth = wrap_angle(theta - truth[2])
        sq = (x - truth[0]) ** 2 + (y - truth[1]) ** 2
        self._loc_sq.append((sq, dth**2))
        self.checkpoints.on_loc_error(stamp, math.sqrt(sq))

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
            "min_clearance_away_m": _rounded(self.min_clearance_away_m),
            "min_clearance_away_nearest": self.away_nearest,
            "min_clearance_away_at": self.away_at,
            "door_clearance": [
                {
                    "door": door,
                    "width_m": round(d.width_m, 3),
                    "min_clearance_m": _rounded(d.min_clearance_m),
                    "free_width_m": round(d.free_width_m or d.width_m, 3),
                    "nearest": d.nearest,
                    "at": list(d.at),
                    "entered": d.entered,
                    "outline_clearance_m": _rounded(d.outline_clearance_m)
                    if d.outline_clearance_m < _FAR_M
                    else None,
                }
                for door, d in self.door_clearance.items()
            ],
            "planned_length_m": None
            if self.planned_length_m is None
            else round(self.planned_length_m, 3),
            "first_planned_length_m": None
            if self.first_planned_length_m is None
            else round(self.first_planned_length_m, 3),
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
            "actions": self.actions,
            "trace": self.trace.rows(),
            "trace_every_s": self.trace.every_s,
            "diagnostics": self.diagnostics_rows(),
        }


def _rounded(value: float) -> float | None:
    return round(value, 4) if math.isfinite(value) else None


def _polyline_length(points) -> float:
    pts = np.asarray(points, float)
    return float(np.linalg.norm(np.diff(pts, axis=0), axis=1).sum()) if len(pts) > 1 else 0.0


def format_report(report: dict[str, Any]) -> str:
    """A short human-readable summary of a report."""
    lines = [
        f"mission {report['scenario']}: {'SUCCESS' if report['success'] else 'FAILURE'}"
        f" ({report['reason']})",
        f"  sim time {report['sim_time_s']:.1f} s, wall time {report['wall_time_s']:.1f} s, "
        f"path {report['path_length_m']:.2f} m",
        f"  collisions {report['collisions']}, min clearance "
        f"{report['min_clearance_m'] if report['min_clearance_m'] is not None else '-'} m",
    ]
    if report.get("cross_track_rms_m") is not None:
        lines.append(f"  cross-track error on legs: RMS {100 * report['cross_track_rms_m']:.1f} cm")
    loc = report["localisation_error"]
    if loc["samples"]:
        lines.append(
            f"  localisation error: RMS {100 * loc['rms_m']:.1f} cm, max "
            f"{100 * loc['max_m']:.1f} cm, heading RMS {loc['rms_deg']:.2f} deg"
        )
    for c in report.get("checkpoints", []):
        lines.append("  " + format_checkpoint(c))
    for e in report.get("events", []):
        if e["kind"] in ("safety_stop", "safety_clear"):
            lines.append(f"  {e['kind']:12s} t={e['t']:6.1f} s  {e['detail']}")
    for fallback in report.get("fallbacks", []):
        lines.append(f"  fallback: {fallback}")
    for p in report["phases"]:
        end = f"{p['end_s']:.1f}" if p["end_s"] is not None else "-"
        lines.append(f"  phase {p['name']:8s} {p['start_s']:7.1f} -> {end} s")
    lines.extend(format_diagnostics(report.get("diagnostics", {})))
    return "\n".join(lines)


def format_diagnostics(rows: dict[str, dict[str, Any]]) -> list[str]:
    """One line per service: messages in, bad messages (by key where any), restarts."""
    lines = []
    for name, d in rows.items():
        where = ", ".join(f"{k} {n}" for k, n in d.get("bad_by_key", {}).items())
        lines.append(
            f"  diagnostics {name:12s} in {d['messages_in']:7d}  bad {d['bad_messages']:5d}"
            f"  restarts {d['restarts']}" + (f"  ({where})" if where else "")
        )
    return lines


def format_checkpoint(c: dict[str, Any]) -> str:
    """One line per checkpoint: result, Phase 0 figures, wait, crossing, phase times."""
    head = f"{c['kind']:8s} {c['id']:14s} {c.get('result', 'passed'):9s}"
    corr = c.get("correction_s")
    fix = f"position error {c['position_error_m']} m, heading {c['heading_error_deg']} deg" + (
        f" after {corr} s" if corr is not None else ""
    )
    extra = (
        f"lateral offset {c['lateral_offset_m']} m"
        if c["kind"] == "door"
        else f"to floor {c['to_floor']}"
    )
    if c.get("closing_at_s") is not None:
        extra += f", door closing at {c['closing_at_s']} s: stopped within {c['closing_stop_m']} m"
    phases = " / ".join(f"{k} {v}" for k, v in c.get("phases", {}).items())
    return f"{head} {fix}, wait {c['wait_s']} s, {extra}" + (f"; {phases} s" if phases else "")


def write_report(report: dict[str, Any], path: str | Path) -> None:
    Path(path).write_text(json.dumps(report, indent=2) + "\n")
