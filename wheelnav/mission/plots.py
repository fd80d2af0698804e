"""Pictures of a mission run, drawn from its report: what the JSON says, at a glance.

:func:`write_plots` writes one PNG per mission (``DIR/<scenario>.png``) with three parts:

- the path driven (the report's ``trace``, ground truth) over the floor map, one panel per
  floor visited, with the doors it crossed marked and labelled by id and crossing time,
  where it started and stopped, the lift cars, and where it changed floor;
- speed and clearance over simulation time, with the door crossings as dotted lines;
- the phase timeline (the report's ``phases``) as horizontal bars, one row per phase name.

Pure: the report dict and the :class:`~shared.site.Site` in, PNG files out. Drawn with
matplotlib's Agg canvas (no pyplot, no display, no global state).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from itertools import pairwise
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.patches import Polygon

from shared.site import Elevator, Floor, Site

PATH_COLOUR = "#1f5fd6"
DOOR_COLOUR = "#e07b00"
LIFT_COLOUR = "#7a3db8"
CLEARANCE_COLOUR = "#2a9d8f"
START_COLOUR, END_COLOUR = "#2ca02c", "#d62728"
WALL_GREY, UNKNOWN_GREY = 0.2, 0.85  # free floor is white
PHASE_COLOURS = (
    "#4c72b0",
    "#dd8452",
    "#55a868",
    "#c44e52",
    "#8172b3",
    "#937860",
    "#da8bc3",
    "#8c8c8c",
    "#ccb974",
    "#64b5cd",
)
WIDTH_IN, DPI = 12.0, 100


@dataclass(frozen=True)
class Crossing:
    """The chair's centre passing through a door's opening (from the trace)."""

    door: str
    floor: str
    t: float
    x: float
    y: float


@dataclass
class MissionFigure:
    """The drawn figure and its axes (tests read known pixels through their transforms)."""

    figure: Figure
    maps: dict[str, Axes]
    speed: Axes
    clearance: Axes
    phases: Axes


def write_plots(report: dict[str, Any], site: Site, out_dir: str | Path) -> list[Path]:
    """Draw the mission in ``report`` into ``out_dir`` (created if needed); the files written."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    path = out / f"{_file_name(report.get('scenario', 'mission'))}.png"
    save(mission_figure(report, site), path)
    return [path]


def save(drawn: MissionFigure, path: str | Path) -> None:
    """Write the figure as a PNG at its own size (no tight crop: pixels stay where drawn)."""
    drawn.figure.savefig(path, dpi=drawn.figure.dpi)


