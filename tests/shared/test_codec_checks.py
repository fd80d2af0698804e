"""Codec: the checks across fields, the ranges of numbers and the schema version.

Each case is a payload a receiver must refuse with one line naming the field (and a
message the sender must not be able to send): without its check, each decodes.
"""

from __future__ import annotations

import msgpack
import numpy as np
import pytest

from shared import messages as m
from shared.codec import DecodeError, EncodeError, decode, encode

POSE = m.Pose2D(1.0, 2.0, 0.5, "1")


def wire(msg: m.Msg) -> dict:
    """The msgpack map of a valid message (arrays kept as extension types)."""
    return msgpack.unpackb(encode(msg), raw=False)


def packed(obj: dict) -> bytes:
    return msgpack.packb(obj)


def path(n_points: int = 3, n_speeds: int = 3, **kw) -> m.Path:
    pts = np.column_stack([np.arange(n_points, dtype=float), np.zeros(n_points)])
    return m.Path(1.0, "p", "1", pts, np.full(n_speeds, 0.5), **kw)


def broken(msg_ok: m.Msg, **fields) -> bytes:
    """A valid message's payload with ``fields`` replaced in its data map, raw."""
    obj = wire(msg_ok)
    obj["d"].update(fields)
    return packed(obj)


def with_arrays(msg_ok: m.Msg, **arrays: np.ndarray) -> bytes:
    """A valid message's payload with array fields swapped (bypassing the encoder's checks)."""
    obj = wire(msg_ok)
    for name, arr in arrays.items():
        header = msgpack.packb([arr.dtype.str, list(arr.shape)])
        obj["d"][name] = msgpack.ExtType(1, header + np.ascontiguousarray(arr).tobytes())
    return packed(obj)


