"""``wheelnav mission``: argument parsing for the mission runner."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from services.mission.core import load_scenario
from services.mission.node import MissionRun, format_report, write_report
from shared.service import add_override_argument


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
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    scenario = load_scenario(args.scenario, args.overrides)
    rrd = str(Path(args.rrd).resolve()) if args.rrd else None
    report = MissionRun(scenario, quiet=args.quiet, rrd=rrd).run()
    if args.report:
        write_report(report, args.report)
    print(json.dumps(report, indent=2) if args.json else format_report(report))
    if args.report:
        print(f"report written to {args.report}", file=sys.stderr)
    return 0 if report["success"] else 1
