"""``wheelnav bench``: the performance benchmarks, each printing figures against a peer or limit."""

from __future__ import annotations

import argparse
import importlib
import sys

BENCHES = {
    "planner": ("wheelnav.bench.planner", "A* vs pyastar2d on 800 x 4000, inflation"),
    "mpc": ("wheelnav.bench.mpc", "MPC cycle time, 1000 x 21 and 2000 x 56"),
    "sim": ("wheelnav.bench.sim", "real-time factor with the 3D LiDAR, ray casting per scan"),
    "fleet": ("wheelnav.bench.fleet", "the whole fleet's real-time factor in lockstep, per tick"),
    "doors": ("wheelnav.bench.doors", "the narrow-door campaign: one door, random starts"),
    "codec": ("wheelnav.bench.codec", "encode and decode per message type vs msgpack alone"),
}


def add_commands(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "bench", help="run a performance benchmark", description=__doc__.splitlines()[0]
    )
    p.add_argument(
        "name", choices=sorted(BENCHES), help="; ".join(f"{k}: {v[1]}" for k, v in BENCHES.items())
    )
    p.add_argument("rest", nargs=argparse.REMAINDER, help="options of the benchmark (--json...)")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Run one benchmark; a missing optional peer (``.[bench]``) is one line, status 2."""
    module = importlib.import_module(BENCHES[args.name][0])
    try:
        return int(module.main(args.rest) or 0)
    except ImportError as exc:
        print(f"wheelnav bench {args.name}: {exc}", file=sys.stderr)
        return 2
