"""The simulator's hardware path without Zenoh: its settings, the port's link, the scans
as paced UDP packets, and the simulated chair driven by the real WHILL driver (through
WHILL's SDK on the emulator's pseudo terminal) while the VLP-16 driver's receiver and
decoder get its scans back.

Waits poll with generous timeouts; nothing asserts how long something took.
"""

from __future__ import annotations

import math
import os
import queue
import socket
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from services.vlp16_driver.decode import Revolution, RevolutionDecoder
from services.vlp16_driver.receiver import UdpReceiver
from services.whill_driver.config import WhillConfig
from services.whill_driver.driver import Driver
from shared import config
from shared.config import ConfigError, FleetConfig, RiderConfig
from shared.messages import Twist
from shared.site import load_site
from sim import vlp16_packets as vp
from sim.hardware_path import HardwarePath, check_hardware_path, link_port, unlink_port
from sim.scan_sender import ScanSender, revolution_packets
from sim.simulation import Simulation
from tests.conftest import ROOT
from wheelnav.mission.run import fleet_profile, free_port, private_links

WAIT_S = 30.0
HARDWARE_PATH = ["clock=wall", "sim.lockstep=false", "sim.hardware_path=true"]


def wait_for(predicate: Callable[[], object], what: str, timeout_s: float = WAIT_S) -> None:
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        if predicate():
            return
        time.sleep(0.02)
    raise AssertionError(f"timed out waiting for {what}")


def ring_points(ranges_m: float | np.ndarray, n_az: int = 1800) -> np.ndarray:
    """Sensor-frame points on the simulated VLP-16's beams (sim/lidar3d.py's layout),
    ``ranges_m`` (16, n_az) or one range for every beam; none where a range is inf."""
    el = np.radians(np.linspace(-15.0, 15.0, 16))[:, None]
    az = np.linspace(-math.pi, math.pi, n_az, endpoint=False)[None, :]
    r = np.broadcast_to(np.asarray(ranges_m, dtype=float), (16, n_az))
    pts = np.stack([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el) + 0 * az], -1)
    hit = np.isfinite(r)
    return (pts[hit] * r[hit][:, None]).astype(np.float32)


# -- settings -------------------------------------------------------------------------------


def test_the_hardware_path_runs_on_wall_time_only_and_says_which_key_is_wrong() -> None:
    check_hardware_path(FleetConfig())  # off: anything goes
    check_hardware_path(config.load(None, [*HARDWARE_PATH]))
    for extra, key in [
        (["clock=sim"], "clock"),
        (["sim.lockstep=true"], "sim.lockstep"),
        (["sim.realtime_factor=0"], "sim.realtime_factor"),
        (["sim.lidar=planar"], "sim.lidar"),
        (["sim.stamp_offset_s=3600"], "sim.stamp_offset_s"),
    ]:
        with pytest.raises(ConfigError, match=rf"^{key}: must be .* with sim.hardware_path"):
            check_hardware_path(config.load(None, [*HARDWARE_PATH, *extra]))
    with pytest.raises(ConfigError, match="sim.vlp16_host: must be an IPv4 address"):
        config.load(None, ["sim.vlp16_host=localhost"])


def test_a_scripted_rider_needs_the_hardware_path_and_a_deflected_joystick() -> None:
    rider = "sim.riders=[{at_s: 4.0, for_s: 0.5, front: 40}]"
    check_hardware_path(config.load(None, [*HARDWARE_PATH, rider]))
    with pytest.raises(ConfigError, match=r"^sim.riders: needs sim.hardware_path"):
        check_hardware_path(config.load(None, [rider]))
    with pytest.raises(ConfigError, match=r"^sim.riders\[0\]: front or side must not be 0"):
        check_hardware_path(config.load(None, [*HARDWARE_PATH, "sim.riders=[{at_s: 1}]"]))
    with pytest.raises(ConfigError, match=r"front: must be in -100..100"):
        config.load(None, ["sim.riders=[{front: 101}]"])