# (payload, expected type, the message's start)
CASES = {
    "path: 1 speed for 3 waypoints": (
        with_arrays(path(), v_ref=np.array([0.5])),
        m.Path,
        "path.v_ref: 1 value(s) for 3 waypoint(s)",
    ),
    "path: zones for fewer waypoints": (
        broken(path(), zones=["room", "door"]),
        m.Path,
        "path.zones: 2 value(s) for 3 waypoint(s)",
    ),
    "path: docking without a waypoint": (
        broken(path(0, 0), dock_heading=0.3),
        m.Path,
        "path.dock_heading: a docking path needs a waypoint",
    ),
    "path: a door pass with 5 values": (
        broken(path(), door=[6.2, 2.7, 0.0, 1.0, 1.0]),
        m.Path,
        "path.door: 5 value(s): [x, y, heading, width, lead, through(, offset)]",
    ),
    "path: a door pass whose offset leaves the doorway": (
        broken(path(), door=[6.2, 2.7, 0.0, 1.0, 1.0, 1.0, 0.6]),
        m.Path,
        "path.door: offset must be within half the door's width",
    ),
    "path: a door pass ending before the plane": (
        broken(path(), door=[6.2, 2.7, 0.0, 1.0, 1.0, 0.0]),
        m.Path,
        "path.door: width and lead must be >= 0, through > 0 (metres)",
    ),
    "path: a door pass with NaN": (
        broken(path(), door=[6.2, float("nan"), 0.0, 1.0, 1.0, 1.2]),
        m.Path,
        "path.door[1]: not finite",
    ),
    "nested leg with mismatched speeds": (
        packed(
            {
                "t": "route_reply",
                "v": 3,
                "d": {
                    "ok": True,
                    "legs": [
                        wire(path())["d"],
                        {**wire(path())["d"], "v_ref": wire(path(2, 2))["d"]["v_ref"]},
                    ],
                },
            }
        ),
        m.RouteReply,
        "route_reply.legs[1].v_ref: 2 value(s) for 3 waypoint(s)",
    ),
    "speed of 1e300 m/s": (
        broken(m.Twist(1.0, 0.5, 0.0), v=1e300),
        m.Twist,
        "twist.v: 1e+300 is outside [-100, 100]",
    ),
    "turn rate beyond the limit": (
        broken(m.Twist(1.0, 0.5, 0.0), w=-250.0),
        m.Twist,
        "twist.w: -250.0 is outside [-100, 100]",
    ),
    "coordinate beyond any building": (
        packed(
            {
                "t": "nav_goal",
                "v": 1,
                "d": {"stamp": 0.0, "goal_id": "g", "goal": {"x": 3e7, "y": 0.0, "theta": 0.0}},
            }
        ),
        m.NavGoal,
        "nav_goal.goal.x: 30000000.0 is outside [-1e+06, 1e+06]",
    ),
    "waypoint beyond any building": (
        with_arrays(path(2, 2), waypoints=np.array([[0.0, 0.0], [1e9, 0.0]])),
        m.Path,
        "path.waypoints: value 1000000000.0 is outside [-1e+06, 1e+06]",
    ),
    "reference speed of 1e300": (
        with_arrays(path(2, 2), v_ref=np.array([0.5, 1e300])),
        m.Path,
        "path.v_ref: value 1e+300 is outside [-100, 100]",
    ),
    "scan point of 1e30 m": (
        with_arrays(
            m.PointCloud(1.0, "lidar", np.zeros((2, 3), np.float32)),
            points=np.array([[0, 0, 0], [1e30, 0, 0]], np.float32),
        ),
        m.PointCloud,
        "point_cloud.points: value",
    ),
    "negative stamp": (
        broken(m.Twist(1.0, 0.5, 0.0), stamp=-5.0),
        m.Twist,
        "twist.stamp: -5.0 is outside [0, 1e+10]",
    ),
    "a number without a range of its own: 1e300": (
        broken(m.SimStatus(1.0, 0, False, 0.5, 0.4), clearance_m=1e300),
        m.SimStatus,
        "sim_status.clearance_m: 1e+300 is outside [-1e+12, 1e+12]",
    ),
    "an integer beyond 2**53": (
        broken(m.Clock(1.0, 5, 0.02), tick=2**63),
        m.Clock,
        "clock.tick: 9223372036854775808 is outside",
    ),
    "clock: negative tick": (
        broken(m.Clock(1.0, 5, 0.02), tick=-1),
        m.Clock,
        "clock.tick: -1 is outside",
    ),
    "clock: a tick of no length": (
        broken(m.Clock(1.0, 5, 0.02), dt=0.0),
        m.Clock,
        "clock.dt: 0.0 is outside",
    ),
    "ack: next tick not after the tick": (
        broken(m.Ack("controller", 10, 12), next_tick=10),
        m.Ack,
        "ack.next_tick: 10 is not after tick 10",
    ),
    "door mode out of the enumeration": (
        broken(m.DoorRequest(1.0, "chair1", "d1", m.DoorMode.OPEN), requested_mode=9),
        m.DoorRequest,
        "door_request.requested_mode: 9 is outside [0, 4]",
    ),
    "door state mode out of the enumeration": (
        broken(m.DoorState(1.0, "d1", m.DoorMode.OPEN), current_mode=-1),
        m.DoorState,
        "door_state.current_mode: -1 is outside [0, 4]",
    ),
    "lift request type out of the enumeration": (
        broken(m.LiftRequest(1.0, "l", "s", 1, "2", 0), request_type=7),
        m.LiftRequest,
        "lift_request.request_type: 7 is outside [0, 2]",
    ),
    "lift motion out of the enumeration": (
        broken(m.LiftState(1.0, "l", ["1"], "1", "1", 0, 0, 1, ""), motion_state=4),
        m.LiftState,
        "lift_state.motion_state: 4 is outside [0, 3]",
    ),
    "building bodies: openings for fewer doors": (
        with_arrays(m.BuildingBodies(1.0, ["d1", "d2"], np.zeros(2)), door_openings=np.zeros(1)),
        m.BuildingBodies,
        "building_bodies.door_openings: 1 value(s) for 2 door(s)",
    ),
    "building bodies: car elevations for more lifts": (
        with_arrays(
            m.BuildingBodies(1.0, [], np.zeros(0), ["a"], np.zeros(1), np.zeros(1)),
            car_elevations=np.zeros(3),
        ),
        m.BuildingBodies,
        "building_bodies.car_elevations: 3 value(s) for 1 lift(s)",
    ),
    "building bodies: lift doors for more lifts": (
        with_arrays(
            m.BuildingBodies(1.0, [], np.zeros(0), ["a"], np.zeros(1), np.zeros(1)),
            lift_door_openings=np.zeros(2),
        ),
        m.BuildingBodies,
        "building_bodies.lift_door_openings: 2 value(s) for 1 lift(s)",
    ),
    "profile: compute times for other participants": (
        broken(
            m.LockstepProfile(1.0, 0.02, 1, 1.0, 0.1, 0.1, 0.0, [0.1], ["a"], [0.1], [1]),
            compute_s=[0.1, 0.2],
        ),
        m.LockstepProfile,
        "lockstep_profile.compute_s: 2 value(s) for 1 participant(s)",
    ),
    "profile: steps for other participants": (
        broken(
            m.LockstepProfile(1.0, 0.02, 1, 1.0, 0.1, 0.1, 0.0, [0.1], ["a"], [0.1], [1]),
            steps=[],
        ),
        m.LockstepProfile,
        "lockstep_profile.steps: 0 value(s) for 1 participant(s)",
    ),
    "goal with neither a pose nor a place": (
        broken(m.NavGoal(1.0, "g", None, "room_b"), place=""),
        m.NavGoal,
        "nav_goal.goal: neither a goal pose nor a place",
    ),
    "availability of nothing": (
        broken(m.Availability(1.0, "d1", False), name=""),
        m.Availability,
        "availability.name: empty",
    ),
    "tree: a node id twice": (
        broken(
            m.TreeSnapshot(1.0, "g", "t", [m.TreeNode(0, -1, "a", "S", "RUNNING")]),
            nodes=[wire(m.TreeNode(0, -1, "a", "S", "RUNNING"))["d"]] * 2,
        ),
        m.TreeSnapshot,
        "tree_snapshot.nodes[1].id: 0 appears twice",
    ),
    "tree: a parent that is not there": (
        broken(
            m.TreeSnapshot(1.0, "g", "t", [m.TreeNode(0, -1, "a", "S", "RUNNING")]),
            nodes=[wire(m.TreeNode(0, 7, "a", "S", "RUNNING"))["d"]],
        ),
        m.TreeSnapshot,
        "tree_snapshot.nodes[0].parent: no node 7 in the snapshot",
    ),
    "door clearance: a pose of 2 numbers": (
        broken(
            m.SimStatus(1.0, 0, False, 0.5, 0.4),
            doors=[wire(m.DoorClearance("d", 0.9, 0.1))["d"] | {"at": [1.0, 2.0]}],
        ),
        m.SimStatus,
        "sim_status.doors[0].at: 2 values",
    ),
    "sim status: a pose of 4 numbers": (
        broken(m.SimStatus(1.0, 0, False, 0.5, 0.4), away_at=[1.0, 2.0, 3.0, 4.0]),
        m.SimStatus,
        "sim_status.away_at: 4 values",
    ),
    "negative width": (
        broken(m.DoorClearance("d", 0.9, 0.1), width_m=-0.9),
        m.DoorClearance,
        "door_clearance.width_m: -0.9 is outside",
    ),
    "diagnostics: totals that are not the keys' sums": (
        broken(m.Diagnostics(1.0, "x", 1, 0, 1.0, 3, 1, [m.KeyCounters("k", 3, 1)]), messages_in=4),
        m.Diagnostics,
        "diagnostics.messages_in: 4, but the keys add up to 3",
    ),
    "diagnostics: bad totals that are not the keys' sums": (
        broken(
            m.Diagnostics(1.0, "x", 1, 0, 1.0, 3, 1, [m.KeyCounters("k", 3, 1)]), bad_messages=0
        ),
        m.Diagnostics,
        "diagnostics.bad_messages: 0, but the keys add up to 1",
    ),
    "text of 2 MB": (
        broken(m.Event(1.0, "sim", "x"), detail="x" * 2_000_000),
        m.Event,
        "event.detail: text of 2000000 characters",
    ),
    "schema version 0": (
        packed({**wire(m.Twist(1.0, 0.5, 0.0)), "v": 0}),
        m.Twist,
        "twist schema version 0: expected an integer >= 1",
    ),
    "schema version -3": (
        packed({**wire(m.Twist(1.0, 0.5, 0.0)), "v": -3}),
        m.Twist,
        "twist schema version -3: expected an integer >= 1",
    ),
    "schema version true": (
        packed({**wire(m.Twist(1.0, 0.5, 0.0)), "v": True}),
        m.Twist,
        "twist schema version True: expected an integer >= 1",
    ),
    "schema version as text": (
        packed({**wire(m.Twist(1.0, 0.5, 0.0)), "v": "1"}),
        m.Twist,
        "twist schema version '1': expected an integer >= 1",
    ),
}


