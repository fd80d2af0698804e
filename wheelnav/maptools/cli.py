"""``wheelnav plan`` and ``wheelnav rooms``: the planner and the room segmentation on a map.

wheelnav plan MAP_OR_SITE --start X,Y --goal X,Y [--floor F] [--radius M] [--json]
              [--repeat N] [--png FILE]
wheelnav rooms MAP_OR_SITE [--floor F] [--json] [--png FILE]

Errors (a missing file, a point outside the map or blocked, no route, bad coordinates, an
unknown floor) print one line to stderr, with ``--json`` also ``{"ok": false, "error":
...}`` to stdout, and exit with status 2.
"""

from __future__ import annotations

import argparse
import json
import math
import re
import sys
from collections.abc import Sequence

from services.planner.errors import BadRequest, PlanError
from shared.config import ConfigError, load
from shared.site import load_site
from wheelnav.maptools import pictures, report
from wheelnav.maptools.plan import plan_route
from wheelnav.maptools.rooms import floor_rooms

COORDINATE_OPTIONS = ("--start", "--goal", "--radius")
_NEGATIVE_VALUE = re.compile(r"^-[\d.]")


def add_commands(sub: argparse._SubParsersAction) -> None:
    """Add ``plan`` and ``rooms`` to the ``wheelnav`` command."""
    p = sub.add_parser(
        "plan",
        help="plan a route on a map or site and print it",
        description="Plan a route on one floor as the planner service would, and print it "
        "(path, waypoints, speeds, the doors it passes, the planning time).",
        epilog="example: wheelnav plan sites/two_rooms --start 2,2.7 --goal 10.5,2.7 --json",
    )
    p.add_argument("site", metavar="MAP_OR_SITE", help="site folder, site.yaml or map YAML")
    p.add_argument("--start", required=True, metavar="X,Y", help="start in metres, map frame")
    p.add_argument("--goal", required=True, metavar="X,Y", help="goal in metres, map frame")
    p.add_argument("--floor", default="", help="floor name (default: the first)")
    p.add_argument(
        "--radius", type=float, metavar="M", help="inflation radius in metres (default: chair's)"
    )
    p.add_argument("--repeat", type=int, metavar="N", help="time the plan N times (a list)")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument("--png", metavar="FILE", help="draw map, inflation, path and checkpoints")
    p.set_defaults(run=run_plan)
    _accept_negative_values(p)

    r = sub.add_parser(
        "rooms",
        help="list a floor's rooms and doors",
        description="Segment a floor into rooms and print them and the doors between them.",
    )
    r.add_argument("site", metavar="MAP_OR_SITE", help="site folder, site.yaml or map YAML")
    r.add_argument("--floor", default="", help="floor name (default: the first)")
    r.add_argument("--json", action="store_true", help="print one JSON object")
    r.add_argument("--png", metavar="FILE", help="draw each room in its own colour, and doors")
    r.set_defaults(run=run_rooms)


def run_plan(args: argparse.Namespace) -> int:
    """Plan and print the route (text or JSON), and draw it with ``--png``."""
    try:
        start = parse_xy(args.start, "start")
        goal = parse_xy(args.goal, "goal")
        site = load_site(args.site)
        result = plan_route(
            site,
            args.floor,
            start,
            goal,
            load(None, []),
            args.radius,
            1 if args.repeat is None else args.repeat,
        )
        scale = pictures.plan_picture(result, args.png) if args.png else None
    except (ConfigError, PlanError, OSError) as exc:
        return fail(exc, args.json)
    if args.json:
        out = report.plan_json(result, args.repeat)
        print(json.dumps(_with_png(out, args.png, scale)))
    else:
        print(report.plan_text(result))
        if args.png:
            print(f"picture: {args.png} ({scale} px per cell)")
    return 0


def run_rooms(args: argparse.Namespace) -> int:
    """Segment the floor and print its rooms and doors, and draw them with ``--png``."""
    try:
        floor = floor_rooms(load_site(args.site), args.floor)
        scale = pictures.rooms_picture(floor, args.png) if args.png else None
    except (ConfigError, OSError) as exc:
        return fail(exc, args.json)
    if args.json:
        print(json.dumps(_with_png(report.rooms_json(floor), args.png, scale)))
    else:
        print(report.rooms_text(floor))
        if args.png:
            print(f"picture: {args.png} ({scale} px per cell)")
    return 0


def parse_xy(text: str, what: str) -> tuple[float, float]:
    """``"X,Y"`` in metres as a point; BadRequest naming ``what`` for anything else."""
    parts = text.split(",")
    try:
        x, y = (float(v) for v in parts)
    except ValueError:
        raise BadRequest(f"{what} {text!r}: expected X,Y in metres, e.g. 2.0,-3.5") from None
    if not (math.isfinite(x) and math.isfinite(y)):
        raise BadRequest(f"{what} {text!r}: coordinates must be finite numbers")
    return x, y


def fail(exc: Exception, as_json: bool) -> int:
    """Report ``exc`` in one line (stderr; also JSON on stdout with ``--json``); status 2."""
    message = " ".join(str(exc).split()) or type(exc).__name__
    if isinstance(exc, OSError):
        message = f"{exc.filename or ''}: {exc.strerror or message}".lstrip(": ")
    print(f"wheelnav: {message}", file=sys.stderr)
    if as_json:
        code = getattr(exc, "code", "SITE_ERROR" if isinstance(exc, ConfigError) else "IO_ERROR")
        print(json.dumps({"ok": False, "error": message, "code": code}))
    return 2


def join_negative_values(args: Sequence[str]) -> list[str]:
    """``--start -6.5,3`` as ``--start=-6.5,3``: argparse takes a value that starts with
    '-' (and is not a plain number) for an option of its own and refuses it."""
    out: list[str] = []
    i = 0
    while i < len(args):
        if (
            args[i] in COORDINATE_OPTIONS
            and i + 1 < len(args)
            and _NEGATIVE_VALUE.match(args[i + 1])
        ):
            out.append(f"{args[i]}={args[i + 1]}")
            i += 2
        else:
            out.append(args[i])
            i += 1
    return out


def _accept_negative_values(parser: argparse.ArgumentParser) -> None:
    """Make ``parser`` join negative coordinates to their option before parsing; the
    ``wheelnav`` parser hands a subcommand its arguments through ``parse_known_args``."""
    parse = parser.parse_known_args

    def parse_known_args(args=None, namespace=None):
        args = sys.argv[1:] if args is None else args
        return parse(join_negative_values(list(args)), namespace)

    parser.parse_known_args = parse_known_args


def _with_png(out: dict, png: str | None, scale: int | None) -> dict:
    if png:
        out.update(png=png, png_scale=scale)
    return out
