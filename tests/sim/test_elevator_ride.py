"""The chair rides a lift car between floors; its LiDAR then sees the new floor's walls."""

from __future__ import annotations

import numpy as np

from services.building.lifts import LiftSim
from services.localisation.matcher import DistanceField, match_scan
from shared.config import load
from shared.messages import LiftRequest, LiftRequestType
from shared.site import load_site
from sim.simulation import Simulation
from tests.conftest import ROOT

SITE = load_site(ROOT / "sites" / "two_floors")


def test_ride_from_floor_1_to_floor_2() -> None:
    lift = SITE.elevator("lift_a")
    cx, cy, theta = lift.inside_pose()
    # stand the chair so that its footprint centre is the car centre
    offset = (0.76 - 0.35) / 2
    x, y = cx - offset * np.cos(theta), cy - offset * np.sin(theta)
    cfg = load(
        None,
        [
            "sim.start.place=",
            f"sim.start.x={x}",
            f"sim.start.y={y}",
            f"sim.start.theta={theta}",
            "sim.start.floor='1'",
        ],
    )
    sim = Simulation(cfg, SITE)
    car = LiftSim(lift.id, {f: SITE.floor(f).elevation for f in lift.floors}, "1")
    assert (
        car.request(0.0, LiftRequest(0.0, lift.id, "s1", LiftRequestType.AGV_MODE, "2", 2)) is None
    )
    floors_seen = []
    last_scan = None
    t = 0.0
    while t < 40.0:
        car.update(t)
        sim.set_lifts([lift.id], [car.car_elevation], [car.door_opening])
        r = sim.step()
        t = r.stamp
        floors_seen.append(sim.floor)
        if r.scan is not None:
            last_scan = r.scan
    assert floors_seen[0] == "1" and floors_seen[-1] == "2"
    assert abs(sim.z - SITE.floor("2").elevation) < 1e-6
    # the sensor now stands 5.5 m up, where only floor 2's walls are: they are where the
    # scan says
    s = sim.state
    m = match_scan(DistanceField(SITE.floor("2").map), last_scan, (s.x, s.y, s.theta))
    assert m.inlier_ratio > 0.8
    assert sim.collisions == 0
