"""``wheelnav bench fleet``: the whole fleet's real-time factor in lockstep, and where a tick goes.

Runs a scenario (the demo by default) as ``wheelnav mission`` does, with every config
default, and listens to the simulator's lockstep profile (``sim/profile``): per tick, the
wall time of the simulator's own step (chair, LiDAR), of its publishing, of each lockstep
stage (from announcing the tick to the last answer) and of its pacing; per participant,
the time its steps took. A stage's wait beyond its slowest participant's compute is
messaging and scheduling. The limit is 10x real time (issue: fast lockstep).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path
from typing import Any

from shared.messages import LockstepProfile
from wheelnav.bench.cpu import cpu_seconds
from wheelnav.mission.run import MissionRun
from wheelnav.mission.scenario import load_scenario

DEMO = Path(__file__).resolve().parents[2] / "scenarios" / "demo.yaml"
TARGET = 10.0


class ProfiledRun(MissionRun):
    """A mission run that keeps the simulator's latest lockstep profile, and the fleet's
    CPU seconds at the first and the latest profile (with their tick counts)."""

    profile: LockstepProfile | None = None
    cpu_first: tuple[int, dict[str, float]] | None = None
    cpu_last: tuple[int, dict[str, float]] | None = None

    def _wire(self, bus) -> None:
        super()._wire(bus)
        bus.subscribe(self.keys.sim_profile, LockstepProfile, self._on_profile)

    def _on_profile(self, msg: LockstepProfile) -> None:
        self.profile = msg
        reading = (msg.ticks, cpu_seconds())
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


def summarise(p: LockstepProfile, stages: list[list[str]]) -> dict[str, Any]:
    """Per-tick wall milliseconds of each part, and the real-time factor."""
    n = max(1, p.ticks)
    ms = 1e3 / n
    rows: list[tuple[str, float]] = [("simulator step (chair, LiDAR)", p.physics_s * ms)]
    rows.append(("simulator publishing", p.publish_s * ms))
    compute = dict(zip(p.participants, p.compute_s, strict=True))
    steps = dict(zip(p.participants, p.steps, strict=True))
    for k, wait in enumerate(p.stage_wait_s):
        names = stages[k] if k < len(stages) else []
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
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="wheelnav bench fleet", description=__doc__.splitlines()[0]
    )
    parser.add_argument("scenario", nargs="?", default=str(DEMO), help="scenario YAML (the demo)")
    parser.add_argument("--json", action="store_true", help="print the figures as JSON")
    args = parser.parse_args(argv)
    scenario = load_scenario(args.scenario)
    run = ProfiledRun(scenario, quiet=True)
    report = run.run()
    if run.profile is None:
        print(f"no lockstep profile heard: {report['reason']}", file=sys.stderr)
        return 1
    figures = summarise(run.profile, scenario.config.sim.lockstep_stages)
    cpu = cpu_rows(run.cpu_first, run.cpu_last, run.profile.dt, os.cpu_count() or 1)
    if cpu is not None:
        figures.update(cpu)
    figures["scenario"] = scenario.name
    figures["success"] = report["success"]
    if args.json:
        print(json.dumps(figures, indent=2))
        return 0 if report["success"] else 1
    print(
        f"{scenario.name}: {figures['sim_s']:.1f} s simulated in {figures['wall_s']:.1f} s of "
        f"wall time (from the first tick): real-time factor {figures['realtime_factor']:.1f}"
        f" (limit >= {TARGET:.0f}), mission {'succeeded' if report['success'] else 'FAILED'}"
    )
    tick = f"{figures['ticks']} ticks of {1e3 * run.profile.dt:.0f} ms"
    print(f"where a tick's wall time goes ({tick}):")
    print(f"  {'part':58s} {'ms/tick':>8s} {'share':>6s}")
    total = figures["tick_ms"]
    for name, value in figures["rows"]:
        share = f"{100 * value / total:5.1f}%" if total > 0 and not name.startswith("    ") else ""
        print(f"  {name:58s} {value:8.3f} {share:>6s}")
    print(f"  {'total':58s} {total:8.3f}")
    if cpu is not None:
        print("CPU a tick costs, by process (its threads and Zenoh's, from /proc):")
        for name, value in cpu["cpu_ms"].items():
            print(f"  {name:58s} {value:8.3f}")
        print(f"  {'total':58s} {cpu['cpu_total_ms']:8.3f}")
        print(
            f"on {cpu['cores']} cores that CPU allows at most {cpu['cpu_bound_factor']:.1f}x real"
            " time, with every core busy all the time"
        )
    return 0 if report["success"] else 1