@pytest.mark.parametrize("name", sorted(CASES))
def test_invalid_message_is_refused_naming_the_field(name: str) -> None:
    payload, expected, says = CASES[name]
    with pytest.raises(DecodeError) as info:
        decode(payload, expected)
    text = str(info.value)
    assert text.startswith(says), text
    assert "\n" not in text


def test_path_with_3_waypoints_and_1_speed_cannot_be_sent() -> None:
    with pytest.raises(EncodeError, match=r"^path.v_ref: 1 value\(s\) for 3 waypoint\(s\)$"):
        encode(path(3, 1))


def test_huge_speed_cannot_be_sent() -> None:
    with pytest.raises(EncodeError, match=r"^twist.v: 1e\+300 is outside \[-100, 100\]$"):
        encode(m.Twist(0.0, 1e300, 0.0))


def test_nested_check_at_the_sender_names_the_leg() -> None:
    with pytest.raises(EncodeError, match=r"^route_reply.legs\[0\].zones: 1 value"):
        encode(m.RouteReply(True, legs=[path(3, 3, zones=["room"])]))


def test_the_edges_of_each_range_are_allowed() -> None:
    for msg in (
        m.Twist(0.0, 100.0, -100.0),
        m.Twist(1e10, -100.0, 100.0),
        m.Pose2D(1e6, -1e6, 0.0),
        path(0, 0),  # an empty path: stop
        path(1, 1, dock_heading=3.1),
        path(2, 2, zones=["room", "goal"]),
        m.Ack("navigator", 0, 1),
        m.Clock(0.0, 0, 1e-6),
        m.NavGoal(0.0, "cancel", cancel=True),
        m.DoorRequest(0.0, "c", "d", m.DoorMode.UNKNOWN),
        m.LiftState(0.0, "l", [], "", "", m.LiftDoor.OPEN, m.LiftMotion.UNKNOWN, 5, ""),
    ):
        back = decode(encode(msg), type(msg))
        assert type(back) is type(msg)


def test_an_older_schema_version_still_decodes() -> None:
    obj = wire(m.Ack("controller", 1, 2))
    obj["v"] = 1  # Ack is at version 2; version 1 had the same required fields
    assert decode(packed(obj), m.Ack).next_tick == 2
