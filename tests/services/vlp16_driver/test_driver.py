"""The VLP-16 driver: packets the encoder makes from the simulator's own LiDAR, sent over UDP
on loopback and decoded by velodyne_decoder, come out one revolution at a time with the
sim's points; malformed datagrams are counted and skipped; the node publishes a revolution
as a PointCloud on ``scan`` over a real Zenoh session."""

from __future__ import annotations

import math
import queue
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from services.vlp16_driver.config import Vlp16Config
from services.vlp16_driver.decode import MalformedPacket, Revolution, RevolutionDecoder
from services.vlp16_driver.receiver import UdpReceiver
from shared.config import ConfigError
from shared.messages import PointCloud
from shared.site import GridMap
from shared.topics import Keys
from sim import vlp16_packets as vp
from sim.lidar3d import MultiRingLidar
from sim.sitegen import draw
from sim.world import World
from tests.conftest import stop_node

ROOT = Path(__file__).resolve().parents[3]
WAIT_S = 60.0  # for any event: generous, the machine may be loaded
MIN_RANGE, MAX_RANGE = 0.4, 100.0


@pytest.fixture(scope="module")
def sim_scans() -> list[np.ndarray]:
    """Two scans of the simulator's VLP-16 in a 10 m x 8 m room with a pillar."""
    res, w, h, t = 0.05, 10.2, 8.2, 0.2
    walls = [(0, 0, w, t), (0, h - t, w, h), (0, 0, t, h), (w - t, 0, w, h), (7, 6, 7.6, 6.6)]
    occ = draw((w, h), walls, resolution=res)
    world = World(GridMap(np.where(occ, 100, 0).astype(np.int8), res, (0.0, 0.0, 0.0)))
    try:
        lidar = MultiRingLidar.for_world(
            world, height_m=1.5, noise_m=0.01, rng=np.random.default_rng(4)
        )
        return [lidar.scan(5.0, 4.0, 0.3), lidar.scan(3.0, 2.5, -2.0)]
    finally:
        world.close()


def assert_matches_sim(points: np.ndarray, sim_points: np.ndarray) -> None:
    """``points`` are the sim's scan as a VLP-16 reports it: one per sim return, each within
    the 2 mm distance unit and the lasers' stagger (0.07 deg) of its beam, from its laser's
    origin (up to 11.2 mm above the sensor's)."""
    ranges = vp.points_to_ranges(sim_points)
    assert np.isfinite(ranges).sum() == len(sim_points)  # every sim return has its own beam
    expected = vp.reported_points(ranges, MIN_RANGE, MAX_RANGE)
    assert points.dtype == np.float32 and points.shape == expected.shape == sim_points.shape
    r = np.linalg.norm(expected, axis=1)
    assert np.all(np.linalg.norm(points - expected, axis=1) <= r * math.radians(0.0066) + 1e-4)
    ring, column = vp.reported_beams(ranges, MIN_RANGE, MAX_RANGE)
    sim = np.radians(-180.0 + column * 360.0 / ranges.shape[1])
    el = np.radians(-15.0 + 2.0 * ring)
    beam = np.stack([np.cos(el) * np.cos(sim), np.cos(el) * np.sin(sim), np.sin(el)], 1)
    sim_at = beam * ranges[ring, column][:, None]
    bound = 0.001 + 0.0113 + ranges[ring, column] * math.radians(0.0701)
    assert np.all(np.linalg.norm(points - sim_at, axis=1) <= bound)


class Driver:
    """The driver's core behind a UDP port on loopback, as the node wires it."""

    def __init__(self) -> None:
        self.decoder = RevolutionDecoder(MIN_RANGE, MAX_RANGE)
        self.revolutions: queue.Queue[Revolution] = queue.Queue()
        self.problems: queue.Queue[str] = queue.Queue()
        self.receiver = UdpReceiver("127.0.0.1", 0, self.on_datagram)

    def on_datagram(self, data: bytes, stamp: float) -> None:
        try:
            rev = self.decoder.feed(data, stamp)
        except MalformedPacket as exc:
            self.problems.put(str(exc))
            return
        if rev is not None:
            self.revolutions.put(rev)


