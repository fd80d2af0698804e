"""``wheelnav mission``: argument parsing for the mission runner."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from shared.service import add_override_argument
from shared.site import load_site
from wheelnav.mission.report import format_report, write_report
from wheelnav.mission.run import MissionRun
from wheelnav.mission.scenario import Scenario, load_scenario

PLOTS_HELP = "draw each run into DIR/<scenario>.png: path over the map, speed, clearance, phases"


def add_commands(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "mission",
        help="run the fleet for one scenario and report",
        description="Run the fleet for one scenario (docs/scenarios.md) and report.",
    )
    p.add_argument("scenario", help="scenario YAML")
    p.add_argument("--report", metavar="FILE", help="write the JSON report here")
    add_override_argument(p)
    p.add_argument("--rrd", metavar="FILE", help="record the run for the rerun viewer")
    p.add_argument("--quiet", action="store_true", help="only print the report")
    p.add_argument("--json", action="store_true", help="print the report as JSON")
    p.add_argument("--plots", metavar="DIR", help=PLOTS_HELP)
    p.set_defaults(run=run)
    t = sub.add_parser(
        "scenarios",
        help="run several scenarios and print a table",
        description="Run each scenario in turn (quietly) and print one table of the results.",
    )
    t.add_argument("scenarios", nargs="+", help="scenario YAML files")
    t.add_argument("--reports", metavar="DIR", help="write each JSON report into DIR")
    t.add_argument("--plots", metavar="DIR", help=PLOTS_HELP)
    add_override_argument(t)
    t.set_defaults(run=run_table)


def run_table(args: argparse.Namespace) -> int:
    """One mission after the other; a table of outcomes, then one of checkpoints.

    Exit code 1 if any scenario's outcome is not the one it expects (``expect``)."""
    rows = []
    for path in args.scenarios:
        scenario = load_scenario(path, args.overrides)
        print(f"running {scenario.name} ...", file=sys.stderr, flush=True)
        report = MissionRun(scenario, quiet=True).run()
        report["expected"] = scenario.expect
        if args.reports:
            Path(args.reports).mkdir(parents=True, exist_ok=True)
            write_report(report, Path(args.reports) / f"{scenario.name}.json")
        if args.plots:
            write_plots(report, scenario, args.plots)
        rows.append(report)
    print(format_table(rows))
    print()
    print(format_checkpoint_table(rows))
    return 0 if all(_as_expected(r) for r in rows) else 1


def _as_expected(report: dict) -> bool:
    wanted = report.get("expected", "success") == "success"
    return report["success"] == wanted and report["collisions"] == 0


def format_table(reports: list[dict]) -> str:
    """The scenarios table (reason shortened to fit a terminal line)."""
    head = (
        f"{'scenario':24s} {'result':8s} {'ok':3s} {'coll':>4s} {'clear m':>7s} {'sim s':>7s} "
        f"{'wall s':>7s} {'loc cm':>6s}  reason"
    )
    lines = [head, "-" * len(head)]
    for r in reports:
        loc = r["localisation_error"]["rms_m"]
        clear = r["min_clearance_m"]
        lines.append(
            f"{r['scenario'][:24]:24s} {'success' if r['success'] else 'FAILURE':8s} "
            f"{'yes' if _as_expected(r) else 'NO':3s} "
            f"{r['collisions']:4d} {clear if clear is not None else float('nan'):7.3f} "
            f"{r['sim_time_s']:7.1f} {r['wall_time_s']:7.1f} "
            f"{100 * loc if loc is not None else float('nan'):6.1f}  {r['reason'][:60]}"
        )
    return "\n".join(lines)


def format_checkpoint_table(reports: list[dict]) -> str:
    """Every checkpoint of every run: Phase 0 figures, wait, crossing, phase times."""
    head = (
        f"{'scenario':24s} {'checkpoint':14s} {'result':9s} {'pos m':>6s} {'hdg deg':>7s} "
        f"{'corr s':>6s} {'wait s':>6s} {'lat m':>6s}  phases (s)"
    )
    lines = [head, "-" * len(head)]

    def num(value, fmt: str) -> str:
        return "-" if value is None else format(value, fmt)

    for r in reports:
        for c in r.get("checkpoints", []):
            lat = c.get("lateral_offset_m") if c["kind"] == "door" else None
            phases = " ".join(f"{k} {v:g}" for k, v in c.get("phases", {}).items())
            lines.append(
                f"{r['scenario'][:24]:24s} {c['id'][:14]:14s} {c.get('result', ''):9s} "
                f"{num(c['position_error_m'], '6.3f'):>6s} "
                f"{num(c['heading_error_deg'], '7.2f'):>7s} "
                f"{num(c.get('correction_s'), '6.1f'):>6s} {num(c['wait_s'], '6.1f'):>6s} "
                f"{num(lat, '6.3f'):>6s}  {phases}"
            )
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    scenario = load_scenario(args.scenario, args.overrides)
    rrd = str(Path(args.rrd).resolve()) if args.rrd else None
    report = MissionRun(scenario, quiet=args.quiet, rrd=rrd).run()
    if args.report:
        write_report(report, args.report)
    print(json.dumps(report, indent=2) if args.json else format_report(report))
    if args.report:
        print(f"report written to {args.report}", file=sys.stderr)
    if args.plots:
        write_plots(report, scenario, args.plots)
    return 0 if report["success"] else 1


def write_plots(report: dict, scenario: Scenario, out_dir: str) -> None:
    """Draw the run into ``out_dir`` (docs/scenarios.md). matplotlib is imported only here,
    so the other ``wheelnav`` commands start without it."""
    from wheelnav.mission import plots

    paths = plots.write_plots(report, load_site(scenario.config.site), out_dir)
    print(f"plots written to {', '.join(str(p) for p in paths)}", file=sys.stderr)
