"""Simulator service: steps the pybullet chair and publishes what a real chair would.

Publishes the clock (in lockstep stages), odometry every tick, LiDAR scans, and for
evaluation only the ground truth and a collision/clearance status. Listens for velocity
commands; the chair's watchdog stops it when they stop coming. Standing in for the
driver, it obeys the emergency stop (shared/estop.py): while it is active every command
is taken as zero, so the chair brakes to a stop whatever ``cmd_vel`` says.

On the hardware path (``sim.hardware_path``, sim/hardware_path.py) it stands in for the
hardware instead: the drivers take ``cmd_vel`` (and the emergency stop) and publish
``odom`` and ``scan``; the simulator moves the chair as an emulated WHILL on a pseudo
terminal at ``whill.port`` executes the WHILL driver's commands, and sends its scans as
VLP-16 packets to the VLP-16 driver. It holds the clock at 0 until the WHILL driver
streams from the emulated chair.
"""

from __future__ import annotations

import contextlib
import functools
import math
import threading
import time
from collections.abc import Callable

from services.sim.pacing import Pacer
from shared.config import ConfigError
from shared.estop import EstopLatch, hold_estop
from shared.lockstep import Barrier, TickProfile
from shared.messages import (
    Ack,
    BuildingBodies,
    Clock,
    DoorClearance,
    Event,
    Odometry,
    PointCloud,
    Pose2D,
    SimStatus,
    Twist,
)
from shared.service import EXIT_CONFIG, Service
from shared.site import SiteError, load_site
from sim.hardware_path import HardwarePath, check_hardware_path
from sim.robot import ChairState
from sim.simulation import Simulation, StepResult

NAME = "sim"
PROFILE_EVERY = 50  # ticks between two lockstep profiles (sim/profile)
REANNOUNCE_S = 0.5  # wall time between two announcements of a tick still waited for
STALL_S = 0.25  # wall time let go at one step (services/sim/pacing.py) that is an event


def status_message(sim: Simulation, stamp: float) -> SimStatus:
    """The evaluation bookkeeping the simulator publishes: collisions and clearances."""
    return SimStatus(
        stamp,
        sim.collisions,
        sim.in_collision,
        _finite(sim.clearance),
        _finite(sim.min_clearance),
        _finite(sim.min_clearance_away),
        [
            DoorClearance(
                door_id,
                seen.width,
                _finite(seen.clearance),
                seen.nearest,
                [round(v, 3) for v in seen.at],
                seen.free,
                seen.entered,
                _finite(seen.outline),
            )
            for door_id, seen in sim.door_clearance.items()
        ],
        away_nearest=sim.away.nearest,
        away_at=[round(v, 3) for v in sim.away.at],
    )


def main(argv: list[str] | None = None) -> None:
    with Service(NAME, __doc__.splitlines()[0], argv) as svc:
        cfg = svc.cfg
        try:
            check_hardware_path(cfg)
        except ConfigError as exc:
            svc.log.error("config error: %s", exc)
            raise SystemExit(EXIT_CONFIG) from None
        hardware = None
        try:
            site = load_site(cfg.sim.world_site or cfg.site)
            hardware = HardwarePath(cfg, svc.log) if cfg.sim.hardware_path else None
            sim = Simulation(cfg, site, hardware.drive if hardware else None)
        except (SiteError, ValueError, OSError) as exc:
            if hardware is not None:
                hardware.close()
            svc.log.error("cannot start: %s", exc)
            raise SystemExit(2) from None
        try:
            _serve(svc, sim, hardware)
        finally:
            if hardware is not None:
                hardware.close()


def _serve(svc: Service, sim: Simulation, hardware: HardwarePath | None) -> None:
    """Wire the simulator to the bus, wait for the fleet, run until stopped. On the
    hardware path the drivers take commands and obey the emergency stop, not the
    simulator; it still holds the stop (answers for it, keeps it for a restarted holder),
    as every live holder does for ``wheelnav stop``."""
    cfg, keys, bus = svc.cfg, svc.keys, svc.bus
    barrier = Barrier(cfg.sim.lockstep_stages)
    profile = TickProfile(barrier.n_stages, cfg.sim.dt)
    wake = threading.Condition(bus.lock)

    def on_cmd(msg: Twist) -> None:
        if estop.active:
            sim.command(0.0, 0.0)  # still a command: the watchdog is not what stops it
        else:
            sim.command(msg.v, msg.w)

    def on_estop(latch: EstopLatch) -> None:
        if latch.stop.active and hardware is None:
            sim.command(0.0, 0.0)

    def on_ack(msg: Ack) -> None:
        barrier.ack(msg)
        profile.ack(msg)
        wake.notify_all()

    def on_alive(key: str, alive: bool) -> None:
        barrier.set_alive(key.rsplit("/", 1)[-1], alive)
        wake.notify_all()

    def on_bodies(msg: BuildingBodies) -> None:
        sim.set_door_openings(msg.doors, msg.door_openings)
        sim.set_lifts(msg.lifts, msg.car_elevations, msg.lift_door_openings)

    estop = hold_estop(bus, keys, NAME, svc.log, on_estop)
    if hardware is None:
        bus.subscribe(svc.declare("subscribes", keys.cmd_vel), Twist, on_cmd)
    bus.subscribe(svc.declare("subscribes", keys.key("building_bodies")), BuildingBodies, on_bodies)
    bus.subscribe(svc.declare("subscribes", keys.ack), Ack, on_ack)
    bus.watch_alive(keys.key("alive"), on_alive)
    sensors = ("odom", "scan") if hardware is None else ()
    for name in ("clock", *sensors, "ground_truth", "sim_status", "sim_profile"):
        svc.declare("publishes", keys.key(name))

    svc.ready()
    linked = hardware.streaming if hardware is not None else None
    _wait_for_fleet(svc, barrier, wake, cfg.sim.lockstep, linked)
    # in lockstep the simulator's thread delivers the fleet's answers itself while it
    # waits for them (Dispatcher.lent): no hand-over to the dispatcher's thread and back
    # at every stage
    with bus.dispatcher.lent() if cfg.sim.lockstep else contextlib.nullcontext():
        _run(svc, sim, barrier, wake, profile, hardware)
    sim.close()


