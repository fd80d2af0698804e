"""``wheelnav up`` and ``wheelnav compose``: argument parsing for the launcher."""

from __future__ import annotations

import argparse
import json
import signal
import sys
import threading
from pathlib import Path

from services.viz.sink_args import add_sink_arguments
from shared import config as config_mod
from shared.credentials import ROUTER, secure_endpoint
from shared.service import add_override_argument, add_transport_arguments
from shared.topics import Keys
from wheelnav.launcher.compose import render_compose
from wheelnav.launcher.fleet import PROFILE_SETTINGS, PROFILES, pick, services_for
from wheelnav.launcher.supervisor import Supervisor, open_router, wait_ready
from wheelnav.security import store
from wheelnav.security.acl import UPSTREAM
from wheelnav.security.store import router_access_control

COMPOSE_FILE = Path(__file__).resolve().parents[2] / "docker-compose.yml"


def add_commands(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "up",
        help="start the whole fleet around a local Zenoh router",
        description="Start the whole fleet as child processes around an "
        "in-process Zenoh router. Ctrl-C stops everything.",
    )
    p.add_argument("--profile", choices=PROFILES, default="sim")
    p.add_argument(
        "--services",
        metavar="NAMES",
        help="only these services of the profile, comma-separated (a fleet split across "
        "hosts, e.g. building on the building's server), or none: the router alone "
        "(default: every service of the profile)",
    )
    p.add_argument("--config", metavar="FILE", help="fleet config YAML")
    add_override_argument(p)
    p.add_argument(
        "--listen",
        metavar="ENDPOINT",
        help="router endpoint (default: launcher.router_listen, tcp/127.0.0.1:7447); "
        "use tcp/0.0.0.0:7447 to let a laptop connect",
    )
    p.add_argument(
        "--connect",
        metavar="ENDPOINT",
        action="append",
        help="link this host's router to another host's, e.g. tcp/CHAIR:7447 (repeatable; "
        "default: launcher.router_connect, none)",
    )
    p.add_argument(
        "--router-identity",
        metavar="NAME",
        help="secured: whose credentials this host's router holds, a `security add NAME "
        "--role host` identity on a host linked to the chair (default: "
        "launcher.router_identity, router: the chair's)",
    )
    p.add_argument(
        "--security",
        metavar="DIR",
        help="run secured on the credentials of `wheelnav security init DIR` (default: "
        "transport.security.dir; without either the fleet runs insecure, for development)",
    )
    p.set_defaults(run=run_up)
    c = sub.add_parser(
        "compose",
        help="print docker-compose.yml generated from the fleet",
        description="Print the docker-compose.yml that describes the same fleet.",
    )
    c.add_argument(
        "--check", action="store_true", help="exit 1 if the committed docker-compose.yml differs"
    )
    c.set_defaults(run=run_compose)
    v = sub.add_parser(
        "viz",
        help="stream a running fleet to a rerun viewer",
        description="Run the viz service here: subscribe to a fleet (--connect, e.g. "
        "tcp/CHAIR:7447 for a chair started with `wheelnav up --listen tcp/0.0.0.0:7447`) "
        "and stream to a rerun viewer started on this machine with `rerun` (--viewer "
        "rerun+http://127.0.0.1:9876/proxy), to a web viewer it serves (--serve), or to a "
        "file (--save). Ctrl-C stops it.",
    )
    add_transport_arguments(v)
    add_sink_arguments(v)
    v.set_defaults(run=run_viz)


def run_viz(args: argparse.Namespace) -> int:
    """The viz service in this process, given the flags as they were typed."""
    from services.viz import node

    raw = args.raw_argv
    node.main(raw[raw.index("viz") + 1 :])
    return 0


def security_banner(
    listen: str, security_dir: str, robot: str, identities: int, identity: str = ROUTER
) -> str:
    """The one line ``wheelnav up`` says about security: secured how, or insecure and so."""
    if not security_dir:
        return (
            f"WARNING: insecure: no authentication nor access control on {listen}; any "
            "client that reaches it can send goals and velocities (development only; "
            "see docs/security.md, `wheelnav up --security DIR`)"
        )
    who = "" if identity == ROUTER else f", this host's router as {identity}"
    return (
        f"secured: mutual TLS, user/password and access control for {robot} "
        f"({identities} identities in {security_dir}{who}; deny by default)"
    )


