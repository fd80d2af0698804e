"""What ``wheelnav plan`` and ``wheelnav rooms`` print: a JSON object or a few lines of text.

Lengths and coordinates are in metres in the map frame (coordinates to 0.1 mm),
headings in radians, times in milliseconds.
"""

from __future__ import annotations

import math

from services.planner.routes import Checkpoint
from wheelnav.maptools.plan import PlanResult
from wheelnav.maptools.rooms import FloorRooms


def plan_json(result: PlanResult, repeat: int | None) -> dict:
    """The route as JSON: ``plan_ms`` is a list when the plan was timed ``repeat`` times."""
    times = [round(t, 3) for t in result.plan_ms]
    return {
        "ok": True,
        "floor": result.floor,
        "start": _xy(result.start),
        "goal": _xy(result.goal),
        "radius_m": round(result.radius_m, 4),
        "path": [_xy(p) for p in result.path],
        "length_m": round(result.plan.length_m, 3),
        "waypoints": [_xy(p) for p in result.plan.waypoints],
        "v_ref": [round(float(v), 3) for v in result.plan.v_ref],
        "checkpoints": [checkpoint_json(cp) for cp in result.checkpoints],
        "plan_ms": times if repeat is not None else times[0],
    }


def checkpoint_json(cp: Checkpoint) -> dict:
    """A door or lift the route passes, with the poses the chair drives to around it."""
    return {
        "kind": cp.kind,
        "id": cp.id,
        "floor": cp.floor,
        "center": _xy(cp.centre),
        "width_m": round(cp.width_m, 3),
        "heading": _angle(cp.approach[2]),
        "approach": [*_xy(cp.approach), _angle(cp.approach[2])],
        "exit": [*_xy(cp.exit), _angle(cp.exit[2])],
        "pass_distance_m": round(cp.pass_distance_m, 3),
        "door_type": cp.door_type,
        "to_floor": cp.to_floor,
    }


def plan_text(result: PlanResult) -> str:
    """A short summary: length, timing, the path's corners, the checkpoints."""
    ms = ", ".join(f"{t:.2f}" for t in result.plan_ms)
    lines = [
        f"floor {result.floor}: {_fmt(result.start)} -> {_fmt(result.goal)}, "
        f"{result.plan.length_m:.2f} m, {len(result.plan.waypoints)} waypoints, "
        f"inflation {result.radius_m:.2f} m, planned in {ms} ms",
        "path: " + " -> ".join(_fmt(p) for p in result.path),
    ]
    if not result.checkpoints:
        lines.append("checkpoints: none")
    for cp in result.checkpoints:
        lines.append(
            f"{cp.kind} {cp.id}: centre {_fmt(cp.centre)}, {cp.width_m:.2f} m wide, "
            f"approach {_fmt(cp.approach)}, exit {_fmt(cp.exit)}, "
            f"heading {math.degrees(cp.approach[2]) + 0.0:.0f} deg"
        )
    return "\n".join(lines)


def rooms_json(floor: FloorRooms) -> dict:
    """Rooms (id, centroid, area) and doors (centre, width, unit normal, the two rooms)."""
    return {
        "ok": True,
        "floor": floor.floor,
        "rooms": [
            {
                "id": r.id,
                "kind": r.kind,
                "centroid": _xy(r.centroid),
                "inside": _xy(r.inside),
                "area_m2": round(r.area_m2, 3),
                "lift": r.lift,
            }
            for r in floor.rooms
        ],
        "doors": [
            {
                "id": d.id,
                "kind": d.kind,
                "type": d.type,
                "center": _xy(d.center),
                "width_m": round(d.width_m, 3),
                "normal": [round(v, 6) + 0.0 for v in d.normal],
                "rooms": list(d.rooms),
                "p1": _xy(d.p1),
                "p2": _xy(d.p2),
            }
            for d in floor.doors
        ],
    }


def rooms_text(floor: FloorRooms) -> str:
    """One line per room and per door."""
    lines = [f"floor {floor.floor}: {_count(floor.rooms, 'room')}, {_count(floor.doors, 'door')}"]
    for r in floor.rooms:
        lift = f" ({r.lift})" if r.lift else ""
        lines.append(
            f"room {r.id}: {r.kind}{lift}, centroid {_fmt(r.centroid)}, {r.area_m2:.1f} m2"
        )
    for d in floor.doors:
        lines.append(
            f"{d.kind} {d.id}: centre {_fmt(d.center)}, {d.width_m:.2f} m wide, "
            f"normal {_fmt(d.normal)}, rooms {d.rooms[0]} -> {d.rooms[1]}"
        )
    return "\n".join(lines)


def _xy(p) -> list[float]:
    return [round(float(p[0]), 4) + 0.0, round(float(p[1]), 4) + 0.0]  # never -0.0


def _angle(theta: float) -> float:
    return round(float(theta), 4) + 0.0


def _count(items: list, noun: str) -> str:
    return f"{len(items)} {noun}{'' if len(items) == 1 else 's'}"


def _fmt(p) -> str:
    x, y = (round(float(v), 2) + 0.0 for v in p[:2])  # never -0.00
    return f"({x:.2f}, {y:.2f})"
