"""``wheelnav stop [--clear]`` and ``wheelnav resume``: the emergency stop and the rider's
pause from a terminal, each confirmed by the services that obey it.

``stop`` puts an EmergencyStop on ``estop`` (``--clear``: one that clears it) and asks
every live service that obeys the stop (shared/estop.py: controller, driver or sim,
navigator) which stop it holds, sending it again every ``RESEND_S``, until each holds it
(set or cleared); then it prints the controller's status if it hears one (``estop``: its
command is zero). Exit 0 once every live holder has it; 1, naming who has not, after
``--timeout``, or when no holder is alive (the stop was sent all the same).

``resume`` asks the navigator to resume the mission the rider paused by taking the
joystick (a NavResume on ``nav/resume``); the navigator answers with an event, ``resume``
or ``resume_refused`` and why (the rider still holds the joystick, nothing is paused).
Exit 0 when resumed. A cleared emergency stop does not resume a paused mission, nor does
a resume clear an emergency stop: the stop is the operator's, for every layer; the pause
is the mission's, started by the rider.
"""

from __future__ import annotations

import argparse
import os
import queue
import socket
import time

from shared.estop import HOLDERS
from shared.messages import EmergencyStop, EmergencyStopQuery, Event, FollowStatus, NavResume
from shared.topics import Keys
from shared.transport import Bus
from wheelnav.topic_tools.cli import add_connect_argument, client_bus

RESEND_S = 0.5  # wall time between two rounds of sending the stop and asking the holders
ASK_S = 0.4  # how long one holder's answer is waited for, per round
STATUS_S = 1.0  # after the holders have it: how long to listen for the controller's status


def _common(p: argparse.ArgumentParser, timeout: float) -> None:
    add_connect_argument(p)
    p.add_argument("--robot", default="chair1")
    p.add_argument(
        "--timeout", type=float, default=timeout, help=f"seconds to wait (default {timeout:g})"
    )


def add_commands(sub: argparse._SubParsersAction) -> None:
    stop = sub.add_parser(
        "stop",
        help="emergency stop: every layer stops the chair",
        description="Set the emergency stop (--clear: clear it) and confirm that every live "
        "service that obeys it (controller, driver or sim, navigator) holds it.",
    )
    _common(stop, 5.0)
    stop.add_argument("--clear", action="store_true", help="clear the emergency stop")
    stop.add_argument("--reason", default="", help="why (in every service's log)")
    stop.set_defaults(run=run_stop)
    resume = sub.add_parser(
        "resume",
        help="resume the mission paused when the rider took the joystick",
        description="Resume the mission the navigator paused when the rider took the "
        "joystick (refused while they still hold it); prints the navigator's answer.",
    )
    _common(resume, 5.0)
    resume.add_argument("--goal", default="", help="only if this is the running mission")
    resume.set_defaults(run=run_resume)


def _source(command: str) -> str:
    return f"wheelnav {command} ({socket.gethostname()}, pid {os.getpid()})"


def run_stop(args: argparse.Namespace) -> int:
    bus = client_bus(args, "stop")
    try:
        return _stop(bus, Keys(args.robot), args)
    finally:
        bus.close()


def _stop(bus: Bus, keys: Keys, args: argparse.Namespace) -> int:
    active = not args.clear
    word = "set" if active else "cleared"
    statuses: queue.SimpleQueue[FollowStatus] = queue.SimpleQueue()
    bus.subscribe(keys.follow_status, FollowStatus, statuses.put)
    alive = {k.rsplit("/", 1)[-1] for k in bus.alive(keys.key("alive"), 1.0)}
    holders = [h for h in HOLDERS if h in alive]
    msg = EmergencyStop(time.time(), active, _source("stop"), args.reason)
    bus.publish(keys.estop, msg)
    if not holders:
        print(
            f"emergency stop {word} and sent, but no service that obeys it is alive on "
            f"{args.connect} (is the fleet up?)"
        )
        return 1
    held = _confirm(bus, keys, msg, holders, args.timeout)
    missing = [h for h in holders if h not in held or held[h].active != active]
    for h in holders:
        print(f"  {h}: {_holds(held.get(h))}")
    if missing:
        print(
            f"emergency stop {word} and sent, but not acknowledged by {', '.join(missing)} "
            f"within {args.timeout:g} s: check those services, and send it again"
        )
        return 1
    print(f"emergency stop {word}: acknowledged by {', '.join(holders)}")
    if "controller" in holders:
        print(f"  controller status: {_controller_status(statuses, active)}")
    if not active:
        print("  a mission paused by the rider goes on only with: wheelnav resume")
    return 0