def secured_router(
    security: str, listen: str, robot: str, identity: str = ROUTER, links: list[str] = ()
) -> tuple[str, str, dict, int]:
    """For a secured ``up``: the credentials folder (absolute, for the services), the
    router's TLS endpoint, the access control of ``identity``'s router for ``robot`` and
    how many identities it admits. ConfigError with one line when ``security`` is not a
    credentials folder, or the chair's router is asked to make a link (a host's router
    links to the chair's, as a host identity the chair's router knows)."""
    if not Path(security).is_dir():
        raise config_mod.ConfigError(f"--security {security}: no such directory")
    if links and identity == ROUTER:
        raise config_mod.ConfigError(
            "launcher.router_connect: a secured link is made by another host's router, as a "
            "host identity (`wheelnav security add DIR NAME --role host --carries WHO`, then "
            "--router-identity NAME), to the chair's router"
        )
    folder = str(Path(security).resolve())
    manifest = store.load(folder)
    access = router_access_control(manifest, robot, identity)
    admitted = [s for s in access["subjects"] if s["id"] != UPSTREAM]
    return folder, secure_endpoint(listen), access, len(admitted)


def run_up(args: argparse.Namespace) -> int:
    cfg = config_mod.load(args.config, args.overrides)
    listen = args.listen or cfg.launcher.router_listen
    links = args.connect or cfg.launcher.router_connect
    identity = args.router_identity or cfg.launcher.router_identity
    extra = [a for o in args.overrides for a in ("--set", o)]
    security = args.security or cfg.transport.security.dir
    access, identities = None, 0
    if security:
        security, listen, access, identities = secured_router(
            security, listen, cfg.robot.name, identity, links
        )
        extra += ["--set", f"transport.security.dir={json.dumps(security)}"]
    connect = listen.replace("0.0.0.0", "127.0.0.1")
    specs = services_for(args.profile)
    if args.services is not None:
        try:
            specs = pick(specs, args.services)
        except ValueError as exc:
            raise config_mod.ConfigError(str(exc)) from None
    extra += [a for o in PROFILE_SETTINGS.get(args.profile, ()) for a in ("--set", o)]
    stop = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stop.set())
    bus = open_router(listen, security, access, links, identity)
    sup = Supervisor(specs, connect, cfg.launcher, args.config, extra)
    sup.say(security_banner(listen, security, cfg.robot.name, identities, identity))
    linked = f", linked to {', '.join(links)}" if links else ""
    starting = ", ".join(s.name for s in specs) or "no service (the router alone)"
    sup.say(f"router listening on {listen}{linked}; starting {starting}")
    sup.start()
    try:
        missing = wait_ready(
            bus, Keys(cfg.robot.name), [s.name for s in specs], cfg.launcher.ready_timeout_s, stop
        )
        if missing and not stop.is_set():
            sup.say(f"not up after {cfg.launcher.ready_timeout_s:.0f} s: {', '.join(missing)}")
        elif not stop.is_set():
            sup.say(f"fleet up; try: wheelnav topic echo {Keys(cfg.robot.name).odom}")
        # wake now and then: Ctrl-C may land on another thread (Zenoh's), and Python runs
        # the handler only once the main thread runs again (a bare wait() missed it)
        while not stop.wait(0.5):
            pass
        sup.say("stopping")
    finally:
        sup.stop()
        bus.close()
    return 0


def run_compose(args: argparse.Namespace) -> int:
    text = render_compose()
    if args.check:
        current = COMPOSE_FILE.read_text() if COMPOSE_FILE.is_file() else ""
        if current != text:
            print(
                "docker-compose.yml is out of date: run `wheelnav compose > docker-compose.yml`",
                file=sys.stderr,
            )
            return 1
        return 0
    sys.stdout.write(text)
    return 0