def mission_figure(report: dict[str, Any], site: Site) -> MissionFigure:
    """The whole picture of one mission: map panels on top, the time plots below."""
    trace = _on_site_floors(report.get("trace") or [], site)
    floors = _floors_visited(trace, site)
    cols = min(len(floors), 2)
    rows = math.ceil(len(floors) / cols)
    phase_names = _phase_names(report.get("phases", []))
    map_h = _map_height_in(site, floors, WIDTH_IN / cols)
    heights = [map_h] * rows + [1.8, 1.8, 0.9 + 0.3 * max(1, len(phase_names))]
    fig = Figure(figsize=(WIDTH_IN, sum(heights) + 0.6), dpi=DPI, layout="constrained")
    FigureCanvasAgg(fig)
    grid = fig.add_gridspec(len(heights), cols, height_ratios=heights)
    crossings = door_crossings(trace, site)
    maps = {}
    for i, name in enumerate(floors):
        ax = fig.add_subplot(grid[i // cols, i % cols])
        _draw_floor(ax, site, site.floors[name], trace, crossings)
        maps[name] = ax
    speed = fig.add_subplot(grid[rows, :])
    clearance = fig.add_subplot(grid[rows + 1, :], sharex=speed)
    phases = fig.add_subplot(grid[rows + 2, :], sharex=speed)
    end_s = max(float(report.get("sim_time_s") or 0.0), trace[-1]["t"] if trace else 0.0)
    _draw_speed(speed, trace, crossings)
    _draw_clearance(clearance, trace, crossings, report.get("min_clearance_m"))
    _draw_phases(phases, report.get("phases", []), phase_names, end_s)
    speed.set_xlim(0.0, max(end_s, 1.0))
    fig.suptitle(_title(report), fontsize=11)
    return MissionFigure(fig, maps, speed, clearance, phases)


def door_crossings(trace: list[dict[str, Any]], site: Site) -> list[Crossing]:
    """Every time the trace passes through a door opening of its floor, in time order."""
    out: list[Crossing] = []
    for floor, run in _floor_runs(trace):
        xy = np.array([(s["x"], s["y"]) for s in run], float)
        t = np.array([s["t"] for s in run], float)
        for door in (d for d in site.doors if d.floor == floor):
            for i, frac in _segment_hits(xy, np.array(door.p1), np.array(door.p2)):
                x, y = xy[i] + frac * (xy[i + 1] - xy[i])
                ti = t[i] + frac * (t[i + 1] - t[i])
                out.append(Crossing(door.id, floor, round(float(ti), 2), float(x), float(y)))
    return sorted(out, key=lambda c: c.t)


def _segment_hits(xy: np.ndarray, p1: np.ndarray, p2: np.ndarray) -> list[tuple[int, float]]:
    """(index, fraction) of the polyline's steps ``xy[i] -> xy[i+1]`` that cross p1 -> p2."""
    if len(xy) < 2:
        return []
    a, d, e = xy[:-1], np.diff(xy, axis=0), p2 - p1
    den = d[:, 0] * e[1] - d[:, 1] * e[0]
    ok = np.abs(den) > 1e-12
    safe = np.where(ok, den, 1.0)
    w = p1 - a
    along = (w[:, 0] * e[1] - w[:, 1] * e[0]) / safe
    on_door = (w[:, 0] * d[:, 1] - w[:, 1] * d[:, 0]) / safe
    hit = ok & (along >= 0) & (along < 1) & (on_door >= 0) & (on_door <= 1)
    return [(int(i), float(along[i])) for i in np.flatnonzero(hit)]


def _on_site_floors(trace: list[dict[str, Any]], site: Site) -> list[dict[str, Any]]:
    """The trace with each sample's floor one of the site's (an empty or unknown one: the
    first floor, as a single-floor run reports it)."""
    default = site.default_floor
    return [s if s.get("floor") in site.floors else {**s, "floor": default} for s in trace]


def _floor_runs(trace: list[dict[str, Any]]) -> list[tuple[str, list[dict[str, Any]]]]:
    """The trace cut where the floor changes: (floor, samples) in time order."""
    runs: list[tuple[str, list[dict[str, Any]]]] = []
    for s in trace:
        if runs and runs[-1][0] == s["floor"]:
            runs[-1][1].append(s)
        else:
            runs.append((s["floor"], [s]))
    return runs


def _floors_visited(trace: list[dict[str, Any]], site: Site) -> list[str]:
    """Floors in the order first visited; the site's first floor if there is no trace."""
    seen = list(dict.fromkeys(s["floor"] for s in trace))
    return seen or [site.default_floor]


def _map_height_in(site: Site, floors: list[str], width_in: float) -> float:
    """Height of a map row: the tallest floor's aspect at ``width_in``, within 2.5-7 in."""
    aspect = max(site.floors[f].map.shape[0] / site.floors[f].map.shape[1] for f in floors)
    return min(7.0, max(2.5, width_in * aspect + 0.5))


def _draw_floor(
    ax: Axes, site: Site, floor: Floor, trace: list[dict[str, Any]], crossings: list[Crossing]
) -> None:
    """The floor map, its doors and lifts, the path driven on it and what happened there."""
    _draw_map(ax, floor)
    for door in (d for d in site.doors if d.floor == floor.name):
        ax.plot(*zip(door.p1, door.p2, strict=True), color=DOOR_COLOUR, lw=1.0, alpha=0.6)
    for lift in (e for e in site.elevators if e.serves(floor.name)):
        _draw_lift(ax, lift)
    runs = _floor_runs(trace)
    for k, (name, run) in enumerate(runs):
        if name != floor.name:
            continue
        ax.plot([s["x"] for s in run], [s["y"] for s in run], color=PATH_COLOUR, lw=2.2)
        if k + 1 < len(runs):
            _mark_floor_change(ax, run[-1], runs[k + 1][0])
    _mark_ends(ax, trace, floor.name)
    for c in (c for c in crossings if c.floor == floor.name):
        ax.plot(c.x, c.y, "o", ms=7, mfc=DOOR_COLOUR, mec="black", mew=0.8)
        ax.annotate(
            f"{c.door}\n{c.t:.1f} s",
            (c.x, c.y),
            xytext=(7, 7),
            textcoords="offset points",
            fontsize=7,
            bbox={"boxstyle": "round,pad=0.2", "fc": "white", "ec": DOOR_COLOUR, "alpha": 0.85},
        )
    times = [s["t"] for s in trace if s["floor"] == floor.name]
    span = f": {times[0]:.1f}-{times[-1]:.1f} s" if times else ""
    ax.set_title(f"floor {floor.name}{span}", fontsize=9)
    ax.set_xlabel("x (m)", fontsize=8)
    ax.set_ylabel("y (m)", fontsize=8)
    ax.tick_params(labelsize=7)


def _draw_map(ax: Axes, floor: Floor) -> None:
    """The occupancy grid in greys: walls dark, unknown light, free white; metres on axes."""
    grid = floor.map
    img = np.ones(grid.shape)
    img[grid.cells < 0] = UNKNOWN_GREY
    img[grid.occupied(unknown_is_occupied=False)] = WALL_GREY
    x0, y0 = grid.origin[0], grid.origin[1]
    h, w = grid.shape
    extent = (x0, x0 + w * grid.resolution, y0, y0 + h * grid.resolution)
    ax.imshow(
        img,
        cmap="gray",
        vmin=0.0,
        vmax=1.0,
        origin="lower",
        extent=extent,
        interpolation="nearest",
    )
    ax.set_aspect("equal")


def _draw_lift(ax: Axes, lift: Elevator) -> None:
    """The car's outline (depth along ``theta``, out through its door) and its id."""
    c, s = math.cos(lift.theta), math.sin(lift.theta)
    half_d, half_w = lift.depth / 2, lift.width / 2
    corners = [
        (lift.x + c * dx - s * dy, lift.y + s * dx + c * dy)
        for dx, dy in ((-half_d, -half_w), (half_d, -half_w), (half_d, half_w), (-half_d, half_w))
    ]
    ax.add_patch(Polygon(corners, closed=True, fc=LIFT_COLOUR, alpha=0.25, ec=LIFT_COLOUR, lw=1.2))
    ax.text(lift.x, lift.y, lift.id, color=LIFT_COLOUR, fontsize=6, ha="center", va="center")


def _mark_floor_change(ax: Axes, last: dict[str, Any], to_floor: str) -> None:
    ax.plot(last["x"], last["y"], "^", ms=8, mfc=LIFT_COLOUR, mec="black", mew=0.8)
    ax.annotate(
        f"to floor {to_floor}\n{last['t']:.1f} s",
        (last["x"], last["y"]),
        xytext=(7, -16),
        textcoords="offset points",
        fontsize=7,
        color=LIFT_COLOUR,
    )


def _mark_ends(ax: Axes, trace: list[dict[str, Any]], floor: str) -> None:
    """Where the mission started and where the chair stood at its end, on their floors."""
    for sample, colour, marker, text in (
        (trace[0] if trace else None, START_COLOUR, "o", "start"),
        (trace[-1] if trace else None, END_COLOUR, "s", "end"),
    ):
        if sample is None or sample["floor"] != floor:
            continue
        ax.plot(sample["x"], sample["y"], marker, ms=8, mfc=colour, mec="black", mew=0.8)
        ax.annotate(
            text,
            (sample["x"], sample["y"]),
            xytext=(-8, -14),
            textcoords="offset points",
            fontsize=7,
            color=colour,
        )


def _draw_speed(ax: Axes, trace: list[dict[str, Any]], crossings: list[Crossing]) -> None:
    ax.plot([s["t"] for s in trace], [s["speed"] for s in trace], color=PATH_COLOUR, lw=1.5)
    ax.axhline(0.0, color="black", lw=0.5)
    _mark_crossings(ax, crossings, label=True)
    _mark_floor_changes(ax, trace)
    ax.margins(y=0.25)  # room for the door labels at the top
    ax.set_ylabel("speed (m/s)", fontsize=8)
    ax.tick_params(labelsize=7, labelbottom=False)
    ax.grid(alpha=0.3)


def _draw_clearance(
    ax: Axes, trace: list[dict[str, Any]], crossings: list[Crossing], min_m: float | None
) -> None:
    """Clearance of the footprint to the nearest wall; gaps where none was reported yet."""
    values = [np.nan if s.get("clearance") is None else s["clearance"] for s in trace]
    ax.plot([s["t"] for s in trace], values, color=CLEARANCE_COLOUR, lw=1.2)
    ax.axhline(0.0, color=END_COLOUR, lw=0.8, ls="--")
    _mark_crossings(ax, crossings, label=False)
    _mark_floor_changes(ax, trace)
    ax.set_ylabel("clearance (m)", fontsize=8)
    if min_m is not None:
        ax.set_title(f"smallest clearance {min_m:.3f} m", fontsize=8, loc="right")
    ax.tick_params(labelsize=7, labelbottom=False)
    ax.grid(alpha=0.3)


def _mark_crossings(ax: Axes, crossings: list[Crossing], label: bool) -> None:
    for c in crossings:
        ax.axvline(c.t, color=DOOR_COLOUR, lw=1.0, ls=":")
        if label:
            ax.annotate(
                c.door,
                (c.t, 1.0),
                xycoords=("data", "axes fraction"),
                xytext=(2, -2),
                textcoords="offset points",
                fontsize=6,
                color=DOOR_COLOUR,
                va="top",
            )


def _mark_floor_changes(ax: Axes, trace: list[dict[str, Any]]) -> None:
    for before, after in pairwise(trace):
        if before["floor"] != after["floor"]:
            ax.axvline(after["t"], color=LIFT_COLOUR, lw=1.0, ls="--")


def _phase_names(phases: list[dict[str, Any]]) -> list[str]:
    """Phase names in the order they first ran: one timeline row each."""
    return list(dict.fromkeys(p["name"] for p in phases))


def phase_colour(names: list[str], name: str) -> str:
    """The colour of phase ``name``'s bars (by its row, cycling through ten)."""
    return PHASE_COLOURS[names.index(name) % len(PHASE_COLOURS)]


def _draw_phases(ax: Axes, phases: list[dict[str, Any]], names: list[str], end_s: float) -> None:
    """One row per phase name, a bar from each start to its end (a running one: to the end)."""
    for p in phases:
        row = names.index(p["name"])
        stop = p["end_s"] if p.get("end_s") is not None else end_s
        ax.broken_barh(
            [(p["start_s"], max(stop - p["start_s"], 0.0))],
            (row - 0.4, 0.8),
            facecolors=phase_colour(names, p["name"]),
        )
    ax.set_yticks(range(len(names)), names, fontsize=7)
    ax.set_ylim(len(names) - 0.5 if names else 0.5, -0.5)
    ax.set_xlabel("simulation time (s)", fontsize=8)
    ax.tick_params(axis="x", labelsize=7)
    ax.grid(axis="x", alpha=0.3)


def _title(report: dict[str, Any]) -> str:
    outcome = "success" if report.get("success") else "FAILURE"
    reason = str(report.get("reason", ""))[:90]
    return (
        f"{report.get('scenario', 'mission')}: {outcome} ({reason}) - "
        f"{report.get('path_length_m', 0):.1f} m in {report.get('sim_time_s', 0):.1f} s, "
        f"{report.get('collisions', 0)} collision(s)"
    )


def _file_name(scenario: str) -> str:
    """The scenario's name, safe as a file name."""
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", scenario) or "mission"
