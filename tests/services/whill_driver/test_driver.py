"""The WHILL driver: its core on a fake clock, then the driver against the emulated chair
through the real SDK on a pseudo terminal, then the node over a real Zenoh router.

Waits poll for events and states with generous timeouts; no test asserts how long
something took on the wall clock (the machine may be busy).
"""

from __future__ import annotations

import math
import signal
import subprocess
import threading
import time
from collections.abc import Callable, Iterator

import msgpack
import pytest
from whill import ComWHILL

from services.whill_driver.base import RELEASE, STOP, Action, Base, velocity_command
from services.whill_driver.config import WhillConfig
from services.whill_driver.driver import Driver
from services.whill_driver.odometry import Sample, WheelOdometry
from shared.config import ConfigError
from shared.messages import (
    Diagnostics,
    DriverStatus,
    EmergencyStop,
    EmergencyStopQuery,
    Odometry,
    Twist,
)
from shared.topics import Keys
from sim.whill_emulator import ChairModel, ChairParams, WhillEmulator
from tests.conftest import PYTHON, ROOT

WAIT_S = 30.0  # the longest any condition is waited for


def wait_for(predicate: Callable[[], bool], what: str, timeout_s: float = WAIT_S) -> None:
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        if predicate():
            return
        time.sleep(0.02)
    raise AssertionError(f"timed out waiting for {what}")


def sample(
    left: float = 0.0,
    right: float = 0.0,
    speeds: tuple[float, float] = (0.0, 0.0),
    joy: tuple[int, int] = (0, 0),
    error: int = 0,
    dt_ms: float = 20.0,
) -> Sample:
    """A data set 1 as the SDK decodes it (raw motor values: the right one counts back)."""
    return Sample(joy[0], joy[1], 70, 0.0, right, left, speeds[1], speeds[0], True, 4, error, dt_ms)


# -- the core on a fake clock -------------------------------------------------------------


def test_cmd_vel_becomes_setvelocity_units_within_the_limits() -> None:
    cfg = WhillConfig()
    assert velocity_command(0.3, 0.0, cfg) == (270, 0)
    assert velocity_command(0.0, 1.0, cfg) == (0, -446)  # left turn: side < 0
    assert velocity_command(0.0, -0.5, cfg) == (0, 223)
    assert velocity_command(5.0, 9.0, cfg) == (540, -446)  # 0.6 m/s, 1 rad/s
    assert velocity_command(-1.0, 0.0, cfg) == (-225, 0)  # 0.25 m/s reverse
    fast = WhillConfig(max_speed=3.0, max_reverse_speed=3.0, max_turn_rate=9.0)
    assert velocity_command(3.0, 9.0, fast) == (1500, -750)  # the chair's own ranges
    assert velocity_command(-3.0, -9.0, fast) == (-500, 750)


def test_bad_settings_are_named() -> None:
    with pytest.raises(ConfigError, match=r"whill\.right_wheel_sign: must be 1 or -1"):
        WhillConfig(right_wheel_sign=0).validate()
    with pytest.raises(ConfigError, match=r"whill\.data_interval_ms"):
        WhillConfig(data_interval_ms=150).validate()


def fed_base(**settings) -> Base:
    """A Base that has a data set (the link is up) at t = 0."""
    base = Base(WhillConfig(**settings))
    base.on_sample(sample(), 0.0)
    return base


def test_nothing_is_sent_before_the_first_command() -> None:
    base = fed_base()
    assert base.step(0.1) is None and base.drain_events() == []


def test_the_watchdog_stops_the_chair_when_commands_stop() -> None:
    base = fed_base()
    base.on_cmd_vel(Twist(0.0, 0.3, 0.0), 0.0)
    for t in (0.1, 0.2):
        base.on_sample(sample(), t)
        assert base.step(t) == Action("velocity", 270, 0)
    base.on_sample(sample(), 0.29)
    assert base.step(0.29) == Action("velocity", 270, 0)  # 0.29 s old: still fresh
    base.on_sample(sample(), 0.31)
    assert base.step(0.31) == STOP
    assert [e[0] for e in base.drain_events()] == ["command_timeout"]
    assert base.step(0.32) == STOP and base.drain_events() == []  # one event per stop
    base.on_cmd_vel(Twist(1.0, 0.2, 0.0), 0.33)
    assert base.step(0.33) == Action("velocity", 180, 0)
    assert [e[0] for e in base.drain_events()] == ["commands_resumed"]