@pytest.fixture
def driver() -> Iterator[Driver]:
    d = Driver()
    with d.receiver:
        yield d


def test_a_sim_revolution_over_udp_comes_out_as_one_revolution_of_its_points(
    driver: Driver, sim_scans: list[np.ndarray]
) -> None:
    with vp.PacketSender("127.0.0.1", driver.receiver.port) as sender:
        for scan in sim_scans:
            packets = vp.encode_revolution(vp.points_to_ranges(scan))
            sender.send(packets)
            rev = driver.revolutions.get(timeout=WAIT_S)
            assert rev.packets == 75 and rev.coverage_deg == pytest.approx(360.0)
            assert_matches_sim(rev.points, scan)
    assert driver.decoder.revolutions == 2 and driver.decoder.packets == 150
    assert driver.revolutions.empty() and driver.problems.empty()


def test_malformed_datagrams_are_counted_and_skipped(
    driver: Driver, sim_scans: list[np.ndarray]
) -> None:
    packets = vp.encode_revolution(vp.points_to_ranges(sim_scans[0]))
    truncated = packets[30][:600]
    wrong_flag = b"\x00\x00" + packets[31][2:]
    hdl32 = packets[32][:-1] + b"\x21"  # another product's packet
    junk = [truncated, wrong_flag, hdl32, b""]
    with vp.PacketSender("127.0.0.1", driver.receiver.port, speed=math.inf) as sender:
        sender.send(packets[:30] + junk + packets[30:])
    rev = driver.revolutions.get(timeout=WAIT_S)
    assert_matches_sim(rev.points, sim_scans[0])
    problems = [driver.problems.get(timeout=WAIT_S) for _ in junk]
    assert problems == [
        "600 bytes, not 1206",
        "block 0: flag 0x0000, not 0xeeff",
        "product id 0x21, not a VLP-16 (0x22)",
        "0 bytes, not 1206",
    ]
    assert driver.decoder.malformed == 4 and driver.decoder.packets == 75


def feed(decoder: RevolutionDecoder, packets: list[bytes]) -> list[Revolution]:
    out = [decoder.feed(p, 100.0 + i * vp.PACKET_S) for i, p in enumerate(packets)]
    return [r for r in out if r is not None]


def rotated(packets: list[bytes], by_cdeg: int) -> list[bytes]:
    """The packets of a sensor whose head is ``by_cdeg`` (0.01 deg) further round."""
    arr = np.frombuffer(b"".join(packets), dtype=vp.PACKET_DTYPE).copy()
    arr["blocks"]["azimuth"] = (arr["blocks"]["azimuth"].astype(int) + by_cdeg) % 36000
    return [p.tobytes() for p in arr]


def test_revolutions_are_cut_at_the_azimuth_wrap_wherever_it_falls() -> None:
    ranges = vp.points_to_ranges(np.array([[5.0, 0.0, 0.0]]))
    revs = [vp.encode_revolution(ranges * (1 + k)) for k in range(3)]
    # the wrap inside a packet (the sensor's usual case): that packet ends the revolution
    decoder = RevolutionDecoder()
    out = feed(decoder, rotated(revs[0] + revs[1] + revs[2], 200))
    assert [r.packets for r in out] == [75, 75, 75]
    assert [r.coverage_deg for r in out] == pytest.approx([360.0] * 3)
    assert [round(float(np.linalg.norm(r.points)), 2) for r in out] == [5.0, 10.0, 15.0]
    # joined mid-turn: the partial first revolution is dropped, the next comes whole
    decoder = RevolutionDecoder()
    out = feed(decoder, revs[0][40:] + revs[1])
    assert [r.packets for r in out] == [75] and decoder.dropped == 1
    # the head a little slower than the last packet said: the wrap comes one block late,
    # inside the next packet; it is the wrap the revolution was cut at, not a new one
    late = np.frombuffer(b"".join(revs[1]), dtype=vp.PACKET_DTYPE).copy()
    late["blocks"]["azimuth"][0, 0] = 35999
    out = feed(RevolutionDecoder(), revs[0] + [p.tobytes() for p in late] + revs[2][:1])
    assert [r.packets for r in out] == [75, 75]
    # the packet with the wrap lost: the revolution ends when the next one starts
    decoder = RevolutionDecoder()
    out = feed(decoder, revs[0][:-1] + revs[1][:1])
    assert [r.packets for r in out] == [74] and out[0].coverage_deg == pytest.approx(355.2)


