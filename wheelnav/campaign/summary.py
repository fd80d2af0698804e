"""What a campaign adds up to: the mission table, the figures, the geometry histogram."""

from __future__ import annotations

import math
from collections import Counter
from typing import Any

import numpy as np

from wheelnav.campaign.results import AWAY_CLEARANCE_M

LOC_AT_DOOR_M = 0.05  # issue 15: the localisation's error at every door checkpoint, at most


def figures(rows: list[dict[str, Any]], planned: int) -> dict[str, Any]:
    """Counts and rates over the rows that ran (``planned``: missions in the campaign)."""
    ran = [r for r in rows if r.get("outcome") != "not run"]
    ok = [r for r in ran if r["as_expected"]]
    ratios = [r["time_ratio"] for r in ran if r.get("time_ratio") is not None]
    away = [r["min_clearance_away_m"] for r in ran if r.get("min_clearance_away_m") is not None]
    slack = [
        d["min_clearance_m"] - d["required_m"]
        for r in ran
        for d in r.get("door_clearance", [])
        if d["min_clearance_m"] is not None
    ]
    by_kind: dict[str, list[int]] = {}
    for r in ran:
        counts = by_kind.setdefault(r.get("kind") or "-", [0, 0])
        counts[0] += int(r["as_expected"])
        counts[1] += 1
    return {
        "missions_planned": planned,
        "missions_run": len(ran),
        "as_expected": len(ok),
        "as_expected_pct": round(100 * len(ok) / len(ran), 1) if ran else None,
        "collisions": sum(r["collisions"] for r in ran),
        "clearance_violations": sum(not r["clearance_ok"] for r in ran),
        "min_clearance_away_m": round(min(away), 4) if away else None,
        "min_door_slack_m": round(min(slack), 4) if slack else None,
        "time_ratio_median": round(float(np.median(ratios)), 3) if ratios else None,
        "time_ratio_p90": round(float(np.percentile(ratios, 90)), 3) if ratios else None,
        "by_kind": {k: f"{v[0]}/{v[1]}" for k, v in sorted(by_kind.items())},
        "time_shares": time_shares([r for r in ran if r["outcome"] == "success"]),
        **_localisation(ran),
    }


def time_shares(rows: list[dict[str, Any]]) -> dict[str, float]:
    """Each phase's share of the phase time of ``rows`` (those with phase times; rows
    from before them count as none), largest first: what dominates mission time."""
    spent: Counter[str] = Counter()
    for r in rows:
        spent.update(r.get("phase_s") or {})
    total = sum(spent.values())
    if total <= 0:
        return {}
    return {name: round(s / total, 4) for name, s in spent.most_common()}


def _localisation(ran: list[dict[str, Any]]) -> dict[str, Any]:
    """Issue 15: missions lost to the localisation, and its error at the doors crossed
    (rows from before these figures count as none)."""
    errors = np.array([e for r in ran for e in r.get("door_loc_errors_m", [])], float)
    spread = None
    if len(errors):
        spread = {
            "doors": len(errors),
            "median_m": round(float(np.median(errors)), 4),
            "p90_m": round(float(np.percentile(errors, 90)), 4),
            "max_m": round(float(errors.max()), 4),
            "over_5_cm": int((errors > LOC_AT_DOOR_M).sum()),
        }
    return {
        "lost_to_localisation": sum(bool(r.get("lost_to_localisation")) for r in ran),
        "missions_ever_lost": sum(r.get("times_lost", 0) > 0 for r in ran),
        "door_loc_error": spread,
    }


def format_table(rows: list[dict[str, Any]]) -> str:
    """One line per mission: outcome, expected outcome, collisions, clearances, time ratio."""
    head = (
        f"{'mission':28s} {'kind':18s} {'outcome':8s} {'expect':8s} {'ok':3s} {'coll':>4s} "
        f"{'away m':>6s} {'door m':>6s} {'t/ideal':>7s}  reason"
    )
    lines = [head, "-" * len(head)]
    for r in rows:
        door = [d["min_clearance_m"] for d in r.get("door_clearance", []) if d["min_clearance_m"]]
        away, tightest = r.get("min_clearance_away_m"), min(door, default=None)
        lines.append(
            f"{r['mission'][:28]:28s} {(r.get('kind') or '-')[:18]:18s} "
            f"{r['outcome'][:8]:8s} {r['expected'][:8]:8s} "
            f"{'yes' if r['as_expected'] else 'NO':3s} {r['collisions']:4d} "
            f"{_num(away, '6.3f')} {_num(tightest, '6.3f')} "
            f"{_num(r.get('time_ratio'), '7.2f')}  {r['reason'][:70]}"
        )
    return "\n".join(lines)


