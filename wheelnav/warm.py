"""``wheelnav warm``: compile every numba kernel of the stack into numba's on-disk cache.

The services' kernels (``@numba.njit(cache=True)``) are compiled the first time they run
and cached beside their sources (``__pycache__/*.nbi``, ``*.nbc``; under
``NUMBA_CACHE_DIR`` if set). On a fresh clone, install or image that first fleet start spent
~25 s compiling (idle 2-core machine; over 60 s on a loaded one, past the launcher's
readiness wait). This command calls each kernel module's ``warm_up()`` ahead of it (the
planner, the localisation and the controller warm theirs at start too, but only the
simulator's first scan compiles its LiDAR kernels), so the services load them instead.

The cache holds the sources it was built from (a file edited since is compiled again) and
the CPU it was built on: run it in the tree the services import, on their machine
(``python -m wheelnav.warm`` imports the tree of the current directory first).
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys
import time
from types import ModuleType
from typing import TextIO

# Every module with cached kernels, cheapest first (tests/wheelnav/test_warm.py checks the
# list against the sources' ``cache=True``)
MODULES = (
    "shared.geometry",
    "shared.scan_band",
    "shared.door_scan_numba",
    "shared.door_scan",
    "services.controller.door_bezier",
    "services.controller.edt",
    "services.controller.mpc_scene",
    "services.controller.scan_frame",
    "services.controller.safety",
    "services.controller.manoeuvre",
    "services.planner.grid_astar",
    "services.controller.mpc_guides",
    "sim.lidar3d",
    "services.localisation.matcher",
    "services.localisation.relocalise",
    "services.controller.mpc_numba",
)


DESCRIPTION = (
    "Compile every numba kernel of the stack into numba's on-disk cache (beside the sources, "
    "or NUMBA_CACHE_DIR), so that the services' first start on a fresh clone, install or "
    "image loads them instead of compiling for ~25 s. Prints one line per module and the "
    "total; exit 1 names each module that failed."
)


def warm(modules: tuple[str, ...] = MODULES, out: TextIO | None = None) -> int:
    """Warm up ``modules`` in turn; one line per module (seconds, kernels compiled or loaded
    from the cache), then the total. 0 if every one warmed a kernel, else 1 with a line on
    stderr naming each module that failed."""
    out = out or sys.stdout
    start = time.perf_counter()
    import numba  # noqa: F401  (its import is not the first module's time)

    failed, compiled, loaded, caches = 0, 0, 0, set()
    for name in modules:
        t0 = time.perf_counter()
        try:
            module = importlib.import_module(name)
            module.warm_up()
        except Exception as exc:  # whatever failed: named, and the others still warmed
            failed += 1
            print(
                f"wheelnav warm: {name}: kernel failed to compile: {_one_line(exc)}",
                file=sys.stderr,
            )
            continue
        misses, hits, paths = _kernel_stats(module)
        if misses + hits == 0:
            failed += 1
            print(f"wheelnav warm: {name}: warm_up() ran none of its kernels", file=sys.stderr)
            continue
        compiled, loaded, caches = compiled + misses, loaded + hits, caches | paths
        what = ", ".join(f"{n} {word}" for n, word in ((misses, "compiled"), (hits, "loaded")) if n)
        print(f"{time.perf_counter() - t0:6.1f} s  {name:<34} {what}", file=out, flush=True)
    where = os.path.commonpath(sorted(caches)) if caches else "-"
    print(
        f"{time.perf_counter() - start:6.1f} s  total: {len(modules) - failed} of "
        f"{len(modules)} modules, {compiled} kernels compiled, {loaded} loaded from the "
        f"cache (under {where})",
        file=out,
        flush=True,
    )
    return 1 if failed else 0


def _kernel_stats(module: ModuleType) -> tuple[int, int, set[str]]:
    """Signatures compiled and loaded from the cache so far by the module's own kernels,
    and their cache directories."""
    from numba.core.dispatcher import Dispatcher

    misses, hits, paths = 0, 0, set()
    for obj in vars(module).values():
        if isinstance(obj, Dispatcher) and obj.py_func.__module__ == module.__name__:
            stats = obj.stats
            misses += len(stats.cache_misses)
            hits += len(stats.cache_hits)
            if stats.cache_misses or stats.cache_hits:
                paths.add(str(stats.cache_path))
    return misses, hits, paths


def _one_line(exc: BaseException) -> str:
    """The gist of an error on one line: numba's first line ("Failed in nopython mode
    pipeline ...") says less than the next one."""
    lines = [line.strip() for line in str(exc).splitlines() if line.strip()]
    gist = next((line for line in lines if not line.startswith("Failed in ")), "")
    return f"{type(exc).__name__}: {gist or (lines[0] if lines else '')}"[:300]


def add_commands(sub: argparse._SubParsersAction) -> None:
    """``wheelnav warm``."""
    p = sub.add_parser(
        "warm",
        help="compile the numba kernels into their cache ahead of the first start",
        description=DESCRIPTION,
    )
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    return warm()


def main(argv: list[str] | None = None) -> int:
    """``python -m wheelnav.warm``: the same as ``wheelnav warm``."""
    parser = argparse.ArgumentParser(prog="python -m wheelnav.warm", description=DESCRIPTION)
    parser.parse_args(argv)
    return warm()


if __name__ == "__main__":
    sys.exit(main())
