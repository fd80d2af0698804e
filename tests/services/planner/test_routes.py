"""Routes on the bundled two-room site: door checkpoints, blocked doors, stitched legs."""

from __future__ import annotations

import math

import numpy as np
import pytest

from services.planner import errors
from services.planner.grid_planner import Planner
from services.planner.node import to_reply
from services.planner.routes import RoutePlanner, crossings
from shared.codec import decode, encode
from shared.config import PlannerConfig, RobotConfig
from shared.messages import RouteReply
from shared.site import Door, load_site
from tests.conftest import ROOT

SITE = load_site(ROOT / "sites" / "two_rooms")


@pytest.fixture
def routes() -> RoutePlanner:
    return RoutePlanner(Planner(SITE, RobotConfig(), PlannerConfig()), SITE, PlannerConfig())


def test_route_through_a_declared_door_has_its_checkpoint(routes: RoutePlanner) -> None:
    route = routes.request((2.0, 2.7), "1", None, "", "room_b")
    assert [c.id for c in route.checkpoints] == ["door_ab"]
    door = route.checkpoints[0]
    assert door.kind == "door" and door.door_type == "manual"
    assert door.width_m == pytest.approx(1.0)
    # approach 1.0 m before the door, facing it (+x); exit 1.2 m beyond
    assert door.approach == pytest.approx((5.2, 2.7, 0.0))
    assert door.exit == pytest.approx((7.4, 2.7, 0.0))
    assert door.pass_distance_m == pytest.approx(2.2)
    first, second = route.legs
    assert np.allclose(first.waypoints[-1], door.approach[:2]) and first.v_ref[-1] == 0.0
    assert np.allclose(second.waypoints[0], door.exit[:2])
    assert np.allclose(second.waypoints[-1], (10.5, 2.7))
    for leg in route.legs:  # no leg crosses the door on its own
        assert crossings(leg.waypoints, SITE.doors) == []
        assert len(leg.waypoints) <= PlannerConfig().max_waypoints + 5


def test_the_other_way_faces_the_other_way(routes: RoutePlanner) -> None:
    route = routes.request((10.5, 2.7), "1", (2.0, 2.7), "1")
    door = route.checkpoints[0]
    assert door.approach == pytest.approx((7.2, 2.7, math.pi))
    assert door.exit == pytest.approx((5.0, 2.7, math.pi))


def test_blocked_door_means_no_route_until_freed(routes: RoutePlanner) -> None:
    routes.set_door_blocked("door_ab", True)
    with pytest.raises(errors.NoPath, match="blocked: door_ab"):
        routes.request((2.0, 2.7), "1", None, "", "room_b")
    routes.set_door_blocked("door_ab", False)
    assert routes.request((2.0, 2.7), "1", None, "", "room_b").checkpoints
    with pytest.raises(errors.BadRequest, match="no door or elevator called 'door_zz'"):
        routes.set_door_blocked("door_zz", True)


def test_a_door_marked_unavailable_is_tried_again_after_the_retry_time() -> None:
    """Issue 12: a door marked blocked stayed blocked for ever, for every later mission.
    A mark is dropped ``planner.unavailable_retry_s`` after it was made (the clock: the
    requests' and updates' stamps, the navigator's); within that time it holds."""
    cfg = PlannerConfig(unavailable_retry_s=300.0)
    routes = RoutePlanner(Planner(SITE, RobotConfig(), cfg), SITE, cfg)
    routes.set_door_blocked("door_ab", True, stamp=10.0)
    with pytest.raises(errors.NoPath, match="blocked: door_ab"):
        routes.request((2.0, 2.7), "1", None, "", "room_b", stamp=309.0)
    assert routes.expire(309.0) == []
    assert routes.request((2.0, 2.7), "1", None, "", "room_b", stamp=310.0).checkpoints
    assert "door_ab" not in routes.blocked_doors


def test_same_room_route_has_no_checkpoint(routes: RoutePlanner) -> None:
    route = routes.request((1.5, 1.5), "1", (4.5, 4.0), "1")
    assert route.checkpoints == [] and len(route.legs) == 1