def format_figures(f: dict[str, Any]) -> str:
    """The campaign's figures, one per line."""
    kinds = ", ".join(f"{k} {v}" for k, v in f["by_kind"].items())
    return "\n".join(
        [
            f"missions run {f['missions_run']} of {f['missions_planned']}; as expected "
            f"{f['as_expected']} ({_num(f['as_expected_pct'], '.1f')} %); collisions "
            f"{f['collisions']}",
            f"by kind: {kinds or '-'}",
            f"clearance: min away from doors {_num(f['min_clearance_away_m'], '.3f')} m "
            f"(limit 0.050), min slack in openings {_num(f['min_door_slack_m'], '.3f')} m "
            f"(limit 0), missions below a limit {f['clearance_violations']}",
            _loc_line(f),
            f"mission time / (planned length / 0.5 m/s), successful missions: median "
            f"{_num(f['time_ratio_median'], '.2f')}, 90th percentile "
            f"{_num(f['time_ratio_p90'], '.2f')}",
            _shares_line(f.get("time_shares") or {}),
        ]
    )


def _shares_line(shares: dict[str, float]) -> str:
    """Where the successful missions' time went, by phase (the largest shares)."""
    if not shares:
        return "where the time goes: no phase times in these rows"
    top = list(shares.items())[:8]
    rest = 1.0 - sum(v for _, v in top)
    parts = [f"{name} {100 * v:.0f} %" for name, v in top]
    if rest > 0.005:
        parts.append(f"other {100 * rest:.0f} %")
    return "where the successful missions' time goes, by phase: " + ", ".join(parts)


def _loc_line(f: dict[str, Any]) -> str:
    """The localisation's figures in one line."""
    d = f.get("door_loc_error")
    at_doors = (
        f"error at {d['doors']} doors crossed: median {d['median_m']:.3f} m, 90th percentile "
        f"{d['p90_m']:.3f} m, max {d['max_m']:.3f} m, over 5 cm {d['over_5_cm']}"
        if d
        else "no door crossings measured"
    )
    return (
        f"localisation: missions lost to it {f.get('lost_to_localisation', 0)}, ever lost "
        f"{f.get('missions_ever_lost', 0)}; {at_doors}"
    )


def _where(nearest: str, at: list[float]) -> str:
    if len(at) < 3:
        return f"to {nearest or '?'}"
    pose = f"({at[0]:.2f}, {at[1]:.2f}, {math.degrees(at[2]):.0f} deg)"
    return f"to {nearest or '?'} with the chair at {pose}"


def format_tight(rows: list[dict[str, Any]]) -> str:
    """Every clearance below its limit: how close, to what, and where the chair stood."""
    lines = []
    for r in rows:
        away = r.get("min_clearance_away_m")
        if away is not None and away < AWAY_CLEARANCE_M:
            where = _where(
                r.get("min_clearance_away_nearest", ""), r.get("min_clearance_away_at", [])
            )
            lines.append(f"  {r['mission']}: {away:.3f} m away from doors, {where}")
        for d in r.get("door_clearance", []):
            if d["door"] not in r.get("tight_doors", []):
                continue
            if d["min_clearance_m"] is not None and d["min_clearance_m"] < d["required_m"]:
                where = _where(d.get("nearest", ""), d.get("at", []))
                lines.append(
                    f"  {r['mission']}: {d['min_clearance_m']:.3f} m in {d['door']} "
                    f"(needs {d['required_m']:.3f}), {where}"
                )
            else:
                lines.append(
                    f"  {r['mission']}: {d['outline_clearance_m']:.3f} m with only the "
                    f"outline in {d['door']} (needs {d['outline_required_m']:.3f})"
                )
    if not lines:
        return "every clearance within its limit"
    return "\n".join([f"{len(lines)} clearance(s) below a limit:", *lines])


