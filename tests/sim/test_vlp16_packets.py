"""The VLP-16 packet encoder: the manual's layout, and a round trip through velodyne_decoder
(the driver's decoder) that gives the encoded returns back within the 2 mm distance unit
and the 0.01 deg azimuth rounding; the UDP sender delivers every packet, in order."""

from __future__ import annotations

import math
import socket
import struct
import threading
import time
from collections.abc import Iterator

import numpy as np
import pytest
import velodyne_decoder as vd

from sim import vlp16_packets as vp

N_AZ = 1800
RECEIVE_TIMEOUT_S = 30.0  # per datagram; generous for a loaded machine


def random_ranges(seed: int = 0, no_return: float = 0.1) -> np.ndarray:
    """A (16, 1800) grid of ranges from 0.5 to 80 m, a share of beams without a return."""
    rng = np.random.default_rng(seed)
    ranges = rng.uniform(0.5, 80.0, (vp.LASERS, N_AZ))
    ranges[rng.random(ranges.shape) < no_return] = np.inf
    return ranges


def decode(packets: list[bytes], min_range: float = 0.1, max_range: float = 200.0) -> np.ndarray:
    """x, y, z of every return velodyne_decoder finds in ``packets`` (one scan)."""
    decoder = vd.ScanDecoder(
        vd.Config(model=vd.Model.VLP16, min_range=min_range, max_range=max_range)
    )
    _stamp, cloud = decoder.decode(vd.PacketVector([vd.VelodynePacket(0.0, p) for p in packets]))
    return cloud[:, :3]


def sim_angle_deg(column: np.ndarray, n_az: int = N_AZ) -> np.ndarray:
    """The sim's angle (counter-clockwise from x) of an azimuth column (sim/lidar3d.py)."""
    return -180.0 + column * 360.0 / n_az


