"""``wheelnav security init | add | show``: a chair's credentials and who may do what."""

from __future__ import annotations

import argparse

from shared.topics import ROOT, TOPICS
from wheelnav.security import store
from wheelnav.security.acl import ACTIONS, grants

EVERYONE_READS = f"{ROOT}/**"


def add_commands(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "security",
        help="credentials for a secured fleet (docs/security.md)",
        description="Make and inspect a chair's credentials: a certificate authority, a "
        "certificate, key and password per service, operator and viewer, the router's "
        "password dictionary and Zenoh configs. `wheelnav up --security DIR` runs on them.",
    )
    ssub = p.add_subparsers(dest="security_command", required=True)
    init = ssub.add_parser("init", help="credentials for one chair, in a new folder")
    init.add_argument("dir", help="folder to create (must not exist, or be empty)")
    init.add_argument("--robot", default="chair1", help="the chair's robot name")
    init.add_argument(
        "--host",
        action="append",
        default=[],
        help="a name or address clients reach the chair's router by, besides localhost "
        "(repeatable), e.g. --host chair1.local --host 192.168.1.20",
    )
    init.add_argument(
        "--operator",
        action="append",
        help="an operator (may send goals, cancels, stops; repeatable; default: operator)",
    )
    init.add_argument(
        "--viewer", action="append", help="a read-only client (repeatable; default: viewer)"
    )
    init.set_defaults(run=run_init)
    add = ssub.add_parser(
        "add", help="credentials for one more operator, viewer, service or host's router"
    )
    add.add_argument("dir", help="the folder `security init` made")
    add.add_argument("name", help="the new identity's name (its username)")
    add.add_argument(
        "--role",
        choices=store.ROLES,
        default="operator",
        help="operator (default), viewer, service (a service added to the fleet since init), "
        "or host (the router of another machine, linked to the chair's: `wheelnav up "
        "--router-identity NAME --connect tcp/CHAIR:7447` there)",
    )
    add.add_argument(
        "--carries",
        metavar="WHO",
        default="",
        help="for a host: whose traffic its router carries, comma-separated identity names "
        "or @operators, @viewers, @services (e.g. building; @operators,@viewers for a laptop), "
        "or rmf: the Open-RMF building side (its zenoh-bridge-ros2dds or rmw_zenohd; "
        "docs/building-bridge.md)",
    )
    add.set_defaults(run=run_add)
    show = ssub.add_parser("show", help="what each identity may do (the router's rules)")
    show.add_argument("dir", help="the folder `security init` made")
    show.add_argument("--robot", help="robot name (default: the folder's)")
    show.set_defaults(run=run_show)


def _print_written(root: str, written: list[store.Written]) -> None:
    width = max(len(w.path) for w in written)
    for w in written:
        print(f"  {root.rstrip('/')}/{w.path.ljust(width)}  {w.what}")


def run_init(args: argparse.Namespace) -> int:
    try:
        written = store.init(
            args.dir,
            args.robot,
            args.host,
            args.operator or ["operator"],
            args.viewer or ["viewer"],
        )
    except ValueError as exc:
        print(f"wheelnav security init: {exc}")
        return 2
    print(f"credentials for {args.robot} written to {args.dir}:")
    _print_written(args.dir, written)
    operator = (args.operator or ["operator"])[0]
    print(
        "keys, passwords and zenoh.json5 files are readable by you only; give each person "
        "their own folder (with its ca.pem), keep ca/ca.key off the chair if you can.\n"
        f"next:  wheelnav up --security {args.dir}\n"
        f"       wheelnav go PLACE --security {args.dir} --user {operator}"
    )
    return 0


def run_add(args: argparse.Namespace) -> int:
    try:
        carries = tuple(w.strip() for w in args.carries.split(",") if w.strip())
        written = store.add(args.dir, args.name, args.role, carries)
    except ValueError as exc:
        print(f"wheelnav security add: {exc}")
        return 2
    print(f"{args.name} ({args.role}) added to {args.dir}:")
    _print_written(args.dir, written)
    print("restart `wheelnav up` for the routers to know them (Zenoh reads its rules at start)")
    return 0


def run_show(args: argparse.Namespace) -> int:
    try:
        manifest = store.load(args.dir)
    except ValueError as exc:
        print(f"wheelnav security show: {exc}")
        return 2
    robot = args.robot or manifest.robot
    granted = grants(TOPICS, manifest.identities, robot)
    print(f"robot {robot}: default deny; every identity may read {EVERYONE_READS}")
    for ident in manifest.identities:
        carries = f", carries {', '.join(ident.carries)}" if ident.carries else ""
        print(f"{ident.name} ({ident.role}{carries})")
        for action in ACTIONS:
            keys = [k for k in granted[ident.name].get(action, []) if k != EVERYONE_READS]
            if keys:  # beyond what everyone may: the building bridge reads Open-RMF's keys
                print(f"  {action:8s} {', '.join(keys)}")
    return 0