def _wait_for_fleet(
    svc: Service,
    barrier: Barrier,
    wake: threading.Condition,
    lockstep: bool,
    linked: Callable[[], bool] | None = None,
) -> None:
    """Hold the clock at 0 until the services in ``sim.start_after`` are up (bounded), in
    lockstep or free running (which started at once: a goal sent before the planner was up
    ended a mission at 0.1 s); on the hardware path also until ``linked()`` (the WHILL
    driver streams from the emulated chair: before, no odometry, so no pose).

    Lockstep participants count only once the barrier itself has seen their liveliness
    token: starting on a liveliness query's answer alone could run the first ticks
    without waiting for a participant whose token the barrier has not yet received.
    """
    wanted = set(svc.cfg.sim.start_after)
    participants = wanted & set(barrier.stage_of) if lockstep else set()
    others = wanted - participants
    deadline = time.monotonic() + svc.cfg.sim.start_wait_s
    present: set[str] = set()
    while not svc.stop_event.is_set():
        if others - present:
            present |= {k.rsplit("/", 1)[-1] for k in svc.bus.alive(svc.keys.key("alive"), 0.2)}
        unlinked = {"the WHILL driver's data stream"} if linked and not linked() else set()
        with wake:
            missing = (participants - barrier.alive) | (others - present) | unlinked
            if not missing:
                svc.log.info("fleet present; starting the clock")
                return
            if time.monotonic() > deadline:
                svc.log.warning(
                    "starting without %s (waited %.0f s)",
                    ", ".join(sorted(missing)),
                    svc.cfg.sim.start_wait_s,
                )
                return
            wake.wait(0.2)


def _run(
    svc: Service,
    sim: Simulation,
    barrier: Barrier,
    wake: threading.Condition,
    profile: TickProfile,
    hardware: HardwarePath | None = None,
) -> None:
    cfg, keys, bus = svc.cfg, svc.keys, svc.bus
    status_every = max(1, round(1.0 / (cfg.sim.status_rate_hz * cfg.sim.dt)))
    pacer = (
        Pacer(cfg.sim.realtime_factor, cfg.sim.max_lag_s, time.monotonic())
        if cfg.sim.realtime_factor > 0
        else None
    )
    timeouts = stalls = 0
    clock = time.perf_counter
    clock_keys = [keys.clock_of(stage) for stage in range(barrier.n_stages)]
    events_key = keys.key("events", source=NAME)
    profile.start()
    while not svc.stop_event.is_set():
        t0 = clock()
        with wake:
            result = sim.step()
            s = sim.state
            pose = Pose2D(s.x, s.y, s.theta, sim.floor)
        t1 = clock()
        profile.physics_s += t1 - t0
        stamp = result.stamp
        # the tick's messages go to the (in-process) dispatcher in one hand-over
        with bus.dispatcher.deferred():
            _publish_tick(svc, sim, result, s, pose, profile, hardware, status_every, events_key)
        t2 = clock()
        profile.publish_s += t2 - t1
        for stage in range(barrier.n_stages):
            with wake:
                due = barrier.waiting_on(result.tick, stage) if cfg.sim.lockstep else []
            if cfg.sim.lockstep and stage > 0 and not due:
                continue  # nobody in this stage is due this tick (free running: all are)
            stage_start = clock()
            key, announce = clock_keys[stage], Clock(stamp, result.tick, sim.dt, stage)
            bus.publish(key, announce)
            again = functools.partial(bus.publish, key, announce)
            if due and not _wait_stage(svc, barrier, wake, result.tick, stage, again):
                timeouts += 1
                if timeouts <= 10 or timeouts % 100 == 0:
                    with wake:
                        late = barrier.waiting_on(result.tick, stage)
                    svc.log.warning(
                        "tick %d: no answer from %s within %.2f s (%d so far)",
                        result.tick,
                        ", ".join(late),
                        cfg.sim.lockstep_timeout_s,
                        timeouts,
                    )
                    # in the report too: a run that went on without someone is not a
                    # repeatable run, and should say so
                    detail = f"tick {result.tick} stage {stage}: no answer from {', '.join(late)}"
                    bus.publish(
                        events_key, Event(stamp, NAME, "lockstep_timeout", detail, "warning")
                    )
            profile.stage_wait_s[stage] += clock() - stage_start
        profile.ticks += 1
        if pacer is not None:
            t3 = clock()
            wait, slip = pacer.wait_s(stamp, time.monotonic())
            if wait > 0:
                _idle(svc, wait)
            elif slip >= STALL_S:
                stalls += 1
                if stalls <= 10 or stalls % 100 == 0:
                    detail = (
                        f"{slip:.2f} s of wall time behind at tick {result.tick}: let go, not "
                        f"run in a burst (sim.max_lag_s {cfg.sim.max_lag_s:g}; "
                        f"{pacer.slipped_s:.1f} s so far)"
                    )
                    svc.log.warning("%s", detail)
                    bus.publish(events_key, Event(stamp, NAME, "behind", detail, "warning"))
            profile.pacing_s += clock() - t3