def test_no_motion_while_the_chair_is_silent() -> None:
    base = fed_base()
    base.on_cmd_vel(Twist(0.0, 0.3, 0.0), 0.6)
    assert not base.data_fresh(0.6) and base.step(0.6) == STOP
    base.on_sample(sample(), 0.65)
    assert base.step(0.66) == Action("velocity", 270, 0)


def test_the_rider_on_the_joystick_gets_the_chair_until_it_rests() -> None:
    base = fed_base(joystick_release_s=1.0)
    base.on_cmd_vel(Twist(0.0, 0.3, 0.0), 0.0)
    base.on_sample(sample(joy=(3, -4)), 0.02)  # within the dead band: not the rider
    assert base.step(0.02) == Action("velocity", 270, 0) and not base.rider
    base.on_sample(sample(joy=(40, 0)), 0.04)
    base.on_cmd_vel(Twist(0.04, 0.3, 0.0), 0.04)  # the controller has not noticed yet
    assert base.step(0.04) == RELEASE
    assert base.status_message(1.0, True).joystick_active
    kind, detail, severity = base.drain_events()[0]
    assert kind == "joystick_taken" and severity == "warning"
    base.on_sample(sample(), 0.5)  # let go at 0.04 + a little
    base.on_cmd_vel(Twist(0.5, 0.3, 0.0), 0.5)
    assert base.step(0.9) == RELEASE  # at rest for less than joystick_release_s
    base.on_sample(sample(), 1.05)
    assert base.step(1.05) is None  # released: the command from before does not count
    assert [e[0] for e in base.drain_events()] == ["joystick_released"]
    base.on_cmd_vel(Twist(1.1, 0.1, 0.0), 1.1)
    assert base.step(1.1) == Action("velocity", 90, 0)


def test_the_emergency_stop_stops_the_chair_whatever_cmd_vel_says() -> None:
    base = fed_base(joystick_release_s=1.0)
    base.on_estop(True, "emergency stop by test")
    assert base.step(0.01) == STOP  # even before any command: the chair is held
    base.on_cmd_vel(Twist(0.0, 0.3, 0.0), 0.02)
    for t in (0.02, 0.1, 0.5):  # commands keep coming: a stop every cycle all the same
        base.on_sample(sample(), t)
        base.on_cmd_vel(Twist(t, 0.3, 0.0), t)
        assert base.step(t) == STOP
    kind, detail, severity = base.drain_events()[0]
    assert (kind, severity) == ("emergency_stop", "warning") and "by test" in detail
    base.on_sample(sample(joy=(40, 0)), 0.6)  # the rider's joystick still has the chair
    assert base.step(0.6) == RELEASE
    base.on_sample(sample(), 1.7)
    assert base.step(1.7) == STOP  # let go: back to the stop, not to the command
    base.on_estop(True)
    base.drain_events()
    base.on_estop(False)
    assert base.step(1.8) is None  # cleared: the commands from before do not count
    assert [e[0] for e in base.drain_events()] == ["emergency_stop"]
    base.on_cmd_vel(Twist(1.9, 0.2, 0.0), 1.9)
    assert base.step(1.9) == Action("velocity", 180, 0)


def test_the_chairs_condition_is_reported() -> None:
    base = fed_base()
    base.on_sample(sample(error=12), 0.1)
    status = base.status_message(5.0, True)
    assert status == DriverStatus(5.0, 70, 4, 12, joystick_active=False, serial_ok=True)
    assert [e[0] for e in base.drain_events()] == ["chair_error"]
    base.on_sample(sample(error=12), 0.12)
    assert base.drain_events() == []  # the same error: no new event


def test_odometry_integrates_wheel_angles_across_their_wrap() -> None:
    odo = WheelOdometry(0.1325, 0.496)
    speed = 1.0  # m/s: the wheels turn 0.151 rad per 20 ms and wrap at pi every 2.6 s
    kmh = speed * 3.6
    for k in range(301):  # 6 s straight ahead
        turned = speed * 0.02 * k / 0.1325
        angle = math.atan2(math.sin(turned), math.cos(turned))
        odo.update(sample(left=angle, right=-angle, speeds=(kmh, -kmh)))
    assert (odo.x, odo.y, odo.theta) == pytest.approx((6.0, 0.0, 0.0), abs=1e-9)
    assert (odo.v, odo.w) == pytest.approx((1.0, 0.0))


