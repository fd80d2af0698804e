"""What a restarted navigator carries on with: the mission it was running.

The navigator saves a :class:`MissionRecord` (goal, what it was doing, the doors and lifts
it had given up on) as its status changes. Restarted by the launcher, it takes a record
that was still running, is from this run (no older than the clock's start, and at most
``within_s`` old) and plans the same goal again from where the chair stands, with the
same checkpoints avoided: before a door that is Phase 0 again, past it the rest of the
route. It waits until the controller has finished the leg it was on and stopped at its end
(never into a door or a car: those legs are sent one at a time). Entering a car or riding
in it, it takes up the saved route at that lift step from "send the car to the floor"
(which renews the lift session) and waits for the lift's state again; leaving a car, the
back-out leg ends outside on the new floor and the goal is planned again. A mission the
rider had paused (services/navigator/holds.py) is taken up paused: a restart does not
resume it. Pure: no I/O.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from shared.messages import NavGoal, Phase, Pose2D

IN_A_CAR = (Phase.ENTER, Phase.RIDE, Phase.EXIT)


@dataclass(frozen=True)
class MissionRecord:
    """The running mission as saved: its goal, state and phase, the avoided checkpoints."""

    stamp: float
    goal_id: str
    goal: tuple[float, float, float, str] | None
    place: str
    state: str
    phase: str = ""
    avoided: list[str] = field(default_factory=list)
    route: str = ""  # the route being driven, encoded (base64 of the codec's bytes)
    step: int = -1  # the index of its running step (a leg, a door, a lift)
    paused: str = ""  # why the rider's pause held it ("" when it was not paused)

    def to_dict(self) -> dict[str, Any]:
        return {
            "stamp": self.stamp,
            "goal_id": self.goal_id,
            "goal": None if self.goal is None else list(self.goal),
            "place": self.place,
            "state": self.state,
            "phase": self.phase,
            "avoided": list(self.avoided),
            "route": self.route,
            "step": self.step,
            "paused": self.paused,
        }

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> MissionRecord:
        """The record; ValueError naming what is wrong if ``d`` is not one."""
        try:
            goal = d["goal"]
            if goal is not None:
                x, y, theta = (float(v) for v in goal[:3])
                goal = (x, y, theta, str(goal[3]))
                if not all(math.isfinite(v) for v in goal[:3]):
                    raise ValueError("goal is not finite")
            record = cls(
                float(d["stamp"]),
                str(d["goal_id"]),
                goal,
                str(d["place"]),
                str(d["state"]),
                str(d.get("phase", "")),
                [str(a) for a in d.get("avoided", [])],
                str(d.get("route", "")),
                int(d.get("step", -1)),
                str(d.get("paused", "")),
            )
        except (KeyError, TypeError, ValueError, IndexError) as exc:
            raise ValueError(f"saved mission: missing or malformed field ({exc})") from None
        if not math.isfinite(record.stamp):
            raise ValueError("saved mission: stamp is not finite")
        return record


def resume_goal(
    record: MissionRecord | None, now: float, within_s: float
) -> tuple[NavGoal | None, str]:
    """(the goal to take up, "") or (None, why not) for a navigator restarted at ``now``.
    In a car (:func:`in_car`) the goal is taken up by riding on, else by planning again."""
    if record is None:
        return None, "no saved mission"
    if record.state != "running":
        return None, f"the saved mission {record.goal_id} had ended ({record.state})"
    if now < record.stamp:
        return None, f"the saved mission {record.goal_id} is from an earlier run"
    if now - record.stamp > within_s:
        return None, (
            f"the saved mission {record.goal_id} is {now - record.stamp:.1f} s old "
            f"(navigator.resume_within_s {within_s:g})"
        )
    if record.phase in IN_A_CAR and record.phase != Phase.EXIT and not in_car(record):
        return None, f"the mission {record.goal_id} stopped in a lift car with no route saved"
    goal = None if record.goal is None else Pose2D(*record.goal)
    return NavGoal(now, record.goal_id, goal, record.place), ""


def in_car(record: MissionRecord) -> bool:
    """True if the mission stopped with the chair in a lift car (entering or riding) and
    its route is saved: it rides on from "send the car to the floor" of that lift step."""
    return record.phase in (Phase.ENTER, Phase.RIDE) and bool(record.route) and record.step >= 0
