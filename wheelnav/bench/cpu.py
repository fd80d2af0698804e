"""CPU time of this process and every process it started, read from Linux's /proc.

``wheelnav bench fleet`` takes a reading at two lockstep profiles and divides by the ticks
between them: the CPU a tick costs, summed over the fleet (the processes' own threads and
Zenoh's), is what bounds the real-time factor on a machine of few cores, whatever the
scheduling. Elsewhere than Linux the readings are empty and the bench leaves the table out.
"""

from __future__ import annotations

import os
import threading
from pathlib import Path

from shared.transport import FLEET_DISPATCHER

PROC = Path("/proc")
_TICK_S = 1.0 / os.sysconf("SC_CLK_TCK") if hasattr(os, "sysconf") else 0.01


def _fields(path: Path) -> list[str] | None:
    """The fields of a process's or thread's ``stat`` after its name, None if it is gone."""
    try:
        text = path.read_text()
    except OSError:
        return None
    return text[text.rindex(")") + 2 :].split()  # the name may hold spaces and ")"


def _stat(pid: int) -> tuple[int, float] | None:
    """(parent pid, user + system CPU seconds) of ``pid``, None if it is gone."""
    fields = _fields(PROC / str(pid) / "stat")
    if fields is None:
        return None
    return int(fields[1]), (int(fields[11]) + int(fields[12])) * _TICK_S


def _name(pid: int) -> str:
    """A short name from the command line: the module after ``-m`` (services.sim.node ->
    sim, wheelnav.launcher.router -> router), else the program's file name."""
    try:
        argv = (PROC / str(pid) / "cmdline").read_bytes().split(b"\0")
    except OSError:
        return str(pid)
    args = [a.decode(errors="replace") for a in argv if a]
    if "-m" in args[:-1]:
        parts = args[args.index("-m") + 1].split(".")
        return parts[1] if parts[0] == "services" and len(parts) > 1 else parts[-1]
    return Path(args[0]).name if args else str(pid)


def cpu_seconds() -> dict[str, float]:
    """CPU seconds used so far by this process ("runner") and each descendant, by name
    (empty where /proc is missing)."""
    if not PROC.is_dir():
        return {}
    me = os.getpid()
    parents: dict[int, int] = {}
    used: dict[int, float] = {}
    for entry in PROC.iterdir():
        if entry.name.isdigit():
            stat = _stat(int(entry.name))
            if stat is not None:
                parents[int(entry.name)], used[int(entry.name)] = stat
    out: dict[str, float] = {}
    for pid, seconds in used.items():
        p, hops = pid, 0
        while p not in (me, 0, 1) and p in parents and hops < 32:
            p, hops = parents[p], hops + 1
        if p == me:
            name = "runner" if pid == me else _name(pid)
            out[name] = out.get(name, 0.0) + seconds
    return out


DELIVERIES = "deliveries, every service's (one thread)"


def _service_of(thread_name: str) -> str:
    """The service a thread works for, from the names the in-process fleet and the bus
    give them ("service-sim", "sim-bus", "sim-diagnostics" -> sim); else the runner. The
    in-process fleet's one dispatcher works for all: its messages and the lockstep steps
    they start (the stage table splits those by service)."""
    if thread_name == FLEET_DISPATCHER:
        return DELIVERIES
    if thread_name.startswith("service-"):
        return thread_name.removeprefix("service-")
    for suffix in ("-bus", "-diagnostics", "-noise"):  # -noise: drawing ahead (shared/normals.py)
        if thread_name.endswith(suffix):
            return thread_name.removesuffix(suffix)
    return "runner"


def thread_cpu_seconds() -> dict[str, float]:
    """CPU seconds used so far by this process's threads, by the service each works for
    (the in-process fleet: wheelnav/launcher/in_process.py); threads Python did not start
    (Zenoh's runtime, numba's) are "zenoh and native threads". Empty where /proc is
    missing."""
    tasks = PROC / "self" / "task"
    if not tasks.is_dir():
        return {}
    names = {t.native_id: t.name for t in threading.enumerate() if t.native_id is not None}
    out: dict[str, float] = {}
    for entry in tasks.iterdir():
        fields = _fields(entry / "stat")
        if fields is None:
            continue
        tid = int(entry.name)
        name = _service_of(names[tid]) if tid in names else "zenoh and native threads"
        out[name] = out.get(name, 0.0) + (int(fields[11]) + int(fields[12])) * _TICK_S
    return out