def test_reply_round_trips_and_joins_legs(routes: RoutePlanner) -> None:
    reply = to_reply(routes.request((2.0, 2.7), "1", None, "", "room_b"), "route-7")
    back = decode(encode(reply), RouteReply)
    assert [leg.path_id for leg in back.legs] == ["route-7.0", "route-7.1"]
    assert back.checkpoints[0].approach.x == pytest.approx(5.2)
    assert np.allclose(back.path.waypoints[0], (2.0, 2.7))
    assert np.allclose(back.path.waypoints[-1], (10.5, 2.7)) and back.path.v_ref[-1] == 0


def test_crossings_finds_order_and_side() -> None:
    doors = [Door("a", "1", (1.0, -1.0), (1.0, 1.0)), Door("b", "1", (3.0, -1.0), (3.0, 1.0))]
    path = np.array([[0.0, 0.0], [2.0, 0.0], [4.0, 0.0]])
    found = crossings(path, doors)
    assert [(d.id, side) for _s, d, side in found] == [("a", -1), ("b", -1)]
    assert [round(s, 6) for s, _d, _side in found] == [1.0, 3.0]
    assert crossings(path[::-1].copy(), doors)[0][1].id == "b"


def test_unannotated_map_gets_the_same_door_checkpoint() -> None:
    """detectDoorsAlongPath: a plain ROS map (no site.yaml) gives the declared checkpoint."""
    plain = load_site(ROOT / "sites" / "two_rooms" / "floor1.yaml")
    assert plain.doors == []
    routes = RoutePlanner(Planner(plain, RobotConfig(), PlannerConfig()), plain, PlannerConfig())
    route = routes.request((2.0, 2.7), "", (10.5, 2.7), "")
    declared = RoutePlanner(
        Planner(SITE, RobotConfig(), PlannerConfig()), SITE, PlannerConfig()
    ).request((2.0, 2.7), "1", (10.5, 2.7), "1")
    assert len(route.checkpoints) == 1
    found, want = route.checkpoints[0], declared.checkpoints[0]
    assert found.width_m == pytest.approx(want.width_m, abs=0.1)
    assert found.approach == pytest.approx(want.approach, abs=0.1)
    assert found.exit == pytest.approx(want.exit, abs=0.1)


def test_multi_floor_route_goes_door_corridor_lift_corridor_door() -> None:
    site = load_site(ROOT / "sites" / "two_floors")
    routes = RoutePlanner(Planner(site, RobotConfig(), PlannerConfig()), site, PlannerConfig())
    route = routes.request((5.0, 4.0), "1", None, "", "room_2b")
    kinds = [(c.kind, c.floor) for c in route.checkpoints]
    assert kinds == [("door", "1"), ("elevator", "1"), ("door", "2")]
    lift = route.checkpoints[1]
    assert lift.to_floor == "2" and lift.id in ("lift_a", "lift_b")
    assert [leg.floor for leg in route.legs] == ["1", "1", "2", "2"]
    routes.set_door_blocked(lift.id, True)  # that lift unavailable: the other one
    other = routes.request((5.0, 4.0), "1", None, "", "room_2b").checkpoints[1]
    assert other.kind == "elevator" and other.id != lift.id


def test_zone_tags_per_waypoint() -> None:
    site = load_site(ROOT / "sites" / "two_floors")
    routes = RoutePlanner(Planner(site, RobotConfig(), PlannerConfig()), site, PlannerConfig())
    route = routes.request((5.0, 4.0), "1", None, "", "room_2b")
    first, corridor = route.legs[0], route.legs[1]
    assert len(first.zones) == len(first.waypoints)
    assert first.zones[0] == "room" and first.zones[-1] == "door"
    assert "corridor" in corridor.zones
    assert route.legs[-1].zones[-1] == "goal"


