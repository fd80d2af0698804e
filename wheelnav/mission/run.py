"""``wheelnav mission``: run the fleet for one scenario and write its report.

Starts a private router process (wheelnav/launcher/router.py) on a free loopback port and
the sim profile around it, joins
the lockstep as the ``mission`` participant (so the goal is sent at a fixed simulation
time), prints progress every few simulated seconds, and ends on success, failure or the
scenario's time limit. The report is printed and, with ``--report``, written as JSON.

With ``sim.hardware_path`` (sim/hardware_path.py) it runs the hardware_path profile
instead: the drivers behind the simulator's emulated links, on wall time. The links are
the run's own, as its router port is: the WHILL's pseudo terminal is linked in the run's
temporary folder and the LiDAR's packets go to a free UDP port.
"""

from __future__ import annotations

import dataclasses
import socket
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any, TextIO

import yaml

from shared import config as config_mod
from shared.config import FleetConfig, TransportConfig
from shared.lockstep import Participant
from shared.messages import (
    Clock,
    Diagnostics,
    DoorMode,
    DoorState,
    Event,
    FollowStatus,
    NavGoal,
    NavStatus,
    Odometry,
    PoseEstimate,
    RouteReply,
    SimStatus,
)
from shared.site import load_site
from shared.topics import Keys
from shared.transport import (
    FLEET_DISPATCHER,
    Bus,
    Dispatcher,
    LocalExchange,
    open_local_session,
    open_session,
)
from sim.hardware_path import check_hardware_path
from wheelnav.launcher.fleet import services_for, viz_recorder
from wheelnav.launcher.in_process import InProcessFleet
from wheelnav.launcher.router import RouterProcess
from wheelnav.launcher.supervisor import Supervisor, wait_ready
from wheelnav.mission.checkpoints import door_shifts
from wheelnav.mission.report import Recorder
from wheelnav.mission.scenario import Scenario

NAME = "mission"
PROGRESS_EVERY_S = 5.0


def free_port(kind: int = socket.SOCK_STREAM) -> int:
    """A TCP (or, with ``socket.SOCK_DGRAM``, UDP) port on loopback that nothing is bound
    to right now."""
    with socket.socket(socket.AF_INET, kind) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def fleet_profile(cfg: FleetConfig) -> str:
    """The launcher profile a mission runs: the simulated fleet, or the hardware path's
    (ConfigError if its settings do not allow it)."""
    check_hardware_path(cfg)
    return "hardware_path" if cfg.sim.hardware_path else "sim"


def private_links(fleet_cfg: dict[str, Any], folder: Path) -> None:
    """Give a hardware-path run links of its own (plain config data, changed in place):
    the WHILL's port in ``folder``, a free UDP port for the LiDAR's packets, and the
    drivers among the services the simulator's clock waits for."""
    fleet_cfg["whill"]["port"] = str(folder / "whill")
    fleet_cfg["vlp16"]["port"] = free_port(socket.SOCK_DGRAM)
    start_after = fleet_cfg["sim"]["start_after"]
    start_after += [name for name in ("driver", "vlp16_driver") if name not in start_after]


def startup_failure(missing: list[str], ended: bool, errors: dict[str, str]) -> str:
    """Why the fleet failed to come up ("" if it did): the services that exited, with their
    errors, else those whose liveliness token never came. A mission that ended while they
    came up keeps its own result: campaign b8200.m06 (every lift out of service) failed at
    tick 0 with its reason, before the planner's token was seen."""
    if not missing or ended:
        return ""
    if errors:
        return "; ".join(f"{name}: {error}" for name, error in errors.items())
    return f"services not up: {', '.join(missing)}"