def test_odometry_turns_on_the_spot_counter_clockwise() -> None:
    odo = WheelOdometry(0.1325, 0.496)
    rate = 0.5  # rad/s: each tyre at 0.124 m/s, the right one forwards
    tyre = rate * 0.496 / 2
    for k in range(101):  # 2 s
        turned = tyre * 0.02 * k / 0.1325
        wrapped = math.atan2(math.sin(turned), math.cos(turned))
        # raw motor values: left backwards (negative), right forwards (counts negative)
        odo.update(
            sample(left=-wrapped, right=-wrapped, speeds=(-tyre * 3.6, -tyre * 3.6), dt_ms=20)
        )
    assert (odo.x, odo.y) == pytest.approx((0.0, 0.0), abs=1e-9)
    assert odo.theta == pytest.approx(1.0) and odo.w == pytest.approx(0.5)


def test_a_wrong_time_does_not_pick_the_wrong_turn() -> None:
    odo = WheelOdometry(0.1325, 0.496)
    odo.update(sample(left=3.0, right=-3.0))
    # 0.3 rad forwards crosses pi; the time says 95 ms instead of 20 (prediction 0.72 rad)
    wrapped = 3.3 - 2 * math.pi
    odo.update(sample(left=wrapped, right=-wrapped, speeds=(3.6, -3.6), dt_ms=95))
    assert odo.x == pytest.approx(0.3 * 0.1325)


# -- the driver against the emulated chair, through the SDK --------------------------------


class Controller:
    """Runs the driver as its node does, every 20 ms: the controller's command (when it
    sends one), then a step; keeps what the steps put out."""

    def __init__(self, driver: Driver) -> None:
        self.driver = driver
        self.command: Twist | None = None
        self.events: list[str] = []
        self.odometry: Odometry | None = None
        self.status: DriverStatus | None = None
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while not self._stop.wait(0.02):
            if self.command is not None:
                self.driver.on_cmd_vel(self.command)
            out = self.driver.step(time.time())
            self.events += [kind for kind, _, _ in out.events]
            self.odometry = out.odometry or self.odometry
            self.status = out.status or self.status

    def stop(self) -> None:
        self._stop.set()
        self._thread.join(timeout=5.0)


@pytest.fixture
def emulator(request) -> Iterator[WhillEmulator]:
    params = getattr(request, "param", ChairParams())
    with WhillEmulator(ChairModel(params, battery_level=66, speed_mode=4)) as emu:
        yield emu


@pytest.fixture
def running(emulator: WhillEmulator) -> Iterator[tuple[WhillEmulator, Controller]]:
    driver = Driver(WhillConfig(port=emulator.port))
    driver.start()
    controller = Controller(driver)
    try:
        wait_for(lambda: controller.status is not None and controller.status.serial_ok, "link")
        yield emulator, controller
    finally:
        controller.stop()
        driver.close()


def chair(emu: WhillEmulator, read: Callable[[ChairModel], object]) -> object:
    with emu.locked() as model:
        return read(model)


def test_a_commanded_arc_moves_the_chair_and_odometry_follows(running) -> None:
    emu, controller = running
    controller.command = Twist(0.0, 0.3, 0.3)
    wait_for(lambda: chair(emu, lambda c: c.theta) > 0.8, "the chair turning 0.8 rad")
    controller.command = None
    wait_for(lambda: chair(emu, lambda c: c.v == 0.0 and c.w == 0.0), "the chair stopping")
    wait_for(lambda: controller.odometry.v == 0.0, "odometry at rest")
    truth = chair(emu, lambda c: (c.x, c.y, c.theta))
    odom = controller.odometry
    assert odom.frame == "odom"
    assert math.hypot(truth[0], truth[1]) > 0.5  # it went somewhere
    assert truth[1] > 0.1  # to the left, as commanded
    assert (odom.pose.x, odom.pose.y) == pytest.approx(truth[:2], abs=0.02)
    assert odom.pose.theta == pytest.approx(truth[2], abs=0.02)
    assert emu.reader.bad == 0 and controller.driver.link.bad_reads == 0


