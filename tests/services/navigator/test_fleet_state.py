"""The navigator's view of the fleet without Zenoh: latest messages, LiDAR checks, requests."""

from __future__ import annotations

import math

import numpy as np
import pytest

from services.navigator.fleet_state import UNUSABLE_WHY, FleetState
from shared.config import DoorCheckConfig, FleetConfig
from shared.messages import (
    Clock,
    DoorMode,
    DoorState,
    LiftDoor,
    LiftMode,
    LiftRequestType,
    LiftState,
    PointCloud,
    Pose2D,
    PoseEstimate,
)
from tests.shared.test_door_scan import _cast


def state(**kwargs) -> FleetState:
    cfg = FleetConfig()
    return FleetState(
        cfg.robot.name,
        cfg.navigator.door_check,
        cfg.robot.lidar_height_m,
        cfg.robot.clearance_half_width_m,
        **kwargs,
    )


def test_the_clearance_half_width_is_the_one_the_navigator_ran_with() -> None:
    assert state().half_width_m == 0.375
    assert state().door_check == DoorCheckConfig()


def test_nothing_is_known_before_the_first_messages() -> None:
    s = state()
    assert s.now() == 0.0 and s.pose() is None and s.door_mode("d1") is None
    assert s.lidar_door_state(1.0, 0.0, 1.0) == (-1.0, "unknown")
    assert s.lane_blocked((1.0, 0.0), 0.0, 0.76, 1.0) == (-1.0, False)
    assert s.route_request(None, "room_b") is None and s.initial_pose("2") is None


def test_latest_messages_and_the_door_check_on_the_latest_scan() -> None:
    s = state()
    s.on_clock(Clock(stamp=3.0, tick=150, dt=0.02))
    s.on_pose(PoseEstimate(3.0, Pose2D(0.0, 0.0, 0.0, "1"), np.eye(3)))
    s.on_door_state(DoorState(3.0, "d1", DoorMode.OPEN))
    wall = np.array([[1.0, y, 0.0] for y in np.linspace(-0.3, 0.3, 40)], np.float32)
    s.on_scan(PointCloud(2.9, "lidar", wall))
    assert s.now() == 3.0 and s.door_mode("d1") == DoorMode.OPEN
    assert s.lidar_door_state(1.0, 0.0, 1.0) == (2.9, "closed")
    assert s.lane_blocked((1.0, 0.0), 0.0, 0.5, 1.0) == (2.9, True)


def test_a_mission_gets_its_session_and_avoid_set() -> None:
    s = state()
    s.on_pose(PoseEstimate(0.0, Pose2D(1.0, 2.0, 0.5, "1"), np.eye(3)))
    s.new_mission("g1")
    s.avoid("door_ab")
    req = s.route_request(None, "room_b")
    assert req.avoid == ["door_ab"] and req.start == Pose2D(1.0, 2.0, 0.5, "1")
    lift = s.lift_request("lift_a", "2")
    assert (lift.session_id, lift.request_type, lift.destination_floor) == (
        "chair1-g1",
        LiftRequestType.AGV_MODE,
        "2",
    )
    assert s.lift_release("lift_a").request_type == LiftRequestType.END_SESSION
    s.new_mission("g2")
    assert s.route_request(None, "room_b").avoid == [] and s.session_id() == "chair1-g2"
    assert s.initial_pose("2").pose == Pose2D(1.0, 2.0, 0.5, "2")
    assert s.event_message("fallback", "x").severity == "warning"
    assert s.event_message("safety_clear", "x").severity == "info"
    assert s.door_request("d1", DoorMode.OPEN).requester_id == "chair1"
    assert len(s.stop_path().waypoints) == 0


def test_marked_blocking_points_go_into_the_next_route_request() -> None:
    from shared.codec import encode
    from shared.messages import PointCloud, Pose2D, PoseEstimate

    fleet = state()
    fleet.on_pose(PoseEstimate(1.0, Pose2D(2.0, 1.0, 0.0, "1"), np.eye(3)))
    wall = np.array([[1.2, y, 0.0] for y in np.linspace(-0.3, 0.3, 7)], np.float32)
    fleet.on_scan(PointCloud(1.0, "lidar", wall))
    assert fleet.mark_blocking() == 7
    req = fleet.route_request(None, "room_b")
    assert len(req.blocked) == 7 and abs(req.blocked[0].x - 3.2) < 1e-6
    encode(req)  # float32 scan values would not go on the wire
    assert not fleet.room_to_turn(1.3) and fleet.room_to_turn(1.1)
    stretch = np.array([[2.5, 1.0], [2.6, 1.0], [2.7, 1.0]])
    assert fleet.mark_untraversed("1", stretch) == 3
    req = fleet.route_request(None, "room_b")
    assert [(u.x, u.y, u.floor) for u in req.untraversed] == [
        (2.5, 1.0, "1"),
        (2.6, 1.0, "1"),
        (2.7, 1.0, "1"),
    ]
    assert len(req.blocked) == 7
    encode(req)
    fleet.forget_blocking()
    req = fleet.route_request(None, "room_b")
    assert req.blocked == [] and req.untraversed == []