def _confirm(
    bus: Bus, keys: Keys, msg: EmergencyStop, holders: list[str], timeout_s: float
) -> dict[str, EmergencyStop]:
    """Ask each holder which stop it holds until every one holds ``msg``'s state (sent
    again each round) or ``timeout_s`` passes; what each last answered."""
    held: dict[str, EmergencyStop] = {}
    deadline = time.monotonic() + timeout_s
    while True:
        pending = [h for h in holders if h not in held or held[h].active != msg.active]
        if not pending or time.monotonic() >= deadline:
            return held
        round_end = time.monotonic() + RESEND_S
        held.update(_ask(bus, keys, pending))
        if any(h not in held or held[h].active != msg.active for h in pending):
            time.sleep(max(0.0, round_end - time.monotonic()))
            bus.publish(keys.estop, msg)


def _ask(bus: Bus, keys: Keys, holders: list[str]) -> dict[str, EmergencyStop]:
    """The stop each of ``holders`` holds, as answered within ``ASK_S`` (the silent left out)."""
    answers: queue.SimpleQueue[tuple[str, EmergencyStop | None]] = queue.SimpleQueue()
    for h in holders:
        bus.request(
            keys.key("estop_state", service=h),
            EmergencyStopQuery("wheelnav stop"),
            EmergencyStop,
            ASK_S,
            lambda reply, _error, h=h: answers.put((h, reply)),
        )
    got: dict[str, EmergencyStop] = {}
    deadline = time.monotonic() + ASK_S + 0.5  # each request ends by itself after ASK_S
    for _ in holders:
        try:
            h, reply = answers.get(timeout=max(0.0, deadline - time.monotonic()))
        except queue.Empty:
            break
        if reply is not None:
            got[h] = reply
    return got


def _holds(stop: EmergencyStop | None) -> str:
    if stop is None:
        return "no answer"
    if not stop.active:
        return "not stopped"
    why = f": {stop.reason}" if stop.reason else ""
    return f"stopped (by {stop.source or '?'}{why})"


def _controller_status(statuses: queue.SimpleQueue[FollowStatus], active: bool) -> str:
    """The first controller status that agrees with the stop, heard within ``STATUS_S``."""
    deadline = time.monotonic() + STATUS_S
    last: FollowStatus | None = None
    while (left := deadline - time.monotonic()) > 0:
        try:
            last = statuses.get(timeout=left)
        except queue.Empty:
            break
        if (last.state == "estop") == active:
            return "estop, command zero" if active else f"{last.state}, tracking again"
    if last is None:
        return f"none heard in {STATUS_S:g} s (is the fleet's clock running?)"
    return f"still {last.state}"


def run_resume(args: argparse.Namespace) -> int:
    keys = Keys(args.robot)
    bus = client_bus(args, "resume")
    answers: queue.SimpleQueue[Event] = queue.SimpleQueue()
    source = _source("resume")

    def on_event(e: Event) -> None:
        if e.kind in ("resume", "resume_refused") and source in e.detail:
            answers.put(e)

    try:
        bus.subscribe(keys.key("events", source="navigator"), Event, on_event)
        time.sleep(0.3)  # let the subscription reach the router before asking
        bus.publish(keys.nav_resume, NavResume(time.time(), source, args.goal))
        try:
            answer = answers.get(timeout=args.timeout)
        except queue.Empty:
            print(f"no answer from the navigator within {args.timeout:g} s (is the fleet up?)")
            return 1
    finally:
        bus.close()
    if answer.kind == "resume":
        print(answer.detail)
        return 0
    print(f"not resumed: {answer.detail}")
    return 1
