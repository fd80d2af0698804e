"""Across machines (issue 16 item 6): the chair, the building and a laptop as three hosts.

Three network namespaces, the chair's linked to each of the others by a veth pair, a
router per host, secured: the chair runs sim, localisation, planner, controller and
navigator (``wheelnav up --services ...``); the building's router links to the chair's as
the host ``building-host`` and runs the building service; the laptop's router links as the
host ``laptop`` and serves the laptop's clients. All on wall time, as on a real chair.

Shown, each refusal beside a positive control (an authorised client on the same key,
seen by the same subscriber, on the chair): a client without credentials refused; a
viewer's goal and velocity dropped; the demo mission, started from the laptop, succeeds
with the laptop's link cut on the way; with the building's link cut, the door step
times out and the navigator falls back (plans around the door: none here, so it stops
saying why). The test fails, not skips, where it cannot make namespaces (it needs root).
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import TypeVar

import pytest
import yaml

from shared import config as config_mod
from shared.codec import decode, encode
from shared.messages import DoorState, Event, Msg, NavGoal, NavStatus, Twist
from shared.topics import Keys
from tests.conftest import PYTHON, ROOT
from wheelnav.mission.scenario import load_scenario
from wheelnav.mission_api import format_status

pytestmark = pytest.mark.e2e
T = TypeVar("T")

KEYS = Keys("chair1")
DEMO = ROOT / "scenarios" / "demo.yaml"
PORT = 7447
LOCAL = f"tcp/127.0.0.1:{PORT}"  # a host's own router, from its clients
# the chair's end of each link (its router listens there) and the other end
LINKS = {"building": ("10.77.1.1", "10.77.1.2"), "laptop": ("10.77.2.1", "10.77.2.2")}
DOOR_TIMEOUT_S = 20  # navigator.door_timeout_s here: the door step's wait, shortened
DEADLINE_S = 180.0  # for what must happen; the machine may be loaded
MISSION_S = 900.0  # for a mission to end, on wall time


@dataclass
class Hosts:
    """Three network namespaces by role, and the chair's end of the link to each other."""

    netns: dict[str, str]
    devices: dict[str, str]  # "building" / "laptop" -> the chair's veth to it

    def command(self, host: str, *argv: str) -> list[str]:
        return ["ip", "netns", "exec", self.netns[host], *argv]

    def link(self, to: str, up: bool) -> None:
        """Set the chair's link to ``to`` up or down (its other end loses carrier too)."""
        state = "up" if up else "down"
        ip("-n", self.netns["chair"], "link", "set", self.devices[to], state)


def ip(*argv: str) -> None:
    subprocess.run(["ip", *argv], check=True, capture_output=True, text=True, timeout=30)


@pytest.fixture
def hosts() -> Iterator[Hosts]:
    """The three namespaces and their veth links; deleted afterwards (their links with
    them). Fails, never skips, when they cannot be made."""
    tag = str(os.getpid() % 100000)
    netns = {role: f"wn{tag}-{role}" for role in ("chair", "building", "laptop")}
    devices = {to: f"wn{tag}{to[0]}c" for to in LINKS}
    made: list[str] = []
    try:
        for name in netns.values():
            ip("netns", "add", name)
            made.append(name)
            ip("-n", name, "link", "set", "lo", "up")
        for to, (chair_ip, other_ip) in LINKS.items():
            theirs = f"wn{tag}{to[0]}"
            pair = ("type", "veth", "peer", "name", theirs, "netns", netns[to])
            ip("link", "add", devices[to], "netns", netns["chair"], *pair)
            ip("-n", netns["chair"], "addr", "add", f"{chair_ip}/24", "dev", devices[to])
            ip("-n", netns[to], "addr", "add", f"{other_ip}/24", "dev", theirs)
            ip("-n", netns["chair"], "link", "set", devices[to], "up")
            ip("-n", netns[to], "link", "set", theirs, "up")
    except (OSError, subprocess.SubprocessError) as exc:
        why = getattr(exc, "stderr", "") or exc
        for name in made:
            subprocess.run(["ip", "netns", "delete", name], capture_output=True, timeout=30)
        pytest.fail(f"cannot make network namespaces (root and iproute2 needed): {why}")
    try:
        yield Hosts(netns, devices)
    finally:
        for name in made:
            subprocess.run(["ip", "netns", "delete", name], capture_output=True, timeout=30)