def test_when_commands_stop_the_driver_stops_the_chair(running) -> None:
    emu, controller = running
    controller.command = Twist(0.0, 0.4, 0.0)
    wait_for(lambda: chair(emu, lambda c: c.v) > 0.3, "the chair driving")
    controller.command = None
    wait_for(lambda: "command_timeout" in controller.events, "the watchdog's event")
    wait_for(lambda: chair(emu, lambda c: c.v) == 0.0, "the chair stopping")
    # stopped by the driver's zero command (the chair's own timeout leaves it alone), and
    # still held under serial control
    assert chair(emu, lambda c: (c.last_velocity, c.serial_control)) == ((0, 0), True)


def test_the_chair_stops_on_its_own_when_its_host_falls_silent(emulator) -> None:
    com = ComWHILL(port=emulator.port, timeout=0.1)
    try:
        com.send_velocity(270, 0)  # one command, then nothing: a host that died
        wait_for(lambda: chair(emulator, lambda c: c.timeouts) == 1, "the chair's timeout")
        wait_for(lambda: chair(emulator, lambda c: c.v) == 0.0, "the chair stopping")
        moved, last, stopped_at = chair(emulator, lambda c: (c.x, c.last_command_at, c.timeout_at))
        assert moved > 0.1 and stopped_at - last >= 1.0  # it drove until its timeout
    finally:
        com.com.close()


STRICT = ChairParams(rider_overrides=False)  # the joystick drives only once handed over


@pytest.mark.parametrize("emulator", [STRICT], indirect=True, ids=["strict"])
def test_the_rider_taking_the_joystick_is_reported_and_given_the_chair(running) -> None:
    emu, controller = running
    controller.command = Twist(0.0, 0.0, 0.5)  # turning on the spot
    wait_for(lambda: chair(emu, lambda c: c.w) > 0.4, "the chair turning")
    with emu.locked() as model:
        model.rider_joystick(60, 0)
    wait_for(lambda: controller.status.joystick_active, "joystick_active in the status")
    assert "joystick_taken" in controller.events
    wait_for(
        lambda: chair(emu, lambda c: not c.serial_control and c.v > 0.5 and abs(c.w) < 0.01),
        "the chair following the rider",
    )
    with emu.locked() as model:
        model.rider_joystick(0, 0)
    wait_for(lambda: not controller.status.joystick_active, "the joystick released")
    assert "joystick_released" in controller.events
    wait_for(lambda: chair(emu, lambda c: c.serial_control and c.w > 0.4), "commands again")


def test_the_emergency_stop_stops_the_chair_at_once(running) -> None:
    emu, controller = running
    controller.command = Twist(0.0, 0.4, 0.0)
    wait_for(lambda: chair(emu, lambda c: c.v) > 0.3, "the chair driving")
    controller.driver.on_estop(True, "emergency stop by test")
    wait_for(lambda: chair(emu, lambda c: c.v) == 0.0, "the chair stopping")
    time.sleep(0.2)  # commands keep coming: the chair stays where it stopped
    assert chair(emu, lambda c: (c.v, c.last_velocity)) == (0.0, (0, 0))
    assert "emergency_stop" in controller.events
    controller.driver.on_estop(False)
    wait_for(lambda: chair(emu, lambda c: c.v) > 0.3, "the chair driving again")


def test_battery_speed_mode_and_errors_are_reported(running) -> None:
    emu, controller = running
    with emu.locked() as model:
        model.battery_level, model.speed_mode, model.error_code = 42, 2, 7
    wait_for(lambda: controller.status.error_code == 7, "the error in the status")
    status = controller.status
    assert (status.battery_percent, status.speed_mode, status.serial_ok) == (42, 2, True)
    assert "chair_error" in controller.events


def test_closing_the_driver_stops_the_chair_and_hands_it_back(running) -> None:
    emu, controller = running
    controller.command = Twist(0.0, 0.3, 0.0)
    wait_for(lambda: chair(emu, lambda c: c.v) > 0.2, "the chair driving")
    controller.stop()
    controller.driver.close()
    wait_for(lambda: chair(emu, lambda c: c.v) == 0.0, "the chair stopping")
    assert chair(emu, lambda c: (c.last_velocity, c.serial_control)) == ((0, 0), False)


def test_a_missing_port_is_reported_not_raised() -> None:
    driver = Driver(WhillConfig(port="/nonexistent/ttyWHILL", reconnect_s=0.1))
    driver.start()
    try:
        driver.on_cmd_vel(Twist(0.0, 0.3, 0.0))
        out = driver.step(1.0)
        assert out.odometry is None and out.status is not None and not out.status.serial_ok
    finally:
        driver.close()


