"""Codec: round trips of every message type, and one typed error for every bad payload."""

from __future__ import annotations

import math

import msgpack
import numpy as np
import pytest

from shared import messages as m
from shared.codec import DecodeError, EncodeError, decode, encode, peek_tag, to_plain


def samples() -> list[m.Msg]:
    pose = m.Pose2D(1.0, -2.5, 0.3, "2")
    return [
        pose,
        m.Twist(1.5, 0.4, -0.2),
        m.Odometry(2.0, pose, 0.5, 0.1),
        m.DriverStatus(2.0, 80, 4, 0, joystick_active=True, serial_ok=True),
        m.PoseEstimate(2.0, pose, np.eye(3) * 0.01, lost=True),
        m.PointCloud(
            3.0, "lidar", np.random.default_rng(0).normal(size=(1000, 3)).astype(np.float32)
        ),
        m.Path(4.0, "route-1", "1", np.array([[0.0, 0.0], [1.0, 2.0]]), np.array([0.5, 0.0])),
        m.Clock(5.0, 250, 0.02, 1),
        m.Ack("controller", 250, 252),
        m.Ack("controller", 250, 252, 0.0031),
        m.LockstepProfile(
            2.0, 0.02, 100, 0.8, 0.1, 0.02, 0.0, [0.3, 0.2], ["controller"], [0.25], [50]
        ),
        m.DoorState(6.0, "door_ab", m.DoorMode.OPEN),
        m.DoorRequest(6.0, "chair1", "door_ab", m.DoorMode.OPEN),
        m.LiftState(
            7.0, "lift1", ["1", "2"], "1", "2", m.LiftDoor.CLOSED, m.LiftMotion.UP, 1, "s1"
        ),
        m.LiftRequest(7.0, "lift1", "s1", m.LiftRequestType.AGV_MODE, "2", m.LiftDoor.OPEN),
        m.RouteRequest(pose, None, "room_b"),
        m.RouteReply(False, None, "NO_PATH", "no way"),
        m.RouteReply(
            True,
            m.Path(0.0, "r", "1", np.zeros((2, 2)), np.zeros(2)),
            legs=[m.Path(0.0, "r.0", "1", np.ones((3, 2)), np.ones(3))],
            checkpoints=[m.Checkpoint("door", "d1", "1", pose, pose, 2.2, "manual", 1.0)],
        ),
        m.Checkpoint("elevator", "lift_a", "1", pose, pose, 1.5, to_floor="2"),
        m.Availability(1.0, "door_ab", False, "stuck closed"),
        m.TreeNode(0, -1, "Route", "Selector", "RUNNING", ""),
        m.TreeSnapshot(1.0, "g1", "Route", [m.TreeNode(0, -1, "Route", "Selector", "RUNNING")]),
        m.BuildingBodies(
            2.0, ["d1", "d2"], np.array([0.0, 0.5]), ["lift_a"], np.array([4.0]), np.array([1.0])
        ),
        m.FollowStatus(8.0, "route-1", "following", 0.4, 3.2, 0.05),
        m.NavGoal(9.0, "g1", pose),
        m.NavResume(9.0, "wheelnav resume", "g1"),
        m.EmergencyStop(1.7e9, True, "wheelnav stop", "person on the ramp"),
        m.EmergencyStopQuery("controller"),
        m.NavStatus(9.5, "g1", "running", "navigate", "follow", "", 0.2),
        m.Event(10.0, "sim", "collision", "at (1, 2)", "error"),
        m.SimStatus(10.0, 1, False, 0.3, 0.1, 0.2, [m.DoorClearance("door_ab", 0.9, 0.12)]),
        m.DoorClearance("door_ab", 0.9, 0.12),
        m.KeyCounters("wheelnav/chair1/odom", 120, 3),
        m.Diagnostics(
            1.7e9,
            "controller",
            4242,
            1,
            12.5,
            125,
            3,
            [m.KeyCounters("wheelnav/chair1/odom", 120, 3), m.KeyCounters("a/b", 5, 0)],
        ),
    ]


@pytest.mark.parametrize("msg", samples(), ids=lambda msg: msg.TAG)
def test_round_trip(msg: m.Msg) -> None:
    back = decode(encode(msg), type(msg))
    assert to_plain(back) == to_plain(msg)


def test_every_registered_type_is_covered() -> None:
    assert {s.TAG for s in samples()} == set(m.REGISTRY)


