"""``wheelnav bench fleet``: the whole fleet's real-time factor in lockstep, and where a tick goes.

Runs a scenario (the demo by default) as ``wheelnav mission`` does, with every config
default, and listens to the simulator's lockstep profile (``sim/profile``): per tick, the
wall time of the simulator's own step (chair, LiDAR), of its publishing, of each lockstep
stage (from announcing the tick to the last answer) and of its pacing; per participant,
the time its steps took. A stage's wait beyond its slowest participant's compute is
messaging and scheduling. The limit is 10x real time (issue: fast lockstep).

``--set launcher.in_process=true`` runs the fleet as threads of the bench's own process
(wheelnav/launcher/in_process.py); the CPU table is then by the service each thread works
for, and one row holds the fleet's one dispatcher: every service's deliveries and the
lockstep steps they run (the stage table splits those by service). ``--compare`` runs
the scenario both ways, one after the other, and prints the two factors side by side.
"""

from __future__ import annotations

import argparse
import json
import os
from pathlib import Path
from typing import Any

from shared.messages import LockstepProfile
from shared.service import add_override_argument
from wheelnav.bench.cpu import cpu_seconds, thread_cpu_seconds
from wheelnav.mission.run import MissionRun
from wheelnav.mission.scenario import load_scenario

DEMO = Path(__file__).resolve().parents[2] / "scenarios" / "demo.yaml"
TARGET = 10.0
# the CPU is read at the first profile and then every CPU_EVERY-th (the simulator sends one
# every 50 ticks): reading /proc for every thread took about 1 ms, which in process the
# tick it lands in pays (1 % of the demo's wall time when read at every profile)
CPU_EVERY = 5


class ProfiledRun(MissionRun):
    """A mission run that keeps the simulator's latest lockstep profile, and the fleet's
    CPU seconds at the first and the latest profile (with their tick counts)."""

    profile: LockstepProfile | None = None
    cpu_first: tuple[int, dict[str, float]] | None = None
    cpu_last: tuple[int, dict[str, float]] | None = None

    def _wire(self, bus) -> None:
        super()._wire(bus)
        bus.subscribe(self.keys.sim_profile, LockstepProfile, self._on_profile)

    profiles = 0

    def _on_profile(self, msg: LockstepProfile) -> None:
        self.profile = msg
        self.profiles += 1
        if self.cpu_first is not None and self.profiles % CPU_EVERY:
            return
        threads = self.scenario.config.launcher.in_process
        reading = (msg.ticks, thread_cpu_seconds() if threads else cpu_seconds())
        if self.cpu_first is None:
            self.cpu_first = reading
        else:
            self.cpu_last = reading


def cpu_rows(
    first: tuple[int, dict[str, float]] | None,
    last: tuple[int, dict[str, float]] | None,
    dt: float,
    cores: int,
) -> dict[str, Any] | None:
    """CPU milliseconds per tick by process between two readings, their sum, and the
    real-time factor that sum allows on ``cores`` cores (None without two readings)."""
    if first is None or last is None or last[0] <= first[0] or not last[1]:
        return None
    ticks = last[0] - first[0]
    per_tick = {
        name: 1e3 * (used - first[1].get(name, 0.0)) / ticks for name, used in last[1].items()
    }
    total = sum(per_tick.values())
    return {
        "cpu_ms": {k: round(v, 3) for k, v in sorted(per_tick.items(), key=lambda kv: -kv[1])},
        "cpu_total_ms": round(total, 3),
        "cores": cores,
        "cpu_bound_factor": round(cores * 1e3 * dt / total, 2) if total > 0 else 0.0,
    }


