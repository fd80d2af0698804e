"""The bundled two_ways site: a direct door between two rooms, and a way round by the corridor."""

from __future__ import annotations

import math

import numpy as np
import pytest

from services.planner.grid_planner import Planner
from services.planner.routes import RoutePlanner, crossings
from shared.config import PlannerConfig, RobotConfig
from shared.site import load_site
from tests.conftest import ROOT

SITE = load_site(ROOT / "sites" / "two_ways")


@pytest.fixture
def routes() -> RoutePlanner:
    return RoutePlanner(Planner(SITE, RobotConfig(), PlannerConfig()), SITE, PlannerConfig())


def start() -> tuple[float, float]:
    place = SITE.place("room_a")
    return place.x, place.y


def test_direct_route_passes_door_ab_only(routes: RoutePlanner) -> None:
    route = routes.request(start(), "1", None, "", "room_b")
    assert [c.id for c in route.checkpoints] == ["door_ab"]
    door = route.checkpoints[0]
    assert door.kind == "door" and door.door_type == "manual"
    assert door.centre == pytest.approx((8.0, 3.0))
    assert door.approach[2] == pytest.approx(0.0)  # eastwards, room_a -> room_b
    assert np.allclose(route.legs[-1].waypoints[-1], (14.0, 3.0))
    for leg in route.legs:
        assert crossings(leg.waypoints, SITE.doors) == []
        assert all(y < 6.0 for _x, y in leg.waypoints)  # never into the corridor


def test_avoiding_door_ab_goes_round_by_the_corridor(routes: RoutePlanner) -> None:
    route = routes.request(start(), "1", None, "", "room_b", avoid=["door_ab"])
    assert [c.id for c in route.checkpoints] == ["door_a_hall", "door_b_hall"]
    out, back = route.checkpoints
    assert out.centre == pytest.approx((4.0, 6.0))
    assert out.approach[2] == pytest.approx(math.pi / 2)  # north, out of room_a
    assert back.centre == pytest.approx((12.0, 6.0))
    assert back.approach[2] == pytest.approx(-math.pi / 2)  # south, into room_b
    first, corridor, last = route.legs
    assert all(x < 8.0 and y < 6.0 for x, y in first.waypoints)  # in room_a
    assert all(y > 6.0 for _x, y in corridor.waypoints)  # along the corridor
    assert "corridor" in corridor.zones
    assert all(x > 8.0 and y < 6.0 for x, y in last.waypoints)  # in room_b
    assert np.allclose(last.waypoints[-1], (14.0, 3.0))
    for leg in route.legs:
        assert crossings(leg.waypoints, SITE.doors) == []
    assert "door_ab" not in routes.blocked_doors  # only for that request
    assert route.length_m > routes.request(start(), "1", None, "", "room_b").length_m