def test_point_cloud_travels_as_raw_bytes_not_lists() -> None:
    pts = np.arange(3000, dtype=np.float32).reshape(1000, 3)
    payload = encode(m.PointCloud(0.0, "lidar", pts))
    assert len(payload) < pts.nbytes + 200  # raw float32, not msgpack floats (5 bytes each)
    raw = msgpack.unpackb(payload, raw=False)
    assert isinstance(raw["d"]["points"], msgpack.ExtType)
    back = decode(payload, m.PointCloud)
    assert back.points.dtype == np.float32 and np.array_equal(back.points, pts)


def test_nested_message_in_reply() -> None:
    path = m.Path(1.0, "p", "1", np.zeros((3, 2)), np.zeros(3))
    back = decode(encode(m.RouteReply(True, path)), m.RouteReply)
    assert back.path.waypoints.shape == (3, 2)


def good() -> bytes:
    return encode(m.Twist(1.0, 0.5, 0.1))


BAD = {
    "not msgpack": b"\xc1\xc1\xc1",
    "truncated": good()[:-3],
    "empty": b"",
    "a list": msgpack.packb([1, 2, 3]),
    "unknown tag": msgpack.packb({"t": "teleport", "v": 1, "d": {}}),
    "newer schema": msgpack.packb({"t": "twist", "v": 99, "d": {"stamp": 0.0, "v": 0.0, "w": 0.0}}),
    "unknown field": msgpack.packb(
        {"t": "twist", "v": 1, "d": {"stamp": 0.0, "v": 0.0, "w": 0.0, "x": 1}}
    ),
    "missing field": msgpack.packb({"t": "twist", "v": 1, "d": {"stamp": 0.0, "v": 0.0}}),
    "wrong type": msgpack.packb({"t": "twist", "v": 1, "d": {"stamp": 0.0, "v": "fast", "w": 0.0}}),
    "nan": msgpack.packb({"t": "twist", "v": 1, "d": {"stamp": 0.0, "v": math.nan, "w": 0.0}}),
    "bool for number": msgpack.packb(
        {"t": "twist", "v": 1, "d": {"stamp": 0.0, "v": True, "w": 0.0}}
    ),
}


@pytest.mark.parametrize("name", sorted(BAD))
def test_malformed_payloads_raise_one_typed_error(name: str) -> None:
    with pytest.raises(DecodeError) as info:
        decode(BAD[name], m.Twist)
    assert "\n" not in str(info.value)


def test_wrong_expected_type() -> None:
    with pytest.raises(DecodeError, match="expected odometry, got twist"):
        decode(good(), m.Odometry)


def test_array_checks() -> None:
    ok = encode(m.PointCloud(0.0, "lidar", np.zeros((4, 3), np.float32)))
    assert decode(ok).points.shape == (4, 3)
    with pytest.raises(EncodeError, match="points: expected shape"):
        encode(m.PointCloud(0.0, "lidar", np.zeros((4, 2), np.float32)))
    with pytest.raises(EncodeError, match="points: expected dtype float32"):
        encode(m.PointCloud(0.0, "lidar", np.zeros((4, 3), np.float64)))
    cut = bytearray(ok)
    with pytest.raises(DecodeError):
        decode(bytes(cut[:-5]))


def test_nan_in_command_is_refused_at_the_sender() -> None:
    with pytest.raises(EncodeError, match="twist.v: not finite"):
        encode(m.Twist(0.0, math.nan, 0.0))


def test_peek_tag() -> None:
    assert peek_tag(good()) == "twist"


@pytest.mark.parametrize("shape", [[-1, -12], ["a"], [4, 3.0], 12, [1] * 300])
def test_bad_array_headers_raise_decode_errors(shape: object) -> None:
    """An array's shape is checked before its bytes are read (a hostile header of
    negative or non-integer dimensions, or one longer than the bytes read for it first)."""
    header = msgpack.packb(["<f4", shape])
    body = np.zeros(12, np.float32).tobytes()
    wire = {"stamp": 0.0, "frame": "lidar", "points": msgpack.ExtType(1, header + body)}
    with pytest.raises(DecodeError, match="array"):
        decode(msgpack.packb({"t": m.PointCloud.TAG, "v": 1, "d": wire}), m.PointCloud)


def test_decoded_arrays_are_writable_copies() -> None:
    pts = np.arange(12, dtype=np.float32).reshape(4, 3)
    back = decode(encode(m.PointCloud(0.0, "lidar", pts)), m.PointCloud).points
    back[0, 0] = 99.0  # consumers may work in place
    assert np.array_equal(back[1:], pts[1:]) and pts[0, 0] == 0.0