# -- the node over a real Zenoh router ----------------------------------------------------


def test_the_node_drives_the_chair_and_counts_bad_commands(router, emulator) -> None:
    bus, endpoint = router
    keys = Keys("chair1")
    odometry: list[Odometry] = []
    statuses: list[DriverStatus] = []
    diagnostics: list[Diagnostics] = []
    bus.subscribe(keys.odom, Odometry, odometry.append)
    bus.subscribe(keys.driver_status, DriverStatus, statuses.append)
    bus.subscribe(keys.key("diagnostics", service="driver"), Diagnostics, diagnostics.append)
    argv = ["--connect", endpoint, "--set", "clock=wall", "--port", emulator.port]
    argv += ["--set", "whill.stamp_offset_s=-3600"]  # its host's clock an hour behind
    node = subprocess.Popen(
        [PYTHON, "-m", "services.whill_driver.node", *argv],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    try:
        alive = keys.key("alive", service="driver")
        wait_for(lambda: bus.alive(alive) == [alive], "the driver's liveliness token", 90.0)
        wait_for(lambda: statuses and statuses[-1].serial_ok, "serial_ok in the status")
        bad = msgpack.packb({"t": "twist", "v": 1, "d": {"stamp": 1.0, "v": math.nan, "w": 0.0}})
        for payload in (b"\x00garbage", bad):
            bus.session.put(keys.cmd_vel, payload)
        wait_for(
            lambda: diagnostics and diagnostics[-1].bad_messages >= 2, "the bad commands counted"
        )
        counts = {k.key: (k.messages_in, k.bad_messages) for k in diagnostics[-1].keys}
        assert counts[keys.cmd_vel] == (2, 2)
        assert chair(emulator, lambda c: c.commands) == 0  # neither moved the chair

        def driving() -> bool:
            bus.publish(keys.cmd_vel, Twist(time.time(), 0.3, 0.0))
            return bool(odometry) and odometry[-1].pose.x > 0.2

        wait_for(driving, "odometry 0.2 m ahead")
        assert odometry[-1].frame == "odom" and odometry[-1].v > 0.1
        assert odometry[-1].stamp == pytest.approx(time.time() - 3600, abs=60)
        assert node.poll() is None  # bad commands did not end it

        # the emergency stop: the chair stops while cmd_vel keeps coming, until cleared
        bus.publish(keys.estop, EmergencyStop(time.time(), True, "test", "node test"))

        def stopped() -> bool:
            bus.publish(keys.cmd_vel, Twist(time.time(), 0.3, 0.0))
            return bool(chair(emulator, lambda c: c.v == 0.0 and c.last_velocity == (0, 0)))

        wait_for(stopped, "the chair stopped by the emergency stop")
        state_key = keys.key("estop_state", service="driver")
        held = bus.call(state_key, EmergencyStopQuery("test"), EmergencyStop, 5.0)
        assert held.active and held.reason == "node test"
        bus.publish(keys.estop, EmergencyStop(time.time(), False, "test"))

        def moving() -> bool:
            bus.publish(keys.cmd_vel, Twist(time.time(), 0.3, 0.0))
            return bool(chair(emulator, lambda c: c.v > 0.1))

        wait_for(moving, "the chair driving again once the stop is cleared")
        bus.publish(keys.cmd_vel, Twist(time.time(), 0.3, 0.0))
        node.send_signal(signal.SIGKILL)  # gone without a word, the chair driving
        node.wait(timeout=10)
        at_kill = chair(emulator, lambda c: c.x)
        wait_for(lambda: chair(emulator, lambda c: c.timeouts) == 1, "the chair's own timeout")
        wait_for(lambda: chair(emulator, lambda c: c.v) == 0.0, "the chair stopping")
        moved, last, stopped_at = chair(emulator, lambda c: (c.x, c.last_command_at, c.timeout_at))
        assert stopped_at - last >= 1.0 and moved > at_kill + 0.1  # it drove on until then
    finally:
        if node.poll() is None:
            node.kill()
        out, _ = node.communicate(timeout=10)
    assert "Traceback" not in out, out
    assert "dropped bad message on wheelnav/chair1/cmd_vel" in out, out