def format_failures(rows: list[dict[str, Any]]) -> str:
    """Every mission not as expected, with the one command that replays it."""
    bad = [r for r in rows if r.get("outcome") != "not run" and not r["as_expected"]]
    if not bad:
        return "every mission as expected"
    lines = [f"{len(bad)} mission(s) not as expected:"]
    for r in bad:
        lines.append(f"  {r['mission']}: {r['outcome']} (expected {r['expected']}): {r['reason']}")
        lines.append(f"    replay: {r['replay']}")
        if r.get("report"):
            lines.append(f"    report (events, phases): {r['report']}")
    return "\n".join(lines)


HISTOGRAMS = {  # geometry key -> (title, bin edges)
    "door_widths_m": ("door width m", [0.8, 0.9, 1.0, 1.1, 1.21]),
    "corridor_widths_m": ("corridor width m", [1.2, 1.5, 2.0, 2.5, 3.01]),
    "corridor_lengths_m": ("corridor length m", [0, 10, 20, 30, 40, 1e9]),
    "room_sizes_m2": ("room area m2", [0, 8, 15, 30, 60, 1e9]),
    "hall_sizes_m2": ("hall area m2", [0, 200, 400, 600, 1e9]),
}


def format_geometry(geometry: list[dict[str, Any]]) -> str:
    """Histograms of what the generator drew, over every building of the campaign."""
    lines = ["geometry drawn:"]
    for key, (title, edges) in HISTOGRAMS.items():
        values = [v for g in geometry for v in g.get(key, [])]
        if not values:
            lines.append(f"  {title}: none")
            continue
        counts, _ = np.histogram(values, bins=edges)
        lines.append(f"  {title} ({len(values)}):")
        for lo, hi, n in zip(edges[:-1], edges[1:], counts, strict=True):
            label = f"{lo:g}-{hi:g}" if hi < 1e8 else f">= {lo:g}"
            lines.append(f"    {label:>12s} {n:4d} {'#' * min(int(n), 60)}")
    series = sum(g.get("doors_in_series", 0) for g in geometry)
    headings = Counter(int(h) for g in geometry for h in g.get("lift_headings_deg", []))
    floors = Counter(int(g.get("floors", 1)) for g in geometry)
    lines.append(f"  doors in series (pairs): {series}")
    turns = ", ".join(f"{h}: {n}" for h, n in sorted(headings.items())) or "none"
    lines.append(f"  lift headings deg: {turns}")
    per = ", ".join(f"{k}: {v}" for k, v in sorted(floors.items()))
    lines.append(f"  floors per building: {per}")
    return "\n".join(lines + format_world(geometry))


def format_world(geometry: list[dict[str, Any]]) -> list[str]:
    """What the simulator's world had that the stack's map had not (``--world-differs``):
    doors moved (how far), furniture added and removed, walls moved, people standing;
    nothing if none."""
    worlds = [g["world"] for g in geometry if "world" in g]
    if not worlds:
        return []

    def values(key: str) -> list[float]:
        return [v for w in worlds for v in w.get(key, [])]

    doors = Counter(round(v, 2) for v in values("doors_moved_m"))
    added, removed = values("furniture_added_m2"), values("furniture_removed_m2")
    shifts, lengths = values("walls_moved_m"), values("walls_moved_length_m")
    lines = [
        f"  world differs from the map ({len(worlds)} of {len(geometry)} buildings):",
        f"    doors moved along their wall ({sum(doors.values())}):",
    ]
    for offset, n in sorted(doors.items()):
        lines.append(f"    {f'{offset:.2f} m':>12s} {n:4d} {'#' * min(n, 60)}")
    lines.append(
        f"    furniture the map lacks: {len(added)} ({sum(added):.1f} m2); "
        f"mapped, not there: {len(removed)} ({sum(removed):.1f} m2)"
    )
    by = Counter(round(v, 2) for v in shifts)
    moved = ", ".join(f"{v:.2f} m: {n}" for v, n in sorted(by.items()))
    lines.append(
        f"    walls moved: {len(shifts)} ({sum(lengths):.1f} m of wall; by {moved or '-'})"
    )
    lines.append(f"    people standing the map does not show: {len(values('people_radius_m'))}")
    return lines


def _num(value, fmt: str) -> str:
    width = fmt.split(".")[0] if fmt[0].isdigit() else ""
    return format(value, fmt) if value is not None else format("-", f">{width or 1}s")