def test_points_that_wall_off_the_only_way_are_dropped_not_a_dead_end(
    routes: RoutePlanner,
) -> None:
    """Seen in a generated building: held before a closed door in a vestibule, the chair
    marked the door's leaf as blocking and the re-plan found no way at all. Points are a
    hint: a way round them if there is one, else the way as if they were not there."""
    door = next(d for d in SITE.doors if d.id == "door_ab")
    (x1, y1), (x2, y2) = door.p1, door.p2
    wall = [(x1 + (x2 - x1) * t, y1 + (y2 - y1) * t, "1") for t in np.linspace(0, 1, 21)]
    route = routes.request((2.0, 2.7), "1", None, "", "room_b", blocked=wall)
    assert [c.id for c in route.checkpoints] == ["door_ab"]
    aside = [(3.5, 2.7, "1")]  # one point on the straight way: the route goes round it
    around = routes.request((2.0, 2.7), "1", None, "", "room_b", blocked=aside)
    first = around.legs[0].waypoints
    assert np.min(np.hypot(first[:, 0] - 3.5, first[:, 1] - 2.7)) > 0.3


def gap_site(tmp_path, closed_below: bool):
    """A 10 x 6 m room with a table 0.6 x 1.2 m that leaves a 0.95 m gap to the top wall;
    below it the room is open, or (``closed_below``) a block 2 m deep fills the room's
    width below the gap (a passage, no doorway)."""
    from tests.services.planner.test_door_poses import make_site

    t = 0.2
    walls = [(0, 0, 10, t), (0, 6 - t, 10, 6), (0, 0, t, 6), (10 - t, 0, 10, 6)]
    walls.append((5.5, 3.65, 6.1, 4.85))  # the table: 0.95 m below the wall's face (5.8)
    if closed_below:
        walls.append((5.5, 0, 7.5, 4.85))
    return make_site(tmp_path, walls, [], [], (10, 6))


def test_a_gap_the_chair_could_not_enter_is_avoided_where_there_is_another_way(
    tmp_path,
) -> None:
    """Campaign b3003.m08: the path ran through a 0.95 m gap between a table and a wall,
    entered from the diagonal; the controller could not swing the chair in, and each
    re-plan after a recovery took the same gap (the scan points it marked, the table and
    the wall, are on the map already). The stretch of the leg the chair was held on,
    marked untraversed, sends the re-plan the other way round the table."""
    site = gap_site(tmp_path, closed_below=False)
    routes = RoutePlanner(Planner(site, RobotConfig(), PlannerConfig()), site, PlannerConfig())
    start, goal = (8.0, 4.4), (2.0, 5.2)

    def near_gap(route) -> float:
        pts = route.legs[0].waypoints
        return float(np.min(np.hypot(pts[:, 0] - 5.8, pts[:, 1] - 5.33)))

    assert near_gap(routes.request(start, "1", goal, "1")) < 0.2  # the premise: the gap
    stretch = [(x, 5.3, "1") for x in np.arange(5.2, 6.8, 0.1)]
    around = routes.request(start, "1", goal, "1", untraversed=stretch)
    assert near_gap(around) > 0.8
    assert np.min(around.legs[0].waypoints[:, 1]) < 3.65  # below the table


def test_untraversed_marks_that_shut_every_way_are_dropped_before_the_blocking_ones(
    tmp_path,
) -> None:
    """The stretch is a hint given up first: where the gap is the only way, the re-plan
    takes it, still round what the scans marked as blocking."""
    site = gap_site(tmp_path, closed_below=True)
    routes = RoutePlanner(Planner(site, RobotConfig(), PlannerConfig()), site, PlannerConfig())
    start, goal = (8.0, 4.4), (2.0, 5.2)
    stretch = [(x, 5.3, "1") for x in np.arange(5.2, 6.8, 0.1)]
    person = [(3.6, 5.0, "1")]  # on the straight way beyond the gap
    route = routes.request(start, "1", goal, "1", blocked=person, untraversed=stretch)
    pts = route.legs[0].waypoints
    assert np.min(np.hypot(pts[:, 0] - 5.8, pts[:, 1] - 5.33)) < 0.2  # through the gap
    assert np.min(np.hypot(pts[:, 0] - 3.6, pts[:, 1] - 5.0)) > 0.35  # round the person
