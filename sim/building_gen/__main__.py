"""``python -m sim.building_gen SEED OUTDIR [--floors N] [--count K]``: draw buildings.

One building goes into OUTDIR itself; with ``--count K`` buildings SEED..SEED+K-1 go into
OUTDIR/seed_<n>. ``--world-differs`` also draws each building's world apart from its map
(``world/``, :mod:`sim.building_gen.world`). Prints one summary line per building.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from sim.building_gen import GenOptions, generate_building


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("seed", type=int)
    parser.add_argument("outdir", type=Path)
    parser.add_argument("--floors", type=int, help="exactly this many floors (1-3)")
    parser.add_argument("--count", type=int, default=1, help="how many buildings")
    parser.add_argument("--missions", type=int, default=8, help="missions per building")
    parser.add_argument(
        "--world-differs",
        action="store_true",
        help="also draw the world (OUTDIR/world) apart from the map: doors, furniture, a "
        "wall, people",
    )
    args = parser.parse_args(argv)
    opts = GenOptions(missions=args.missions, world_differs=args.world_differs)
    if args.floors is not None:
        opts.floors = (args.floors, args.floors)
    for seed in range(args.seed, args.seed + args.count):
        folder = args.outdir if args.count == 1 else args.outdir / f"seed_{seed}"
        t0 = time.perf_counter()
        built = generate_building(seed, folder, opts)
        print(f"{built.summary()} [{time.perf_counter() - t0:.1f} s] -> {folder}")


if __name__ == "__main__":
    main()
