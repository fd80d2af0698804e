"""Per-checkpoint figures for the mission report, measured on the ground truth.

For each door: the position and heading error at the end of position correction (the
navigator's Phase 0, read from its status; without one, the closest approach and the
heading at set-off), how long it waited at the approach pose, its lateral offset from
the door's centre when it crossed the door plane, the localisation's error then (its
estimate of that tick against the truth: issue 15), and the time of each phase. For each
elevator: the floors, the phases (waiting for the car, entering, the ride, leaving).
Pure: the runner feeds it the route, the navigator's status and the true poses.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from shared.geometry import angle_between
from shared.messages import Checkpoint, Phase
from shared.site import Door

NEAR_M = 0.3  # "at the approach pose": within this distance of it
LOC_KEPT = 500  # estimate errors kept by stamp (10 s at 50 Hz) for doors crossed
STILL = 0.03  # m/s: standing


@dataclass
class _Track:
    cp: Checkpoint
    arrived_s: float | None = None
    set_off_s: float | None = None
    position_error_m: float | None = None
    heading_error_deg: float | None = None
    crossed_s: float | None = None
    lateral_offset_m: float | None = None
    loc_error_m: float | None = None  # the estimate's error at the crossing tick
    floor_after: str = ""
    corrected: bool = False
    passed_s: float | None = None  # crossed the door plane / out of the car: done when the
    # navigator's action moves on
    closing_at: tuple[float, float, float] | None = None  # (t, x, y): door left OPEN mid-pass
    closing_stop_m: float | None = None  # how far the chair went after that before it stood
    phases: dict[str, float] = field(default_factory=dict)
    _side: float | None = None


Pose = tuple[float, float, float]


def door_shifts(mapped: list[Door], world: list[Door]) -> dict[str, tuple[float, float]]:
    """How far each door of ``mapped`` stands in ``world`` from where the map has it (its
    middle's move; doors the world has as mapped, or lacks, are left out)."""
    true = {d.id: d for d in world}
    shifts = {}
    for d in mapped:
        w = true.get(d.id)
        if w is None:
            continue
        sx = round((w.p1[0] + w.p2[0] - d.p1[0] - d.p2[0]) / 2, 6)
        sy = round((w.p1[1] + w.p2[1] - d.p1[1] - d.p2[1]) / 2, 6)
        if sx or sy:
            shifts[d.id] = (sx, sy)
    return shifts


class PoseHistory:
    """The last ``size`` true poses by the stamp of their tick.

    Statuses and door states arrive on other keys than the ground truth, and can arrive
    after the next tick's truth: figures about a tick look its pose up by stamp.
    """

    def __init__(self, size: int = 200) -> None:
        self.size = size
        self._poses: dict[float, Pose] = {}
        self.latest: Pose | None = None

    def add(self, stamp: float, pose: Pose) -> None:
        self._poses[round(stamp, 6)] = pose
        self.latest = pose
        if len(self._poses) > self.size:
            self._poses.pop(next(iter(self._poses)))

    def at(self, stamp: float) -> Pose | None:
        """The pose of the tick at ``stamp``, None if not (or no longer) known."""
        return self._poses.get(round(stamp, 6))


@dataclass
class CheckpointLog:
    """Follows the chair through the current route's checkpoints, in order.

    ``door_shifts`` (door id -> metres, map frame) moves a door from where the stack's map
    puts it to where the simulated world has it: the lateral offset is the chair's from
    the true door."""

    door_shifts: dict[str, tuple[float, float]] = field(default_factory=dict)
    done: list[dict[str, Any]] = field(default_factory=list)
    _queue: list[_Track] = field(default_factory=list)
    _truth: PoseHistory = field(default_factory=PoseHistory)
    _loc: dict[float, float] = field(default_factory=dict)  # recent estimate errors by stamp
    _phase: tuple[str, float] | None = None  # (name, start) of the head's running phase

    def on_route(self, checkpoints: list[Checkpoint], stamp: float = 0.0) -> None:
        """A (new) route: the checkpoints still ahead. A checkpoint the old route had
        started on (the door that never opened) is kept in the report as abandoned."""
        head = self._queue[0] if self._queue else None
        if head is not None and (head.phases or self._phase is not None):
            self._finish(stamp, "abandoned")
        self._queue = [_Track(cp) for cp in checkpoints]
        self._phase = None

    def on_status(self, stamp: float, action: str, phase: str) -> None:
        """The navigator's action ("Door d1 (2/5)") and phase: times the head's phases and
        takes the position error when its position correction ends."""
        head = self._queue[0] if self._queue else None
        ours = head is not None and action.split(" (")[0].split(" ", 1)[-1] == head.cp.id
        if head is not None and head.passed_s is not None and not ours:
            self._finish(stamp)
            self.on_status(stamp, action, phase)  # the next checkpoint may start right away
            return
        if self._phase is not None and (not ours or phase != self._phase[0]):
            name, start = self._phase
            if head is not None:
                head.phases[name] = round(head.phases.get(name, 0.0) + stamp - start, 2)
                truth = self._truth_at(stamp)
                if name == Phase.CORRECT and truth is not None:
                    self._corrected(head, truth)
            self._phase = None
        if ours and phase and self._phase is None:
            self._phase = (phase, stamp)

    def on_door_state(self, stamp: float, door_id: str, open_now: bool) -> None:
        """The building's report of a door: one that stops being open while the chair is
        passing it (before the plane) starts the stopping-distance measurement."""
        head = self._queue[0] if self._queue else None
        if (
            head is None
            or head.cp.id != door_id
            or open_now
            or head.closing_at is not None
            or head.passed_s is not None
            or self._phase is None
            or self._phase[0] != Phase.PASS
            or self._truth_at(stamp) is None
        ):
            return
        x, y, _ = self._truth_at(stamp)
        head.closing_at = (stamp, x, y)

    def on_loc_error(self, stamp: float, error_m: float) -> None:
        """The localisation's position error of the tick at ``stamp`` (estimate against
        truth): kept a while, and given to a door crossed at that tick."""
        key = round(stamp, 6)
        self._loc[key] = error_m
        if len(self._loc) > LOC_KEPT:
            del self._loc[next(iter(self._loc))]
        for t in self._queue:
            if t.crossed_s is not None and round(t.crossed_s, 6) == key:
                t.loc_error_m = error_m

    def _truth_at(self, stamp: float) -> Pose | None:
        """The true pose of the tick at ``stamp`` (the latest one if it is not known)."""
        return self._truth.at(stamp) or self._truth.latest

    def rows(self, stamp: float) -> list[dict[str, Any]]:
        """The report's rows: the checkpoints done, and the one the mission ended at
        (abandoned: the door that never opened when there was no other way)."""
        head = self._queue[0] if self._queue else None
        if head is None or not (head.phases or self._phase is not None):
            return list(self.done)
        result = "abandoned" if head.passed_s is None else "passed"
        return [*self.done, self._row(head, stamp, result)]

    def _corrected(self, t: _Track, truth: Pose) -> None:
        x, y, theta = truth
        a = t.cp.approach
        t.position_error_m = math.hypot(x - a.x, y - a.y)
        t.heading_error_deg = math.degrees(angle_between(theta, a.theta))
        t.corrected = True

    def on_truth(
        self, stamp: float, x: float, y: float, theta: float, v: float, floor: str
    ) -> None:
        self._truth.add(stamp, (x, y, theta))
        if not self._queue:
            return
        t = self._queue[0]
        cp = t.cp
        ax, ay, ath = cp.approach.x, cp.approach.y, cp.approach.theta
        dist = math.hypot(x - ax, y - ay)
        if t.arrived_s is None and dist < NEAR_M:
            t.arrived_s = stamp
        along = (x - ax) * math.cos(ath) + (y - ay) * math.sin(ath)
        if t.arrived_s is not None and t.set_off_s is None:
            if not t.corrected and (t.position_error_m is None or dist < t.position_error_m):
                t.position_error_m = dist  # closest approach, if there is no Phase 0
            if along > 0.05 and v > STILL:
                t.set_off_s = stamp
                if not t.corrected:
                    t.heading_error_deg = math.degrees(angle_between(theta, ath))
        if t.passed_s is not None:
            return
        if t.closing_at is not None and t.closing_stop_m is None and abs(v) < STILL:
            t.closing_stop_m = math.hypot(x - t.closing_at[1], y - t.closing_at[2])
        if cp.kind == "door":
            self._door(t, stamp, x, y)
        elif (
            t.set_off_s is not None
            and floor == cp.to_floor
            and abs(v) < STILL
            and math.hypot(x - cp.exit.x, y - cp.exit.y) < NEAR_M
        ):
            t.floor_after = floor
            t.passed_s = stamp

    def _door(self, t: _Track, stamp: float, x: float, y: float) -> None:
        c = t.cp.centre or t.cp.approach
        sx, sy = self.door_shifts.get(t.cp.id, (0.0, 0.0))
        cx, cy = c.x + sx, c.y + sy
        n = (math.cos(t.cp.approach.theta), math.sin(t.cp.approach.theta))
        side = (x - cx) * n[0] + (y - cy) * n[1]
        if t._side is not None and t._side < 0 <= side:
            t.crossed_s = stamp
            t.lateral_offset_m = -(x - cx) * n[1] + (y - cy) * n[0]
            t.loc_error_m = self._loc.get(round(stamp, 6))  # else when its estimate comes
            t.passed_s = stamp
            return
        t._side = side

    def _finish(self, stamp: float, result: str = "passed") -> None:
        self.done.append(self._row(self._queue.pop(0), stamp, result))
        self._phase = None

    def _row(self, t: _Track, stamp: float, result: str) -> dict[str, Any]:
        """The report row of ``t``, counting the phase still running up to ``stamp``."""
        phases = dict(t.phases)
        if self._phase is not None:
            name, start = self._phase
            phases[name] = round(phases.get(name, 0.0) + stamp - start, 2)
        cp = t.cp
        row: dict[str, Any] = {"kind": cp.kind, "id": cp.id, "floor": cp.floor, "result": result}
        wait = (t.set_off_s - t.arrived_s) if t.set_off_s and t.arrived_s is not None else None
        row.update(
            {
                "arrived_s": _r(t.arrived_s),
                "set_off_s": _r(t.set_off_s),
                "wait_s": _r(wait),
                "position_error_m": _r(t.position_error_m, 3),
                "heading_error_deg": _r(t.heading_error_deg, 2),
                "correction_s": phases.get(Phase.CORRECT),
                "phases": phases,
            }
        )
        if cp.kind == "door":
            row.update(
                {
                    "crossed_s": _r(t.passed_s),
                    "lateral_offset_m": _r(t.lateral_offset_m, 3),
                    "loc_error_m": _r(t.loc_error_m, 4),
                }
            )
            if t.closing_at is not None:
                row["closing_at_s"] = _r(t.closing_at[0])
                row["closing_stop_m"] = _r(t.closing_stop_m, 3)
        else:
            row.update({"to_floor": cp.to_floor, "left_car_s": _r(t.passed_s)})
        return row


def _r(value: float | None, digits: int = 2) -> float | None:
    return None if value is None else round(value, digits)
