"""``wheelnav topic``: list, echo and measure live topics, locally or on a remote chair.

Zenoh has no topic registry, so ``list`` listens to ``wheelnav/**`` for a moment and
reports every key it heard (with its message type and rate) plus the live services.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import sys
import threading
import time
from collections import defaultdict
from pathlib import Path

from shared.codec import DecodeError, decode, peek_tag, to_plain
from shared.config import ConfigError, SecurityConfig, TransportConfig
from shared.messages import TreeSnapshot
from shared.topics import ROOT, Keys
from shared.transport import Bus, open_session
from shared.tree_text import render_tree
from wheelnav.topic_tools.summary import RateMeter, summarise

SECURITY_ENV = "WHEELNAV_SECURITY"  # default of --security: a terminal exports it once
USER_ENV = "WHEELNAV_USER"  # default of --user


def add_commands(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "topic", help="list, echo or measure live topics", description=__doc__.splitlines()[0]
    )
    tsub = p.add_subparsers(dest="topic_command", required=True)

    common = add_connect_argument

    ls = tsub.add_parser("list", help="keys heard on the bus, with type and rate")
    common(ls)
    ls.add_argument("--duration", type=float, default=2.0, help="seconds to listen")
    ls.set_defaults(run=run_list)
    echo = tsub.add_parser("echo", help="print decoded messages on a key (wildcards allowed)")
    common(echo)
    echo.add_argument("key")
    echo.add_argument("--json", action="store_true", help="one JSON object per line, full arrays")
    echo.add_argument("--count", type=int, default=0, help="stop after N messages")
    echo.add_argument("--duration", type=float, default=0.0, help="stop after S seconds")
    echo.set_defaults(run=run_echo)
    hz = tsub.add_parser("hz", help="message rate on a key (wall time)")
    common(hz)
    hz.add_argument("key")
    hz.add_argument("--window", type=int, default=100, help="messages in the rate window")
    hz.add_argument("--duration", type=float, default=0.0, help="stop after S seconds")
    hz.set_defaults(run=run_hz)


def add_tree_command(sub: argparse._SubParsersAction) -> None:
    t = sub.add_parser(
        "tree",
        help="show the navigator's live behaviour tree",
        description="Show the navigator's behaviour tree as it runs.",
    )
    add_connect_argument(t)
    t.add_argument("--robot", default="chair1")
    t.add_argument("--once", action="store_true", help="print one snapshot and exit")
    t.add_argument("--duration", type=float, default=0.0, help="stop after S seconds")
    t.set_defaults(run=run_tree)


def run_tree(args: argparse.Namespace) -> int:
    bus = _bus(args)
    stop = threading.Event()
    shown = [0]
    redraw = sys.stdout.isatty() and not args.once

    def on_snapshot(snap: TreeSnapshot) -> None:
        text = render_tree(snap)
        print(("\033[2J\033[H" if redraw else "") + text + ("" if redraw else "\n"), flush=True)
        shown[0] += 1
        if args.once:
            stop.set()

    bus.subscribe(Keys(args.robot).tree, TreeSnapshot, on_snapshot)
    _wait(stop, args.duration)
    bus.close()
    return 0 if shown[0] else 1


def add_connect_argument(p: argparse.ArgumentParser) -> None:
    """``--connect ENDPOINT`` (the router a terminal command reaches, local by default) and
    the credentials of a secured fleet: ``--security DIR --user NAME``."""
    p.add_argument(
        "--connect",
        metavar="ENDPOINT",
        default="tcp/127.0.0.1:7447",
        help="router to reach, e.g. tcp/192.168.1.20:7447 (default: local; a secured "
        "fleet is reached on tls/ at the same address)",
    )
    p.add_argument(
        "--security",
        metavar="DIR",
        default=os.environ.get(SECURITY_ENV, ""),
        help="credentials folder of a secured fleet (`wheelnav security init`; "
        f"default: ${SECURITY_ENV})",
    )
    p.add_argument(
        "--user",
        metavar="NAME",
        default=os.environ.get(USER_ENV, ""),
        help=f"whose credentials in --security DIR, e.g. operator (default: ${USER_ENV})",
    )


def client_transport(args: argparse.Namespace) -> TransportConfig:
    """The transport of a terminal command: a client of ``--connect``, secured by
    ``--security`` (as ``--user``); ConfigError with one line when they do not fit."""
    if args.security and not args.user:
        raise ConfigError("--security needs --user NAME (whose credentials to use)")
    if args.security and not Path(args.security).is_dir():
        raise ConfigError(f"--security {args.security}: no such directory")
    return TransportConfig(
        mode="client", connect=[args.connect], security=SecurityConfig(dir=args.security)
    )


def client_bus(args: argparse.Namespace, name: str = "topic") -> Bus:
    """A client session on the router given by ``--connect``, as ``--user`` if secured."""
    return Bus(open_session(client_transport(args), identity=args.user), name)


def _bus(args: argparse.Namespace) -> Bus:
    return client_bus(args)


def _wait(stop: threading.Event, duration: float) -> None:
    with contextlib.suppress(KeyboardInterrupt):
        stop.wait(duration if duration > 0 else None)


def run_list(args: argparse.Namespace) -> int:
    bus = _bus(args)
    seen: dict[str, RateMeter] = defaultdict(RateMeter)
    tags: dict[str, str] = {}

    def on_raw(key: str, payload: bytes) -> None:
        seen[key].tick(time.monotonic())
        try:
            tags[key] = peek_tag(payload)
        except DecodeError:
            tags[key] = "(not a wheelnav message)"

    bus.subscribe_raw(f"{ROOT}/**", on_raw)
    time.sleep(args.duration)
    alive = bus.alive(f"{ROOT}/*/alive/*")
    bus.close()
    if not seen and not alive:
        print(f"nothing heard on {args.connect} in {args.duration:g} s (is the fleet up?)")
        return 1
    width = max([len(k) for k in seen] + [10])
    print(f"{'KEY'.ljust(width)}  {'TYPE':16s}  RATE")
    for key in sorted(seen):
        print(f"{key.ljust(width)}  {tags.get(key, '?'):16s}  {seen[key].rate():7.1f} Hz")
    print("\nservices alive:")
    for key in alive:
        print(f"  {key}")
    return 0


def run_echo(args: argparse.Namespace) -> int:
    bus = _bus(args)
    stop = threading.Event()
    count = [0]
    lock = threading.Lock()

    def on_raw(key: str, payload: bytes) -> None:
        try:
            msg = decode(payload)
        except DecodeError as exc:
            line = (
                json.dumps({"key": key, "error": str(exc)})
                if args.json
                else f"{key}: bad message: {exc}"
            )
        else:
            if args.json:
                line = json.dumps({"key": key, **to_plain(msg)})
            else:
                line = f"--- {key}\n{summarise(msg)}"
        with lock:
            if stop.is_set():
                return
            print(line, flush=True)
            count[0] += 1
            if args.count and count[0] >= args.count:
                stop.set()

    bus.subscribe_raw(args.key, on_raw)
    _wait(stop, args.duration)
    stop.set()
    bus.close()
    return 0 if count[0] else 1


def run_hz(args: argparse.Namespace) -> int:
    bus = _bus(args)
    meter = RateMeter(window=args.window)
    stop = threading.Event()
    bus.subscribe_raw(args.key, lambda _k, _p: meter.tick(time.monotonic()))
    deadline = time.monotonic() + args.duration if args.duration > 0 else None
    try:
        while not stop.wait(1.0):
            r = meter.stats()
            if r is None:
                print(f"{args.key}: no messages yet", flush=True)
            else:
                print(
                    f"{args.key}: {r['rate_hz']:.2f} Hz  min {r['min_ms']:.1f} ms  "
                    f"max {r['max_ms']:.1f} ms  std {r['std_ms']:.1f} ms  window {r['n']}",
                    flush=True,
                )
            if deadline and time.monotonic() >= deadline:
                break
    except KeyboardInterrupt:
        pass
    bus.close()
    return 0 if meter.stats() is not None else 1