class Process:
    """A process started in a session of its own, its output lines gathered as they come."""

    def __init__(self, argv: list[str], stdin: bool = False) -> None:
        self.proc = subprocess.Popen(
            argv,
            cwd=ROOT,
            stdin=subprocess.PIPE if stdin else subprocess.DEVNULL,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
            start_new_session=True,  # its pid is its group's: the services it starts go too
        )
        self.lines: list[str] = []
        self.ended = False
        self.changed = threading.Condition()
        self.reader = threading.Thread(target=self._read, daemon=True)
        self.reader.start()

    def _read(self) -> None:
        for line in self.proc.stdout:
            with self.changed:
                self.take(line.rstrip("\n"))
                self.changed.notify_all()
        with self.changed:
            self.ended = True
            self.changed.notify_all()

    def take(self, line: str) -> None:
        self.lines.append(line)

    def text(self) -> str:
        with self.changed:
            return "\n".join(self.lines)

    def said(self, text: str) -> Callable[[], bool]:
        """A condition for :meth:`wait_for`: a line of its output holds ``text``."""
        return lambda: any(text in line for line in self.lines)

    def tail(self) -> str:
        """The end of its output, for a failure's message."""
        with self.changed:
            return "\n".join(self.lines[-60:])

    def wait_for(self, what: Callable[[], object], timeout: float, why: str) -> object:
        """The first truthy ``what()`` within ``timeout`` s of wall time, else fail."""
        deadline = time.monotonic() + timeout
        with self.changed:
            while not (got := what()):
                left = deadline - time.monotonic()
                if left <= 0 or self.ended:
                    pytest.fail(f"{why}:\n{self.tail()}")
                self.changed.wait(min(left, 1.0))
        return got

    def stop(self, sig: int = signal.SIGINT, grace_s: float = 60.0) -> int:
        """Send ``sig``; after ``grace_s`` kill its whole process group."""
        if self.proc.poll() is None:
            self.proc.send_signal(sig)
        try:
            self.proc.wait(grace_s)
        except subprocess.TimeoutExpired:
            os.killpg(self.proc.pid, signal.SIGKILL)
            self.proc.wait(30)
        self.reader.join(5)
        return self.proc.returncode


class Agent(Process):
    """A client of one host's router (tests/integration/netns_agent.py): subscribes and
    publishes on command, and keeps what it heard by key."""

    def __init__(self, argv: list[str]) -> None:
        self.samples: dict[str, list[bytes]] = {}
        super().__init__(argv, stdin=True)

    def take(self, line: str) -> None:
        if not line.startswith("{"):
            return super().take(line)
        sample = json.loads(line)
        self.samples.setdefault(sample["key"], []).append(bytes.fromhex(sample["hex"]))

    def command(self, **command: str) -> None:
        self.proc.stdin.write(json.dumps(command) + "\n")
        self.proc.stdin.flush()

    def put(self, key: str, msg: Msg) -> None:
        self.command(put=key, hex=encode(msg).hex())

    def heard(self, key: str, msg_type: type[T]) -> list[T]:
        """The messages heard on ``key`` so far, in order."""
        with self.changed:
            return [decode(p, msg_type) for p in self.samples.get(key, [])]

    def tail(self) -> str:
        """What it heard last on the mission's keys, besides its output."""
        seen = [f"goal {g.goal_id} cancel={g.cancel}" for g in self.heard(KEYS.nav_goal, NavGoal)]
        seen += [format_status(s) for s in self.heard(KEYS.nav_status, NavStatus)]
        return super().tail() + "\n" + "\n".join(dict.fromkeys(seen[-40:]))

    def count(self, key: str, msg: Msg) -> int:
        """How often exactly ``msg`` was heard on ``key``."""
        with self.changed:
            return self.samples.get(key, []).count(encode(msg))

    def status(self, goal_id: str, what: Callable[[NavStatus], bool]) -> Callable[[], object]:
        """A condition for :meth:`wait_for`: the first status of ``goal_id`` with ``what``."""
        return lambda: next(
            (s for s in self.heard(KEYS.nav_status, NavStatus) if s.goal_id == goal_id and what(s)),
            None,
        )


@dataclass
class Fleet:
    """The secured fleet split over the three hosts, and the test's clients on them."""

    hosts: Hosts
    keys: str
    ups: dict[str, Process]
    started: list[Process] = field(default_factory=list)

    def agent(self, host: str, user: str) -> Agent:
        """A client of ``host``'s own router, as ``user``."""
        argv = [PYTHON, "-m", "tests.integration.netns_agent", "--connect", LOCAL]
        argv += ["--security", self.keys, "--user", user]
        agent = Agent(self.hosts.command(host, *argv))
        self.started.append(agent)
        agent.wait_for(agent.said("ready"), DEADLINE_S, f"{user} on {host}")
        return agent

    def wheelnav(self, host: str, *argv: str, user: str = "") -> subprocess.CompletedProcess:
        """A ``wheelnav`` command on ``host`` (reaching its own router unless ``argv`` says
        otherwise), as ``user`` if given, else without credentials."""
        creds = ["--security", self.keys, "--user", user] if user else []
        return subprocess.run(
            self.hosts.command(host, PYTHON, "-m", "wheelnav.cli", *argv, *creds),
            cwd=ROOT,
            capture_output=True,
            text=True,
            timeout=DEADLINE_S,
        )


