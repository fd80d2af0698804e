"""``wheelnav go | cancel | status``: the mission API from a terminal, on a live fleet.

``go PLACE`` or ``go --pose X Y THETA --floor F`` publishes a NavGoal; with ``--wait`` it
follows the mission's NavStatus (action, phase, progress) until it ends, exit code 0 on
success. ``cancel`` stops the running mission; ``status`` prints the current state.
"""

from __future__ import annotations

import argparse
import contextlib
import threading
import time

from shared.messages import TERMINAL_STATES, NavGoal, NavStatus, Pose2D
from shared.topics import Keys
from wheelnav.topic_tools.cli import add_connect_argument, client_bus


def _common(p: argparse.ArgumentParser) -> None:
    add_connect_argument(p)
    p.add_argument("--robot", default="chair1")


def add_commands(sub: argparse._SubParsersAction) -> None:
    go = sub.add_parser("go", help="start a mission to a place or a pose", description=__doc__)
    _common(go)
    go.add_argument("place", nargs="?", default="", help="a place of the site, e.g. room_b")
    go.add_argument("--pose", nargs=3, type=float, metavar=("X", "Y", "THETA"))
    go.add_argument("--floor", default="", help="floor of --pose")
    go.add_argument("--wait", action="store_true", help="follow the mission until it ends")
    go.add_argument("--timeout", type=float, default=0.0, help="stop waiting after S seconds")
    go.set_defaults(run=run_go)
    cancel = sub.add_parser("cancel", help="cancel the running mission")
    _common(cancel)
    cancel.set_defaults(run=run_cancel)
    status = sub.add_parser("status", help="print the navigator's mission status")
    _common(status)
    status.add_argument("--follow", action="store_true", help="keep printing changes")
    status.add_argument("--duration", type=float, default=5.0, help="seconds to wait for one")
    status.set_defaults(run=run_status)


def format_status(s: NavStatus) -> str:
    """One line: state, action, phase, progress and the reason or feedback."""
    parts = [f"{s.goal_id or '-'}: {s.state}"]
    if s.action:
        parts.append(s.action)
    if s.phase:
        parts.append(f"phase {s.phase}")
    parts.append(f"{100 * s.progress:.0f} %")
    line = ", ".join(parts)
    return f"{line} - {s.reason}" if s.reason else line


def run_go(args: argparse.Namespace) -> int:
    if bool(args.place) == bool(args.pose):
        print("wheelnav go: give a place or --pose X Y THETA (not both)")
        return 2
    keys = Keys(args.robot)
    goal = Pose2D(*args.pose, args.floor) if args.pose else None
    goal_id = f"cli-{int(time.time() * 1000)}"
    bus = client_bus(args, "cli")
    done = threading.Event()
    result = {"state": ""}
    last = [""]

    def on_status(s: NavStatus) -> None:
        if s.goal_id != goal_id:
            return
        line = format_status(s)
        if args.wait and line != last[0]:
            print(line, flush=True)
            last[0] = line
        if s.state in TERMINAL_STATES:
            result["state"] = s.state
            done.set()

    bus.subscribe(keys.nav_status, NavStatus, on_status)
    time.sleep(0.3)  # let the subscription reach the router before the goal goes out
    bus.publish(keys.nav_goal, NavGoal(0.0, goal_id, goal, args.place))
    print(f"goal {goal_id} sent: {args.place or goal}", flush=True)
    if not args.wait:
        bus.close()
        return 0
    with contextlib.suppress(KeyboardInterrupt):
        done.wait(args.timeout if args.timeout > 0 else None)
    bus.close()
    return 0 if result["state"] == "succeeded" else 1


def run_cancel(args: argparse.Namespace) -> int:
    bus = client_bus(args, "cli")
    time.sleep(0.3)
    bus.publish(Keys(args.robot).nav_goal, NavGoal(0.0, "cancel", cancel=True))
    print("cancel sent")
    bus.close()
    return 0


def run_status(args: argparse.Namespace) -> int:
    bus = client_bus(args, "cli")
    got = threading.Event()
    last = [""]

    def on_status(s: NavStatus) -> None:
        line = format_status(s)
        if line != last[0]:
            print(line, flush=True)
            last[0] = line
        got.set()

    bus.subscribe(Keys(args.robot).nav_status, NavStatus, on_status)
    with contextlib.suppress(KeyboardInterrupt):
        if args.follow:
            threading.Event().wait(args.duration if args.duration > 0 else None)
        else:
            got.wait(args.duration)
    bus.close()
    if not got.is_set():
        print(f"no status from the navigator on {args.connect} in {args.duration:g} s")
        return 1
    return 0