def test_points_in_the_way_of_a_docking_pose_are_marked() -> None:
    # a Phase 0 that failed marks what stands in the footprint (grown by the position
    # tolerance) at the pose it docked at, not what stands ahead of the chair
    from shared.messages import PointCloud, Pose2D, PoseEstimate

    fleet = state()
    fleet.on_pose(PoseEstimate(1.0, Pose2D(2.0, 1.0, math.pi / 2, "1"), np.eye(3)))
    # sensor frame (x ahead = +y on the map): a cupboard's edge 0.5 m to the chair's left
    # (map x 1.5), from 0.2 m behind to 1.0 m ahead; a far wall 3 m ahead
    edge = [[a, 0.5, 0.0] for a in np.linspace(-0.2, 1.0, 13)]
    wall = [[3.0, b, 0.0] for b in np.linspace(-0.3, 0.3, 7)]
    fleet.on_scan(PointCloud(1.0, "lidar", np.array(edge + wall, np.float32)))
    # standing at (2.0, 1.5): the edge is 0.125 m beside its clearance width (0.375 m)
    assert fleet.mark_in_footprint((2.0, 1.5, math.pi / 2), 0.0) == 0
    assert fleet.mark_in_footprint((2.0, 1.5, math.pi / 2), 0.15) == 11  # from its rear on
    req = fleet.route_request(None, "room_b")
    assert {round(b.x, 3) for b in req.blocked} == {1.5}
    assert min(b.y for b in req.blocked) == pytest.approx(1.0)


def test_points_on_the_way_ahead_are_marked_whichever_way_the_chair_faces() -> None:
    # the leg runs west from a chair facing east: the cupboard on it is behind the chair
    from shared.messages import PointCloud, Pose2D, PoseEstimate

    fleet = state()
    fleet.on_pose(PoseEstimate(1.0, Pose2D(5.0, 1.0, 0.0, "1"), np.eye(3)))
    cupboard = [[-1.0, b, 0.0] for b in np.linspace(-0.3, 0.3, 7)]  # map x 4.0
    aside = [[-1.0, 1.5, 0.0]]  # map (4.0, 2.5): 1.5 m off the leg
    fleet.on_scan(PointCloud(1.0, "lidar", np.array(cupboard + aside, np.float32)))
    way = np.column_stack([np.arange(5.0, 1.0, -0.1), np.full(40, 1.0)])
    assert fleet.mark_near(way) == 7
    req = fleet.route_request(None, "room_b")
    assert {round(b.x, 3) for b in req.blocked} == {4.0}
    assert fleet.mark_near(way[:5]) == 0  # the first 0.4 m of the way: nothing on it


def test_a_powered_door_is_closed_only_once_its_leaf_cannot_reach_the_chair() -> None:
    """Campaign b8.m07 (generated building 8): the navigator asked powered hinged door
    d3_021 (1.05 m) to close as soon as the pass ended, 0.7 m past the door plane, and the
    leaf swung shut through the chair (a collision, 0.46 m of overlap)."""
    s = state()
    s.on_clock(Clock(stamp=10.0, tick=500, dt=0.02))
    s.on_pose(PoseEstimate(10.0, Pose2D(28.42, 14.92, 0.28, "3"), np.eye(3)))
    s.close_door_when_clear("d3_021", "3", (27.7, 14.925, 0.0), 1.05)
    assert s.doors_clear_to_close() == []
    s.on_pose(PoseEstimate(11.0, Pose2D(29.5, 14.9, 0.0, "3"), np.eye(3)))
    assert s.doors_clear_to_close() == []  # the leaf's tip still reaches the chair's front
    held = s.hold_door_open_request("d3_021")  # renewed meanwhile: the close still waits
    assert (held.door_name, held.requested_mode) == ("d3_021", DoorMode.OPEN)
    s.on_pose(PoseEstimate(12.0, Pose2D(30.6, 14.9, 0.0, "3"), np.eye(3)))
    (req,) = s.doors_clear_to_close()
    assert (req.door_name, req.requested_mode) == ("d3_021", DoorMode.CLOSED)
    assert s.doors_clear_to_close() == []  # asked once


def test_a_door_left_behind_on_another_floor_is_closed_and_a_reopened_one_is_not() -> None:
    s = state()
    s.on_pose(PoseEstimate(0.0, Pose2D(1.0, 0.0, 0.0, "1"), np.eye(3)))
    s.close_door_when_clear("d1", "1", (0.0, 0.0, 0.0), 1.0)
    s.close_door_when_clear("d2", "1", (0.5, 0.0, 0.0), 1.0)
    s.door_request("d2", DoorMode.OPEN)  # asked open again: the close is dropped
    s.on_pose(PoseEstimate(1.0, Pose2D(1.0, 0.0, 0.0, "2"), np.eye(3)))
    assert [r.door_name for r in s.doors_clear_to_close()] == ["d1"]