def _fleet_config(path: Path) -> None:
    """The demo's fleet on wall time (no lockstep), the door step's wait shortened."""
    cfg = load_scenario(DEMO).config
    cfg.clock = "wall"
    cfg.sim.lockstep, cfg.sim.realtime_factor = False, 1.0
    cfg.navigator.door_timeout_s = float(DOOR_TIMEOUT_S)
    # the simulator starts once the services of both hosts are up (no mission runner here)
    cfg.sim.start_after = ["localisation", "planner", "controller", "navigator", "building"]
    cfg.launcher.ready_timeout_s = 2 * DEADLINE_S  # each host says "fleet up" once it is
    path.write_text(yaml.safe_dump(config_mod.to_dict(cfg)))


def _security(*argv: str) -> None:
    made = subprocess.run(
        [PYTHON, "-m", "wheelnav.cli", "security", *argv],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert made.returncode == 0, made.stdout + made.stderr


@pytest.fixture
def fleet(hosts: Hosts, tmp_path: Path) -> Iterator[Fleet]:
    """Credentials with the two hosts' routers, then ``wheelnav up`` on each host; stopped
    (Ctrl-C, then killed) at the end, the test's clients first."""
    keys = str(tmp_path / "keys")
    _security("init", keys, *(a for chair, _ in LINKS.values() for a in ("--host", chair)))
    _security("add", keys, "building-host", "--role", "host", "--carries", "building")
    _security("add", keys, "laptop", "--role", "host", "--carries", "@operators,@viewers")
    cfg = tmp_path / "fleet.yaml"
    _fleet_config(cfg)
    up = [PYTHON, "-m", "wheelnav.cli", "up", "--config", str(cfg), "--security", keys]
    argv = {
        "chair": ["--services", "sim,localisation,planner,controller,navigator"],
        "building": ["--services", "building", "--router-identity", "building-host"],
        "laptop": ["--services", "none", "--router-identity", "laptop"],
    }
    argv["chair"] += ["--listen", f"tcp/0.0.0.0:{PORT}"]  # its links' ends and loopback
    for host in ("building", "laptop"):
        argv[host] += ["--listen", LOCAL, "--connect", f"tcp/{LINKS[host][0]}:{PORT}"]
    ups: dict[str, Process] = {}
    running = Fleet(hosts, keys, ups)
    try:
        for host, args in argv.items():
            ups[host] = Process(hosts.command(host, *up, *args))
        for host, proc in ups.items():
            proc.wait_for(proc.said("fleet up"), 3 * DEADLINE_S, f"{host}: not up")
        yield running
    finally:
        for agent in running.started:
            agent.stop(signal.SIGTERM, 10)
        codes = {host: proc.stop() for host, proc in ups.items()}
        for host, proc in ups.items():  # shown when the test fails
            print(f"---- {host}\n" + proc.text()[-6000:])
    for host, proc in ups.items():
        assert codes[host] == 0, proc.text()[-3000:]
        assert "Traceback" not in proc.text(), proc.text()[-3000:]


def seen(
    listener: Agent, key: str, refused: tuple[Agent, Msg], allowed: tuple[Agent, Msg]
) -> tuple[int, int]:
    """Publish the refused then the allowed message on ``key``, in turns, until
    ``listener`` (subscribed to ``key``) has heard the allowed one 3 times; (refused
    heard, allowed heard)."""
    deadline = time.monotonic() + DEADLINE_S
    while listener.count(key, allowed[1]) < 3 and time.monotonic() < deadline:
        refused[0].put(key, refused[1])
        allowed[0].put(key, allowed[1])
        time.sleep(0.5)
    time.sleep(1.0)  # what was sent last has had time to arrive
    return listener.count(key, refused[1]), listener.count(key, allowed[1])


def test_the_fleet_across_three_hosts_refuses_strangers_and_outlives_cut_links(
    fleet: Fleet,
) -> None:
    events, door = KEYS.key("events", source="navigator"), KEYS.key("door_state", door="door_ab")
    watch = fleet.agent("chair", "viewer")  # the subscriber of every check, on the chair
    for key in (KEYS.nav_status, KEYS.nav_goal, events, KEYS.key("door_state")):
        watch.command(sub=key)
    viewer, operator = fleet.agent("laptop", "viewer"), fleet.agent("laptop", "operator")
    viewer.command(sub=KEYS.nav_status)
    # linked: the simulator saw the building's service, its door states reach the chair,
    # the chair's status reaches the laptop
    chair = fleet.ups["chair"]
    chair.wait_for(chair.said("starting the clock"), DEADLINE_S, "the sim did not see the fleet")
    watch.wait_for(lambda: watch.heard(door, DoorState), DEADLINE_S, "no door state on the chair")
    viewer.wait_for(
        lambda: viewer.heard(KEYS.nav_status, NavStatus), DEADLINE_S, "no status on the laptop"
    )

    # a client without credentials is refused, by the laptop's router and by the chair's;
    # the operator's cancel from the same command is heard on the chair
    for where in (LOCAL, f"tcp/{LINKS['laptop'][0]}:{PORT}"):
        bare = fleet.wheelnav("laptop", "cancel", "--connect", where)
        assert bare.returncode == 1, bare.stdout + bare.stderr
        assert "cannot open a Zenoh client session" in bare.stderr
    cancel = fleet.wheelnav("laptop", "cancel", user="operator")
    assert cancel.returncode == 0 and "cancel sent" in cancel.stdout, cancel.stderr

    def cancelled() -> bool:  # `wheelnav cancel` sends this goal id
        return any(g.goal_id == "cancel" for g in watch.heard(KEYS.nav_goal, NavGoal))

    watch.wait_for(cancelled, DEADLINE_S, "the operator's cancel was not heard")

    # a viewer's goal is dropped, an operator's (a cancel: nothing runs) heard
    bad, good = seen(
        watch,
        KEYS.nav_goal,
        (viewer, NavGoal(0.0, "from-viewer", None, "room_b")),
        (operator, NavGoal(0.0, "from-operator", cancel=True)),
    )
    assert good >= 3 and bad == 0

    # a viewer's velocity is dropped; the controller's (on the chair: the laptop's router
    # may not carry one) heard
    controller = fleet.agent("chair", "controller")
    watch.command(sub=KEYS.cmd_vel)
    watch.wait_for(lambda: watch.heard(KEYS.cmd_vel, Twist), DEADLINE_S, "no cmd_vel on the chair")
    bad, good = seen(
        watch,
        KEYS.cmd_vel,
        (viewer, Twist(111.0, 0.0, 0.0)),
        (controller, Twist(222.0, 0.0, 0.0)),
    )
    assert good >= 3 and bad == 0

    # the demo, started from the laptop; the laptop's link cut once the chair drives
    go = fleet.wheelnav("laptop", "go", "room_b", user="operator")
    assert go.returncode == 0, go.stdout + go.stderr
    goal_id = go.stdout.split()[1]
    watch.wait_for(
        watch.status(goal_id, lambda s: s.phase == "follow"), DEADLINE_S, "the chair never drove"
    )
    fleet.hosts.link("laptop", up=False)
    ended = watch.status(goal_id, lambda s: s.state != "running")
    done = watch.wait_for(ended, MISSION_S, "the mission did not end")
    assert done.state == "succeeded", done.reason
    fleet.hosts.link("laptop", up=True)  # the laptop's router links again by itself
    viewer.wait_for(
        viewer.status(goal_id, lambda s: s.state == "succeeded"),
        DEADLINE_S,
        "the laptop never heard the chair again",
    )

    # the building's link cut: once its last door state is older than the navigator
    # trusts, the door step waits, times out and falls back
    fleet.hosts.link("building", up=False)
    time.sleep(config_mod.NavigatorConfig().building_state_max_age_s + 1.0)
    last = len(watch.heard(door, DoorState))
    back = fleet.wheelnav("laptop", "go", "room_a", user="operator")
    assert back.returncode == 0, back.stdout + back.stderr
    goal_id = back.stdout.split()[1]
    done = watch.wait_for(
        watch.status(goal_id, lambda s: s.state != "running"), MISSION_S, "no end"
    )
    assert len(watch.heard(door, DoorState)) == last  # nothing from the building since
    assert done.state == "failed", done.reason
    assert done.reason.startswith(f"door door_ab did not open within {DOOR_TIMEOUT_S} s"), done
    assert "no other route" in done.reason, done.reason
    fallbacks = [e.detail for e in watch.heard(events, Event) if e.kind == "fallback"]
    assert any(f.startswith("avoiding door_ab: door door_ab did not open") for f in fallbacks)