def _publish_tick(
    svc: Service,
    sim: Simulation,
    result: StepResult,
    s: ChairState,
    pose: Pose2D,
    profile: TickProfile,
    hardware: HardwarePath | None,
    status_every: int,
    events_key: str,
) -> None:
    """Publish what the simulator knows after a step: the chair's sensors (or hand them to
    the drivers), the ground truth, events, and now and then its status and profile
    (``s`` and ``pose``: the chair after the step, read under the bus lock)."""
    cfg, keys, bus = svc.cfg, svc.keys, svc.bus
    stamp = result.stamp
    rider = ""
    if hardware is not None:  # the drivers publish the chair's sensors
        if result.scan is not None:
            hardware.send_scan(result.scan, time.time())
        rider = hardware.ride(stamp)
    else:
        # the chair's sensors: stamped as a driver stamps them (its host's clock) on wall
        # time
        sensed = time.time() + cfg.sim.stamp_offset_s if cfg.clock == "wall" else stamp
        if result.scan is not None:
            bus.publish(keys.scan, PointCloud(sensed, "lidar", result.scan))
        o = sim.odometry
        # wheel odometry knows nothing of floors: the floor comes from the lift protocol
        bus.publish(keys.odom, Odometry(sensed, Pose2D(o.x, o.y, o.theta, ""), o.v, o.w))
    bus.publish(keys.ground_truth, Odometry(stamp, pose, s.v, s.w, frame="ground_truth"))
    if result.new_collision:
        bus.publish(
            events_key,
            Event(
                stamp,
                NAME,
                "collision",
                f"with {sim.nearest} at ({s.x:.2f}, {s.y:.2f}, {math.degrees(s.theta):.0f} deg)",
                "error",
            ),
        )
    for text in result.events:
        bus.publish(events_key, Event(stamp, NAME, "watchdog", text, "warning"))
    if result.kidnapped:
        bus.publish(events_key, Event(stamp, NAME, "kidnapped", result.kidnapped, "warning"))
    if rider:
        bus.publish(events_key, Event(stamp, NAME, "rider", rider, "info"))
    if result.new_collision or result.tick % status_every == 0:
        bus.publish(keys.sim_status, status_message(sim, stamp))
    if result.tick % PROFILE_EVERY == 0:
        bus.publish(keys.sim_profile, profile.message(stamp))


def _wait_stage(
    svc: Service,
    barrier: Barrier,
    wake: threading.Condition,
    tick: int,
    stage: int,
    announce: Callable[[], None],
) -> bool:
    """Wait until every live participant of ``stage`` answered ``tick``; False after
    ``sim.lockstep_timeout_s``. Every ``REANNOUNCE_S`` of the wait the tick is announced
    again: a participant restarted meanwhile declared its subscription after the first
    announcement and would otherwise wait for the next tick while the simulator waits for
    it (one that has answered ignores a repeat; so does one still at work, once done)."""
    deadline = time.monotonic() + svc.cfg.sim.lockstep_timeout_s

    def done() -> bool:
        with wake:
            return svc.stop_event.is_set() or barrier.answered(tick, stage)

    while True:
        left = deadline - time.monotonic()
        if svc.bus.dispatcher.pump(done, max(0.0, min(REANNOUNCE_S, left))):
            return True
        if left <= REANNOUNCE_S:
            return False
        announce()


def _idle(svc: Service, wait_s: float) -> None:
    """Wait ``wait_s`` (pacing), delivering meanwhile if the dispatcher is lent to this
    thread (lockstep), or until the service stops."""
    if not svc.cfg.sim.lockstep:
        svc.stop_event.wait(wait_s)
        return
    svc.bus.dispatcher.pump(svc.stop_event.is_set, wait_s)


def _finite(value: float, cap: float = 1e6) -> float:
    return min(value, cap)


if __name__ == "__main__":
    main()