def test_a_revolution_is_stamped_with_the_arrival_of_its_last_packet() -> None:
    packets = vp.encode_revolution(vp.points_to_ranges(np.array([[0.0, 3.0, 0.0]])))
    (rev,) = feed(RevolutionDecoder(), packets)
    assert rev.stamp == pytest.approx(100.0 + 74 * vp.PACKET_S)
    assert rev.points[0, 1] == pytest.approx(3.0, abs=0.002)  # to the left: y


def test_a_malformed_packet_leaves_the_revolution_being_gathered_as_it_was() -> None:
    packets = vp.encode_revolution(vp.points_to_ranges(np.array([[5.0, 0.0, 0.0]])))
    decoder = RevolutionDecoder()
    assert feed(decoder, packets[:-1]) == []
    bad_azimuth = bytearray(packets[-1])
    bad_azimuth[2:4] = (36000).to_bytes(2, "little")
    for bad in (bytes(bad_azimuth), packets[-1][:-2] + b"\x40\x22"):
        with pytest.raises(MalformedPacket, match="azimuth 36000|return mode 0x40"):
            decoder.feed(bad, 1.0)
    (rev,) = feed(decoder, packets[-1:])
    assert rev.packets == 75 and len(rev.points) == 1 and decoder.malformed == 2


def test_config_checks_name_the_key() -> None:
    Vlp16Config().validate()
    for bad, key in [
        (Vlp16Config(port=70000), "vlp16.port"),
        (Vlp16Config(bind_address="eth0"), "vlp16.bind_address"),
        (Vlp16Config(frame=""), "vlp16.frame"),
        (Vlp16Config(min_range_m=5.0, max_range_m=2.0), "vlp16.min_range_m"),
    ]:
        with pytest.raises(ConfigError, match=key):
            bad.validate()


def free_udp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_the_node_publishes_a_revolution_on_scan(router, sim_scans: list[np.ndarray]) -> None:
    bus, endpoint = router
    keys = Keys("vlp")
    scans: queue.Queue[PointCloud] = queue.Queue()
    alive = threading.Event()
    bus.subscribe(keys.scan, PointCloud, scans.put)
    bus.watch_alive(keys.key("alive", service="vlp16_driver"), lambda _key, up: up and alive.set())
    port = free_udp_port()
    args = ["--connect", endpoint, "--robot", "vlp", "--set", "clock=wall"]
    args += ["--set", f"vlp16.port={port}", "--set", "vlp16.bind_address=127.0.0.1"]
    args += ["--set", "vlp16.stamp_offset_s=3600"]  # its host's clock an hour ahead
    proc = subprocess.Popen(
        [sys.executable, "-m", "services.vlp16_driver.node", *args],
        cwd=ROOT,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert alive.wait(WAIT_S), "the driver never announced itself"
        packets = vp.encode_revolution(vp.points_to_ranges(sim_scans[1]))
        with vp.PacketSender("127.0.0.1", port) as sender:
            sender.send([b"not a packet", *packets])
        cloud = scans.get(timeout=WAIT_S)
        assert cloud.frame == "lidar"
        assert cloud.stamp == pytest.approx(time.time() + 3600, abs=60)
        assert_matches_sim(cloud.points, sim_scans[1])
    finally:
        err = stop_node(proc, WAIT_S)
    assert proc.returncode == 0, err
    assert "dropped malformed packet (1 so far): 12 bytes, not 1206" in err
    assert "75 packets, 1 malformed, 1 revolutions published, 0 dropped" in err