def angle_diff_deg(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.abs((a - b + 180.0) % 360.0 - 180.0)


def test_a_revolution_is_75_packets_laid_out_as_the_manual_says() -> None:
    ranges = np.full((vp.LASERS, N_AZ), np.inf)
    ranges[8, N_AZ // 2] = 5.0  # ring 8 (+1 deg: laser 1), straight ahead (sensor azimuth 0)
    start = 7200 + 12.5  # two hours and 12.5 s: 12,500,000 us past the hour
    packets = vp.encode_revolution(ranges, start_s=start)
    assert len(packets) == 75 and {len(p) for p in packets} == {vp.PACKET_SIZE}
    azimuths = []
    for i, packet in enumerate(packets):
        for b in range(12):
            flag, azimuth = struct.unpack_from("<2sH", packet, 100 * b)
            assert flag == b"\xff\xee"
            azimuths.append(azimuth)
        stamp_us, mode, product = struct.unpack_from("<IBB", packet, 1200)
        assert (mode, product) == (0x37, 0x22)
        assert stamp_us == 12_500_000 + round(i * 1327.104)
    # two firings of 0.2 deg a block; blocks start 0.06 deg early (half the lasers' stagger)
    assert azimuths[0] == 20 - 6 and np.all(np.diff(azimuths) == 40)
    assert azimuths[-1] == 36000 - 40 + 20 - 6
    # the turn's firings are at sensor azimuths 0.2, 0.4, ... 360 deg: straight ahead is the
    # last one, the second firing of the last block (packet 74, block 11); laser 1: channel 17
    found = []
    for i, packet in enumerate(packets):
        for b in range(12):
            for c in range(32):
                dist, refl = struct.unpack_from("<HB", packet, 100 * b + 4 + 3 * c)
                if dist:
                    found.append((i, b, c, dist, refl))
    assert found == [(74, 11, 17, 2500, vp.DEFAULT_REFLECTIVITY)]


def test_round_trip_through_velodyne_decoder_gives_the_returns_back() -> None:
    ranges = random_ranges()
    decoded = decode(vp.encode_revolution(ranges))
    ring, column = vp.reported_beams(ranges, 0.1, 200.0)
    assert len(decoded) == np.isfinite(ranges).sum() == len(ring)
    laser = np.argsort(vp.RING_OF_LASER)[ring]
    # from each laser's own origin (its vertical offset), as the manual and decoder do
    rel = decoded - np.stack(
        [np.zeros(len(laser)), np.zeros(len(laser)), np.take(vp.VERTICAL_OFFSETS_M, laser)], 1
    )
    distance = np.linalg.norm(rel, axis=1)
    expected = ranges[ring, column]
    assert np.abs(distance - expected).max() <= 0.001 + 1e-4  # half the 2 mm unit (+ float32)
    elevation = np.degrees(np.arcsin(rel[:, 2] / distance))
    assert np.abs(elevation - np.take(vp.ELEVATIONS_DEG, laser)).max() < 0.01
    # each laser fires a little after its block's azimuth; within 0.07 deg of the sim's beam
    azimuth = np.degrees(np.arctan2(rel[:, 1], rel[:, 0]))
    assert angle_diff_deg(azimuth, sim_angle_deg(column)).max() <= 0.07 + 1e-4


def test_decoded_points_are_the_reported_points_within_the_azimuth_rounding() -> None:
    ranges = random_ranges(seed=1)
    decoded = decode(vp.encode_revolution(ranges), 0.4, 100.0)
    expected = vp.reported_points(ranges, 0.4, 100.0)
    assert decoded.shape == expected.shape
    r = np.linalg.norm(expected, axis=1)
    # a decoder rounds each beam's azimuth to 0.01 deg (0.005 off at most)
    assert np.all(np.linalg.norm(decoded - expected, axis=1) <= r * math.radians(0.0066) + 1e-4)


def test_the_decoded_frame_is_x_forward_y_left_z_up() -> None:
    ranges = np.full((vp.LASERS, N_AZ), np.inf)
    ranges[7, N_AZ // 2] = 4.0  # ring 7 (-1 deg), straight ahead
    ranges[15, 3 * N_AZ // 4] = 6.0  # ring 15 (+15 deg), 90 deg to the left
    pts = decode(vp.encode_revolution(ranges))
    ahead, left = sorted(pts, key=lambda p: p[1])
    assert ahead[0] > 3.99 and abs(ahead[1]) < 0.01 and ahead[2] < 0
    assert left[1] > 5.7 and abs(left[0]) < 0.01 and left[2] > 1.5


def test_points_to_ranges_inverts_the_sims_beams() -> None:
    ranges = random_ranges(seed=2, no_return=0.3)
    el = np.radians(np.linspace(-15, 15, 16))[:, None]
    az = np.radians(sim_angle_deg(np.arange(N_AZ)))[None, :]
    dirs = np.stack(
        np.broadcast_arrays(np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)), -1
    )
    hit = np.isfinite(ranges)
    points = (dirs[hit] * ranges[hit][:, None]).astype(np.float32)
    back = vp.points_to_ranges(points)
    assert np.array_equal(np.isfinite(back), hit)
    assert np.abs(back[hit] - ranges[hit]).max() < 1e-4  # float32 points
    # two points on one beam: the nearer is the return; one far off every ring: none
    up = math.radians(1.0)  # ring 8
    beam = np.array([math.cos(up), 0.0, math.sin(up)])
    two = vp.points_to_ranges(np.array([3.0 * beam, 2.0 * beam, [1.0, 0.0, 1.0]]))
    assert np.isfinite(two).sum() == 1 and two[8, N_AZ // 2] == pytest.approx(2.0)


def test_bad_grids_are_refused_with_the_reason() -> None:
    with pytest.raises(ValueError, match="multiple of 24"):
        vp.encode_revolution(np.ones((16, 1000)))
    with pytest.raises(ValueError, match=r"\(16, n_az\)"):
        vp.encode_revolution(np.ones((32, 1800)))
    with pytest.raises(ValueError, match="speed"):
        vp.PacketSender("127.0.0.1", 9, speed=0)


def test_no_return_and_out_of_field_ranges_encode_as_zero() -> None:
    units = vp.distance_units(np.array([np.inf, np.nan, -1.0, 0.0, 200.0, 0.001, 1.0]))
    assert units.tolist() == [0, 0, 0, 0, 0, 0, 500]


@pytest.fixture
def udp_socket() -> Iterator[socket.socket]:
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4 << 20)
    sock.bind(("127.0.0.1", 0))
    sock.settimeout(RECEIVE_TIMEOUT_S)
    yield sock
    sock.close()


def test_the_sender_delivers_every_packet_in_order_at_the_sensors_pace(udp_socket) -> None:
    packets = vp.encode_revolution(random_ranges(seed=3))
    port = udp_socket.getsockname()[1]
    with vp.PacketSender("127.0.0.1", port) as sender:
        t0 = time.monotonic()
        assert sender.send(packets) == len(packets)
        elapsed = time.monotonic() - t0
    received = [udp_socket.recv(2048) for _ in packets]
    assert received == packets
    # paced: the last packet leaves 74 packet times after the first (never earlier)
    assert elapsed >= (len(packets) - 1) * vp.PACKET_S - 1e-3


def test_the_sender_stops_when_asked(udp_socket) -> None:
    stop = threading.Event()
    stop.set()
    with vp.PacketSender("127.0.0.1", udp_socket.getsockname()[1], speed=math.inf) as sender:
        assert sender.send(vp.encode_revolution(random_ranges()), stop) == 0