def test_a_hardware_path_mission_runs_its_profile_on_links_of_its_own(tmp_path: Path) -> None:
    assert fleet_profile(FleetConfig()) == "sim"
    cfg = config.load(None, HARDWARE_PATH)
    assert fleet_profile(cfg) == "hardware_path"
    with pytest.raises(ConfigError, match="^clock"):
        fleet_profile(config.load(None, ["sim.hardware_path=true"]))
    data = config.to_dict(cfg)
    private_links(data, tmp_path)
    again = config.from_dict(FleetConfig, data)
    assert again.whill.port == str(tmp_path / "whill")
    assert again.vlp16.port not in (0, 2368)
    assert {"driver", "vlp16_driver"} <= set(again.sim.start_after)


def test_the_port_is_linked_replacing_an_old_link_but_never_a_file(tmp_path: Path) -> None:
    link = tmp_path / "dev" / "whill"
    link_port("/dev/null", str(link))
    assert os.readlink(link) == "/dev/null"
    link_port("/dev/zero", str(link))  # a link left by an earlier run is replaced
    assert os.readlink(link) == "/dev/zero"
    unlink_port("/dev/null", str(link))  # not ours any more: left alone
    assert link.is_symlink()
    unlink_port("/dev/zero", str(link))
    assert not link.exists() and not link.is_symlink()
    plain = tmp_path / "ttyUSB0"
    plain.write_text("a device, say")
    with pytest.raises(FileExistsError, match="not a symbolic link"):
        link_port("/dev/null", str(plain))
    assert plain.read_text() == "a device, say"


# -- the LiDAR's packets ---------------------------------------------------------------------


def test_a_scan_is_one_revolution_the_drivers_decoder_gives_back() -> None:
    rng = np.random.default_rng(5)
    ranges = rng.uniform(0.5, 20.0, (16, 1800))
    ranges[rng.random(ranges.shape) < 0.2] = np.inf  # beams without a return
    points = ring_points(ranges)
    packets = revolution_packets(points, stamp_s=12.0)
    assert len(packets) == 75
    decoder = RevolutionDecoder(min_range_m=0.4, max_range_m=100.0)
    revs = [r for p in packets if (r := decoder.feed(p, 1.0)) is not None]
    assert len(revs) == 1 and len(revs[0].points) == len(points)
    # within the 2 mm distance unit (and the float32 points' rounding) of the sim's beams
    expected = vp.reported_points(ranges, 0.4, 100.0)
    assert np.abs(revs[0].points - expected).max() < 0.004


def test_the_sender_paces_each_scan_and_replaces_one_left_waiting() -> None:
    received: queue.Queue[bytes] = queue.Queue()
    with UdpReceiver("127.0.0.1", 0, lambda data, _stamp: received.put(data)) as receiver:
        sender = ScanSender("127.0.0.1", receiver.port).start()
        try:
            scans = [ring_points(r) for r in (4.0, 5.0, 6.0)]
            sender.submit(scans[0], 0.0)
            wait_for(lambda: sender.packets > 0, "the first scan going out")
            sender.submit(scans[1], 0.1)  # waits for the first to be sent...
            sender.submit(scans[2], 0.2)  # ...and is replaced by this one
            wait_for(lambda: sender.revolutions == 2, "two revolutions sent")
        finally:
            sender.close()
        wait_for(lambda: received.qsize() >= 150, "150 packets")
    decoder = RevolutionDecoder()
    revs = [decoder.feed(received.get(), 0.0) for _ in range(150)]
    ranges = [float(np.linalg.norm(r.points[0])) for r in revs if r is not None]
    assert ranges == pytest.approx([4.0, 6.0], abs=0.02) and sender.dropped == 1


# -- the chair driven through the WHILL driver, its scans back through the VLP-16 driver ------