class MissionRun:
    """One scenario run: fleet up, goal sent at tick 0, recorder fed, fleet down."""

    def __init__(
        self,
        scenario: Scenario,
        out: TextIO = sys.stdout,
        quiet: bool = False,
        fleet_output: TextIO | None = None,
        rrd: str | None = None,
    ) -> None:
        self.scenario = scenario
        self.out = out
        self.quiet = quiet
        self.keys = Keys(scenario.config.robot.name)
        self.goal_id = f"{scenario.name}-{int(time.time())}"
        self.recorder = Recorder(self.goal_id)
        world = scenario.config.sim.world_site
        if world:  # the report's door figures are the true doors'
            self.recorder.checkpoints.door_shifts = door_shifts(
                load_site(scenario.config.site).doors, load_site(world).doors
            )
        self.done = threading.Event()
        self.port = free_port()
        self.fleet_output = fleet_output
        self.rrd = rrd
        self.supervisor: Supervisor | InProcessFleet | None = None
        self._goal_sent = False
        self._last_progress = -PROGRESS_EVERY_S
        self._last_status: NavStatus | None = None
        self._bus: Bus | None = None
        # on wall time every service stamps from its host's clock (the drivers' may be
        # an hour off): the report's times are the simulator's clock when a message came
        self._arrival = scenario.config.clock == "wall"
        self._now = 0.0

    def run(self) -> dict[str, Any]:
        """Run to the end and return the report."""
        cfg = self.scenario.config
        profile = fleet_profile(cfg)
        endpoint = f"tcp/127.0.0.1:{self.port}"
        wall_start = time.monotonic()
        with tempfile.TemporaryDirectory(prefix="wheelnav-mission-") as tmp:
            cfg_path = Path(tmp) / "fleet.yaml"
            fleet_cfg = config_mod.to_dict(cfg)
            if NAME in self._participants() and NAME not in cfg.sim.start_after:
                # the clock waits for this runner too: the goal goes out at tick 0 of every run
                fleet_cfg["sim"]["start_after"] = [*cfg.sim.start_after, NAME]
            if cfg.sim.hardware_path:
                private_links(fleet_cfg, Path(tmp))
            cfg_path.write_text(yaml.safe_dump(fleet_cfg, sort_keys=False))
            in_process = cfg.launcher.in_process and profile == "sim"
            router = None if in_process else RouterProcess(endpoint)
            if router is None:
                # one dispatcher delivers to the runner and every hosted service, and
                # they hand messages to each other as checked objects, not bytes
                dispatcher = Dispatcher(FLEET_DISPATCHER)
                bus = Bus(
                    open_local_session(), NAME, dispatcher=dispatcher, exchange=LocalExchange()
                )
            else:
                router.start()
                bus = Bus(open_session(TransportConfig(connect=[endpoint])), NAME)
            self._wire(bus)
            bus.declare_alive(self.keys.key("alive", service=NAME))
            specs = services_for(profile) + ([viz_recorder(self.rrd)] if self.rrd else [])
            out = self.fleet_output or (_Null() if self.quiet else self.out)
            if in_process:
                self.supervisor = InProcessFleet(
                    specs, str(cfg_path), bus, out, on_stopped=self._service_stopped
                )
                where = "as threads of this process (launcher.in_process)"
            else:
                self.supervisor = Supervisor(specs, endpoint, cfg.launcher, str(cfg_path), out=out)
                where = f"on {endpoint}"
            self._say(
                f"scenario {self.scenario.name}: fleet starting {where}"
                + (
                    " (hardware path: the drivers behind emulated links)"
                    if profile != "sim"
                    else ""
                )
            )
            self.supervisor.start()
            try:
                missing = wait_ready(
                    bus,
                    self.keys,
                    [s.name for s in specs],
                    cfg.launcher.ready_timeout_s,
                    self.done,
                    supervisor=self.supervisor,
                )
                errors = {
                    name: self.supervisor.last_error(name) for name in self.supervisor.failed()
                }
                why = startup_failure(missing, self.done.is_set(), errors)
                if why:
                    self.recorder.state = "failed"
                    self.recorder.reason = why
                else:
                    wall_limit = self.scenario.time_limit_s * 20 + 120
                    if not self.done.wait(wall_limit):
                        self.recorder.state = "failed"
                        self.recorder.reason = f"no result within {wall_limit:.0f} s of wall time"
            finally:
                self.supervisor.stop()
                if router is None:
                    session = bus.session
                    bus.close()
                    session.close()
                    dispatcher.close()
                else:
                    bus.close()
                    router.stop()
        report = self.recorder.report(self.scenario.name, time.monotonic() - wall_start)
        return report

    def _service_stopped(self, name: str, why: str) -> None:
        """In process a service that ends is not restarted: the mission ends with why."""
        if not self.done.is_set():
            self.recorder.state = "failed"
            self.recorder.reason = f"{name} stopped ({why}); in process nothing restarts it"
            self.done.set()

    def _wire(self, bus: Bus) -> None:
        keys = self.keys
        participant = Participant(
            NAME, self._stage(), 10.0, self._step, lambda ack: bus.publish(keys.ack, ack)
        )
        self._bus = bus
        bus.subscribe(keys.clock_of(self._stage()), Clock, participant.on_clock, latest=True)
        bus.subscribe(keys.nav_status, NavStatus, self._on_status)
        bus.subscribe(keys.sim_status, SimStatus, self.recorder.on_sim_status)
        bus.subscribe(
            keys.ground_truth,
            Odometry,
            self._on_truth,
        )
        bus.subscribe(
            keys.nav_route,
            RouteReply,
            self._on_route,
        )
        bus.subscribe(
            keys.follow_status,
            FollowStatus,
            lambda m: self.recorder.on_follow(m.state, m.cross_track, m.precise),
        )
        bus.subscribe(
            keys.pose,
            PoseEstimate,
            lambda m: self.recorder.on_pose(self._t(m.stamp), m.pose.x, m.pose.y, m.pose.theta),
        )
        bus.subscribe(keys.key("events"), Event, self._on_event)
        bus.subscribe(keys.key("diagnostics"), Diagnostics, self.recorder.on_diagnostics)
        bus.subscribe(
            keys.key("door_state"),
            DoorState,
            lambda m: self.recorder.checkpoints.on_door_state(
                self._t(m.stamp), m.door_name, m.current_mode == DoorMode.OPEN
            ),
        )

    def _participants(self) -> set[str]:
        return {name for names in self.scenario.config.sim.lockstep_stages for name in names}

    def _stage(self) -> int:
        stages = self.scenario.config.sim.lockstep_stages
        return next((i for i, names in enumerate(stages) if NAME in names), 0)

    def _t(self, stamp: float) -> float:
        """A message's time for the report: its stamp, or on wall time the simulator's
        clock when it came (the services' stamps are their hosts' clocks)."""
        return self._now if self._arrival else stamp

    def _step(self, clock: Clock) -> None:
        self._now = clock.stamp
        if not self._goal_sent:
            s = self.scenario
            self._bus.publish(
                self.keys.nav_goal, NavGoal(clock.stamp, self.goal_id, s.goal, s.place)
            )
            self._goal_sent = True
            self._say(f"t={clock.stamp:6.1f} s  goal sent: {s.place or s.goal}")
        self.recorder.on_time(clock.stamp, self.scenario.time_limit_s)
        if clock.stamp - self._last_progress >= PROGRESS_EVERY_S:
            self._last_progress = clock.stamp
            st = self._last_status
            if st is not None:
                self._say(
                    f"t={clock.stamp:6.1f} s  {st.state:9s} phase={st.phase or '-':7s} "
                    f"progress={100 * st.progress:5.1f} %  {st.reason}"
                )
        if self.recorder.finished:
            self.done.set()

    def _on_status(self, msg: NavStatus) -> None:
        msg = dataclasses.replace(msg, stamp=self._t(msg.stamp))
        self._last_status = msg
        if msg.goal_id == self.goal_id and not self.recorder.finished:
            self.recorder.checkpoints.on_status(msg.stamp, msg.action, msg.phase)
        self.recorder.on_status(msg)
        if self.recorder.finished:
            self.done.set()

    def _on_route(self, m: RouteReply) -> None:
        self.recorder.on_route(m)
        self.recorder.checkpoints.on_route(m.checkpoints, self.recorder.sim_time_s)

    def _on_truth(self, m: Odometry) -> None:
        self.recorder.on_truth(m.pose.x, m.pose.y, m.pose.theta, m.stamp, m.v, m.pose.floor)
        if not self.recorder.finished:
            self.recorder.checkpoints.on_truth(
                m.stamp, m.pose.x, m.pose.y, m.pose.theta, m.v, m.pose.floor
            )

    def _on_event(self, msg: Event) -> None:
        self.recorder.events.append(
            {
                "t": round(self._t(msg.stamp), 3),
                "source": msg.source,
                "kind": msg.kind,
                "detail": msg.detail,
            }
        )

    def _say(self, text: str) -> None:
        if not self.quiet:
            self.out.write(f"[mission] {text}\n")
            self.out.flush()


class _Null:
    def write(self, _text: str) -> None:
        pass

    def flush(self) -> None:
        pass

    def isatty(self) -> bool:
        return False