def summarise(
    p: LockstepProfile, stages: list[list[str]], side_by_side: bool = True
) -> dict[str, Any]:
    """Per-tick wall milliseconds of each part, and the real-time factor.

    ``side_by_side``: a stage's participants step at once (a process each), so a stage's
    compute is its slowest participant's; False (the fleet in one process, one interpreter
    lock): they step one after another, so it is their sum.
    """
    n = max(1, p.ticks)
    ms = 1e3 / n
    rows: list[tuple[str, float]] = [("simulator step (chair, LiDAR)", p.physics_s * ms)]
    rows.append(("simulator publishing", p.publish_s * ms))
    compute = dict(zip(p.participants, p.compute_s, strict=True))
    steps = dict(zip(p.participants, p.steps, strict=True))
    # the floor of a tick in series: the simulator's step, then each stage's compute (its
    # slowest participant, or all of them one after another), with no messaging at all
    serial_s = p.physics_s
    for k, wait in enumerate(p.stage_wait_s):
        names = stages[k] if k < len(stages) else []
        stage_s = [compute[name] for name in names if name in compute]
        serial_s += max(stage_s, default=0.0) if side_by_side else sum(stage_s)
        rows.append((f"stage {k} wait ({', '.join(names)})", wait * ms))
        for name in names:
            if name in compute:
                per_step = 1e3 * compute[name] / max(1, steps[name])
                rows.append(
                    (
                        f"    {name} compute ({per_step:.2f} ms x {steps[name] / n:.2f}/tick)",
                        compute[name] * ms,
                    )
                )
    rows.append(("simulator pacing", p.pacing_s * ms))
    accounted = p.physics_s + p.publish_s + sum(p.stage_wait_s) + p.pacing_s
    rows.append(("other (loop, locks)", max(0.0, p.wall_s - accounted) * ms))
    sim_s = p.ticks * p.dt
    return {
        "ticks": p.ticks,
        "sim_s": round(sim_s, 3),
        "wall_s": round(p.wall_s, 3),
        "realtime_factor": round(sim_s / p.wall_s, 2) if p.wall_s > 0 else 0.0,
        "tick_ms": round(p.wall_s * ms, 3),
        "rows": [(name, round(value, 3)) for name, value in rows],
        "serial_compute_ms": round(serial_s * ms, 3),
        "stage_compute": "slowest participant" if side_by_side else "participants in turn",
        "compute_bound_factor": round(sim_s / serial_s, 2) if serial_s > 0 else 0.0,
        # how much of that bound the run reached (the rest: messaging, hand-overs)
        "share_of_bound": round(serial_s / p.wall_s, 3) if p.wall_s > 0 else 0.0,
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="wheelnav bench fleet", description=__doc__.splitlines()[0]
    )
    parser.add_argument("scenario", nargs="?", default=str(DEMO), help="scenario YAML (the demo)")
    parser.add_argument("--json", action="store_true", help="print the figures as JSON")
    parser.add_argument(
        "--compare",
        action="store_true",
        help="run with a process per service, then in process, and print both factors",
    )
    add_override_argument(parser)
    args = parser.parse_args(argv)
    if not args.compare:
        figures = bench(args.scenario, args.overrides)
        if args.json:
            print(json.dumps(figures, indent=2))
        else:
            print_figures(figures)
        return 0 if figures.get("success") else 1
    runs = {
        mode: bench(args.scenario, [*args.overrides, f"launcher.in_process={flag}"])
        for mode, flag in (("processes", "false"), ("in process", "true"))
    }
    if args.json:
        print(json.dumps(runs, indent=2))
    else:
        for mode, figures in runs.items():
            print(f"== {mode}")
            print_figures(figures)
            print()
        a, b = (runs[m].get("realtime_factor", 0.0) for m in ("processes", "in process"))
        ratio = f"{b / a:.2f}x the processes'" if a > 0 else "no ratio"
        print(f"real-time factor: processes {a:.1f}, in process {b:.1f} ({ratio})")
    return 0 if all(f.get("success") for f in runs.values()) else 1


def bench(scenario_path: str, overrides: list[str]) -> dict[str, Any]:
    """Run ``scenario_path`` with ``overrides``: its figures (``success`` False, with the
    reason, if no lockstep profile was heard)."""
    scenario = load_scenario(scenario_path, overrides)
    run = ProfiledRun(scenario, quiet=True)
    report = run.run()
    if run.profile is None:
        return {"scenario": scenario.name, "success": False, "error": report["reason"]}
    in_process = scenario.config.launcher.in_process
    figures = summarise(run.profile, scenario.config.sim.lockstep_stages, not in_process)
    cores = 1 if in_process else os.cpu_count() or 1
    cpu = cpu_rows(run.cpu_first, run.cpu_last, run.profile.dt, cores)
    if cpu is not None:
        figures.update(cpu)
    figures["dt"] = run.profile.dt
    figures["in_process"] = in_process
    figures["scenario"] = scenario.name
    figures["success"] = report["success"]
    return figures


def print_figures(figures: dict[str, Any]) -> None:
    """The figures of one run as the bench prints them."""
    if "error" in figures:
        print(f"no lockstep profile heard: {figures['error']}")
        return
    print(
        f"{figures['scenario']}: {figures['sim_s']:.1f} s simulated in {figures['wall_s']:.1f} s"
        f" of wall time (from the first tick): real-time factor"
        f" {figures['realtime_factor']:.1f} (limit >= {TARGET:.0f}), mission"
        f" {'succeeded' if figures['success'] else 'FAILED'}"
        + (" (fleet in process)" if figures["in_process"] else "")
    )
    tick = f"{figures['ticks']} ticks of {1e3 * figures['dt']:.0f} ms"
    print(f"where a tick's wall time goes ({tick}):")
    print(f"  {'part':58s} {'ms/tick':>8s} {'share':>6s}")
    total = figures["tick_ms"]
    for name, value in figures["rows"]:
        share = f"{100 * value / total:5.1f}%" if total > 0 and not name.startswith("    ") else ""
        print(f"  {name:58s} {value:8.3f} {share:>6s}")
    print(f"  {'total':58s} {total:8.3f}")
    print(
        f"the stages' own compute in series (the simulator's step, then each stage's"
        f" {figures['stage_compute']}) is {figures['serial_compute_ms']:.2f} ms a tick: with"
        f" no messaging at"
        f" all, lockstep would run at most {figures['compute_bound_factor']:.1f}x real time;"
        f" this run reached {100 * figures['share_of_bound']:.0f}% of that bound"
    )
    if "cpu_ms" not in figures:
        return
    by = "the service each thread works for" if figures["in_process"] else "process"
    print(f"CPU a tick costs, by {by} (its threads and Zenoh's, from /proc):")
    for name, value in figures["cpu_ms"].items():
        print(f"  {name:58s} {value:8.3f}")
    print(f"  {'total':58s} {figures['cpu_total_ms']:8.3f}")
    if figures["in_process"]:
        print(
            f"under one interpreter lock (one core for the Python work) that CPU allows about"
            f" {figures['cpu_bound_factor']:.1f}x real time"
        )
    else:
        print(
            f"on {figures['cores']} cores that CPU allows at most"
            f" {figures['cpu_bound_factor']:.1f}x real time, with every core busy all the time"
        )