@pytest.fixture
def hardware_path(tmp_path: Path):
    """A Simulation of the two-rooms site on the hardware path, the WHILL driver on its
    port's link, and the VLP-16 driver's receiver and decoder on its packets' port."""
    revolutions: queue.Queue[Revolution] = queue.Queue()
    decoder = RevolutionDecoder()

    def on_datagram(data: bytes, stamp: float) -> None:
        rev = decoder.feed(data, stamp)
        if rev is not None:
            revolutions.put(rev)

    receiver = UdpReceiver("127.0.0.1", free_port(socket.SOCK_DGRAM), on_datagram)
    cfg = config.load(
        None,
        [
            *HARDWARE_PATH,
            f"site={ROOT / 'sites' / 'two_rooms'}",
            f"whill.port={tmp_path / 'whill'}",
            f"vlp16.port={receiver.port}",
        ],
    )
    hardware = HardwarePath(cfg)
    sim = Simulation(cfg, load_site(cfg.site), hardware.drive)
    driver = Driver(WhillConfig(port=cfg.whill.port))
    receiver.start()
    driver.start()
    try:
        yield sim, hardware, driver, revolutions
    finally:
        driver.close()
        hardware.close()
        receiver.close()
        sim.close()


def test_the_whill_driver_drives_the_simulated_chair_and_the_scans_come_back(
    hardware_path,
) -> None:
    sim, hardware, driver, revolutions = hardware_path
    wait_for(hardware.streaming, "the driver asking the emulated chair for its data")
    start = sim.state.x, sim.state.y, sim.state.theta
    odometry = None
    end = time.monotonic() + WAIT_S
    # the simulator's loop and the driver's node loop, as one at 50 Hz of wall time
    while time.monotonic() < end and (odometry is None or odometry.pose.x < 1.0):
        driver.on_cmd_vel(Twist(time.time(), 0.4, 0.0))
        odometry = driver.step(time.time()).odometry or odometry
        result = sim.step()
        if result.scan is not None:
            hardware.send_scan(result.scan, time.time())
        time.sleep(0.02)
    assert odometry is not None and odometry.pose.x >= 1.0, "the chair never drove 1 m"
    wait_for(lambda: driver.step(time.time()).odometry.v == 0.0, "the chair stopping")
    sim.step()
    s = sim.state
    travelled = math.hypot(s.x - start[0], s.y - start[1])
    # where the driver's wheel odometry says, give or take the ground's errors (1 %, the
    # casters' kick) and the last step
    assert travelled == pytest.approx(driver.base.odometry.x, abs=0.05)
    assert abs(s.theta - start[2]) < 0.1 and sim.collisions == 0
    rev = revolutions.get(timeout=WAIT_S)
    assert rev.packets == 75 and len(rev.points) > 10_000  # walls and floor of the room
    assert hardware.sender.revolutions > 0 and hardware.emulator.reader.bad == 0


def test_a_scripted_rider_takes_the_joystick_and_the_driver_hands_the_chair_over(
    hardware_path,
) -> None:
    sim, hardware, driver, _ = hardware_path
    hardware.cfg.sim.riders = [RiderConfig(at_s=1.0, for_s=0.5, front=40)]
    wait_for(hardware.streaming, "the driver asking the emulated chair for its data")
    assert hardware.ride(0.5) == ""
    assert hardware.ride(1.0) == "the rider takes the joystick (front 40, side 0)"
    assert hardware.ride(1.2) == ""  # still held: nothing changed
    events: list[str] = []

    def rider_seen() -> bool:
        out = driver.step(time.time())
        events.extend(kind for kind, _, _ in out.events)
        return "joystick_taken" in events

    wait_for(rider_seen, "the driver seeing the rider's joystick")
    assert driver.base.rider
    assert hardware.ride(1.5) == "the rider lets go of the joystick"
    with hardware.emulator.locked() as chair:
        assert chair.joystick == (0, 0)