def test_the_doorways_in_the_latest_scan_are_given_on_the_map() -> None:
    s = state()
    assert s.doorways_seen() == (-1.0, [])
    # a wall 2 m ahead of the sensor with a 0.9 m gap to its left, the chair at (10, 5)
    # facing +y: the gap's centre is at (10 - 0.45, 5 + 2) on the map, its wall along x
    walls = [((2, -3), (2, 0.0)), ((2, 0.9), (2, 3)), ((5, -3), (5, 3))]
    xy = _cast(walls)
    s.on_pose(PoseEstimate(1.0, Pose2D(10.0, 5.0, np.pi / 2), np.eye(3)))
    s.on_scan(PointCloud(1.0, "lidar", np.c_[xy, np.zeros(len(xy))].astype(np.float32)))
    stamp, ((x, y, direction, width),) = s.doorways_seen()
    assert stamp == 1.0 and abs(width - 0.9) < 0.02
    assert abs(x - 9.55) < 0.02 and abs(y - 7.0) < 0.02
    assert abs(np.sin(direction)) < 0.02  # the wall runs along the map's x axis


def test_a_building_state_older_than_its_limit_counts_as_none() -> None:
    # a silent building (its link cut) leaves no OPEN behind: the door step waits and
    # times out as when nobody answers (issue 16 item 6)
    s = state(state_max_age_s=5.0)
    s.on_door_state(DoorState(10.0, "d1", DoorMode.OPEN))
    s.on_lift_state(LiftState(10.0, "lift_a", ["1"], "1", "1", LiftDoor.OPEN, 0, 2, ""))
    s.on_clock(Clock(stamp=15.0, tick=750, dt=0.02))
    assert s.door_mode("d1") == DoorMode.OPEN and s.lift_state("lift_a") is not None
    s.on_clock(Clock(stamp=15.1, tick=755, dt=0.02))
    assert s.door_mode("d1") is None and s.lift_state("lift_a") is None
    s.on_door_state(DoorState(15.1, "d1", DoorMode.OPEN))
    assert s.door_mode("d1") == DoorMode.OPEN


def test_on_wall_time_a_building_state_is_as_old_as_its_arrival() -> None:
    # the building's host stamps from its own clock (here an hour behind): the age is
    # the time since the state arrived, on the navigator's clock
    cfg = FleetConfig()
    wall = [1000.0]
    s = FleetState(
        cfg.robot.name,
        cfg.navigator.door_check,
        cfg.robot.lidar_height_m,
        cfg.robot.clearance_half_width_m,
        restamp=lambda: wall[0],
        state_max_age_s=5.0,
    )
    s.on_door_state(DoorState(1000.0 - 3600.0, "d1", DoorMode.OPEN))
    s.on_clock(Clock(stamp=1004.0, tick=1, dt=0.1))
    assert s.door_mode("d1") == DoorMode.OPEN
    s.on_clock(Clock(stamp=1006.0, tick=2, dt=0.1))
    assert s.door_mode("d1") is None


def test_a_route_is_not_planned_through_a_lift_out_of_service() -> None:
    # campaign b2011.m06: both lifts out of service, and the chair drove 100 s towards
    # one of them, to fail there; the planner now hears it and answers "no route"
    s = state(state_max_age_s=5.0)
    s.on_pose(PoseEstimate(10.0, Pose2D(1.0, 2.0, 0.5, "1"), np.eye(3)))
    s.on_clock(Clock(stamp=10.0, tick=500, dt=0.02))
    s.new_mission("g1")
    s.avoid("door_ab")
    for name, mode in (("lift_a", LiftMode.OFFLINE), ("lift_b", LiftMode.AGV)):
        s.on_lift_state(LiftState(10.0, name, ["1", "2"], "1", "1", LiftDoor.OPEN, 0, mode, ""))
    s.on_lift_state(LiftState(10.0, "lift_c", ["1"], "1", "1", 0, 0, LiftMode.FIRE, ""))
    assert s.unusable_lifts() == ["lift_a", "lift_c"]
    assert s.route_request(None, "room_b").avoid == ["door_ab", "lift_a", "lift_c"]
    assert s.lifts_to_report() == [("lift_a", "out of service"), ("lift_c", "in fire mode")]
    assert s.lifts_to_report() == []  # once per mission
    assert set(UNUSABLE_WHY) == set(LiftMode.UNUSABLE)  # every such mode says why
    s.avoid("lift_a")  # failed at it already: named once
    assert s.route_request(None, "room_b").avoid == ["door_ab", "lift_a", "lift_c"]
    s.on_clock(Clock(stamp=15.1, tick=755, dt=0.02))  # a state too old is no state
    assert s.route_request(None, "room_b").avoid == ["door_ab", "lift_a"]
