"""The 3D LiDAR: rings, wall and floor returns, the sensor frame, bodies, and the two casters."""

from __future__ import annotations

import json
import math
from collections.abc import Iterator

import numpy as np
import pybullet as pb
import pytest
from scipy.spatial import cKDTree

from shared.site import GridMap
from sim.lidar3d import LidarConfigError, MultiRingLidar
from sim.sitegen import draw
from sim.world import World

RES = 0.05
HEIGHT = 1.5
NOISE = 0.01


def grid(occ: np.ndarray) -> GridMap:
    return GridMap(np.where(occ, 100, 0).astype(np.int8), RES, (0.0, 0.0, 0.0))


def room() -> np.ndarray:
    """A 10.2 m x 8.2 m room: inner faces at x = 0.2 and 10, y = 0.2 and 8; a pillar."""
    w, h, t = 10.2, 8.2, 0.2
    walls = [(0, 0, w, t), (0, h - t, w, h), (0, 0, t, h), (w - t, 0, w, h), (7, 6, 7.6, 6.6)]
    return draw((w, h), walls, resolution=RES)


@pytest.fixture
def world() -> Iterator[World]:
    w = World(grid(room()))
    yield w
    w.close()


def lidar(world: World, method: str = "auto", noise: float = NOISE, **kw) -> MultiRingLidar:
    return MultiRingLidar.for_world(
        world, height_m=HEIGHT, noise_m=noise, rng=np.random.default_rng(1), method=method, **kw
    )


def elevation_deg(pts: np.ndarray) -> np.ndarray:
    return np.degrees(np.arctan2(pts[:, 2], np.hypot(pts[:, 0], pts[:, 1])))


def ahead(pts: np.ndarray, azimuth_deg: float = 0.0) -> np.ndarray:
    """The returns of the beams at one azimuth (sensor frame)."""
    az = np.degrees(np.arctan2(pts[:, 1], pts[:, 0]))
    return pts[np.abs((az - azimuth_deg + 180) % 360 - 180) < 0.01]


def test_rings_span_plus_minus_15_degrees_in_16_steps(world: World) -> None:
    lid = lidar(world)
    assert np.allclose(np.degrees(lid.elevations), np.linspace(-15, 15, 16))
    assert np.allclose(np.diff(np.degrees(lid.elevations)), 2.0)
    assert np.allclose(np.diff(np.degrees(lid.azimuths)), 0.2)
    assert lid.beams == 16 * 1800
    pts = lid.scan(5.0, 4.0, 0.0)
    rings = np.unique(np.round(elevation_deg(pts)))
    assert set(rings) <= set(np.linspace(-15, 15, 16))


@pytest.mark.parametrize("method", ["grid", "pybullet"])
def test_wall_at_known_distance(world: World, method: str) -> None:
    # the east wall's face is at x = 10; the sensor at x = 5, so 5 m ahead, horizontally
    pts = ahead(lidar(world, method).scan(5.0, 4.0, 0.0))
    el = np.round(elevation_deg(pts)).astype(int)
    horizontal = np.hypot(pts[:, 0], pts[:, 1])
    on_wall = [e for e in range(-15, 16, 2) if 0 <= HEIGHT + 5 * math.tan(math.radians(e)) <= 2.2]
    assert on_wall == list(range(-15, 8, 2))  # the rings from +9 deg up pass over the wall
    assert sorted(set(el)) == on_wall
    assert np.abs(horizontal - 5.0).max() < 5 * NOISE
    assert abs(horizontal.mean() - 5.0) < 2 * NOISE


@pytest.mark.parametrize("method", ["grid", "pybullet"])
def test_floor_seen_by_downward_rings(method: str) -> None:
    w = World(grid(np.zeros((400, 400), dtype=bool)))  # 20 m x 20 m with no walls
    try:
        pts = lidar(w, method).scan(10.0, 10.0, 0.3)
    finally:
        w.close()
    el = elevation_deg(pts)
    assert (el < 0).all()  # upward rings see nothing
    assert len(pts) == 8 * 1800  # every downward beam hits the floor
    for ring in range(-15, 0, 2):
        mine = pts[np.abs(el - ring) < 0.5]
        expected = HEIGHT / math.tan(math.radians(-ring))
        ranges = np.linalg.norm(mine, axis=1)
        assert np.abs(ranges - HEIGHT / math.sin(math.radians(-ring))).max() < 5 * NOISE
        assert np.hypot(mine[:, 0], mine[:, 1]).mean() == pytest.approx(expected, abs=NOISE)
        assert mine[:, 2].mean() == pytest.approx(-HEIGHT, abs=NOISE)


def test_floor_follows_base_z() -> None:
    w = World(grid(np.zeros((200, 200), dtype=bool)), True, 4.0)
    try:
        lid = lidar(w, noise=0.0, elevation=4.0)
        pts = lid.scan(5.0, 5.0, 0.0, base_z=4.0)
    finally:
        w.close()
    assert np.allclose(pts[:, 2], -HEIGHT, atol=1e-5)


def test_points_are_float32_in_the_sensor_frame(world: World) -> None:
    lid = lidar(world)
    east = lid.scan(5.0, 4.0, 0.0)
    assert east.dtype == np.float32 and east.ndim == 2 and east.shape[1] == 3
    north = lid.scan(5.0, 4.0, math.pi / 2)  # now the north wall (y = 8) is ahead
    level = lambda p: p[np.abs(elevation_deg(p)) < 1.5]  # noqa: E731  the -1 and +1 deg rings
    assert np.hypot(*ahead(level(east))[:, :2].T).mean() == pytest.approx(5.0, abs=0.02)
    assert np.hypot(*ahead(level(north))[:, :2].T).mean() == pytest.approx(4.0, abs=0.02)
    right = ahead(level(north), -90.0)  # the east wall is on the chair's right
    assert np.hypot(*right[:, :2].T).mean() == pytest.approx(5.0, abs=0.02)
    assert (right[:, 1] < 0).all()


@pytest.mark.parametrize("method", ["grid", "pybullet"])
def test_a_body_appears_and_disappears(world: World, method: str) -> None:
    lid = lidar(world, method, noise=0.0)
    c = world.client
    shape = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=[0.025, 0.5, 1.0], physicsClientId=c)
    door = pb.createMultiBody(0, shape, basePosition=[7.0, 4.0, 1.01], physicsClientId=c)
    near = ahead(lid.scan(5.0, 4.0, 0.0))
    assert np.hypot(near[:, 0], near[:, 1]).min() == pytest.approx(1.975, abs=2e-3)
    pb.removeBody(door, physicsClientId=c)
    gone = ahead(lid.scan(5.0, 4.0, 0.0))
    assert np.hypot(gone[:, 0], gone[:, 1]).min() == pytest.approx(5.0, abs=2e-3)


def test_ignored_body_is_not_seen_and_stays_put(world: World) -> None:
    c = world.client
    shape = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=[0.5, 0.5, 2.0], physicsClientId=c)
    chair = pb.createMultiBody(0, shape, basePosition=[7.0, 4.0, 2.0], physicsClientId=c)
    pose = pb.getBasePositionAndOrientation(chair, physicsClientId=c)
    for method in ("grid", "pybullet"):
        pts = ahead(lidar(world, method, noise=0.0, ignore_ids=[chair]).scan(5.0, 4.0, 0.0))
        assert np.hypot(pts[:, 0], pts[:, 1]).min() == pytest.approx(5.0, abs=2e-3)
    assert pb.getBasePositionAndOrientation(chair, physicsClientId=c) == pose


def agree(a: np.ndarray, b: np.ndarray) -> None:
    """Two noise-free clouds of the same scene match point for point (within Bullet's 2 mm
    box margin; a beam grazing a wall corner may go either way)."""
    assert abs(len(a) - len(b)) <= max(2, len(a) // 1000)
    for p, q in ((a, b), (b, a)):
        d, _ = cKDTree(q).query(p)
        assert (d < 5e-3).mean() > 0.999


def test_grid_and_pybullet_agree_on_a_site() -> None:
    occ = room()
    lower, upper = grid(occ), grid(np.flipud(occ))  # a different storey above, 4 m up
    w = World(lower, True, 0.0)
    w.add_floor(upper, 4.0)
    try:
        c = w.client
        shape = pb.createCollisionShape(
            pb.GEOM_BOX, halfExtents=[0.6, 0.025, 1.0], physicsClientId=c
        )
        for pos in ([3.0, 2.0, 1.01], [6.0, 5.5, 5.01]):  # a door leaf on each storey
            pb.createMultiBody(0, shape, basePosition=pos, physicsClientId=c)
        person = pb.createCollisionShape(
            pb.GEOM_CYLINDER, radius=0.25, height=1.7, physicsClientId=c
        )
        pb.createMultiBody(0, person, basePosition=[6.5, 3.0, 0.86], physicsClientId=c)
        maps = {0.0: lower, 4.0: upper}
        kw = dict(height_m=HEIGHT, noise_m=0.0, static_maps=maps, static_ids=w.wall_ids)
        fast = MultiRingLidar(c, rng=np.random.default_rng(0), **kw)
        slow = MultiRingLidar(c, rng=np.random.default_rng(0), method="pybullet", **kw)
        assert fast.method == "grid"
        for pose in [(5.0, 4.0, 0.0, 0.0), (1.0, 1.0, 0.7, 0.0), (8.3, 7.1, -2.0, 4.0)]:
            agree(fast.scan(*pose), slow.scan(*pose))
    finally:
        w.close()


def test_bad_parameters_fail_with_one_line(world: World) -> None:
    for kw, name in (
        ({"rings": 0}, "rings"),
        ({"azimuth_step_deg": 0.7}, "azimuth_step_deg"),
        ({"vertical_fov_deg": 200.0}, "vertical_fov_deg"),
        ({"range_m": -1.0}, "range_m"),
        ({"min_range_m": 200.0}, "min_range_m"),
        ({"method": "magic"}, "method"),
    ):
        with pytest.raises(LidarConfigError, match=f"^{name}: must be") as err:
            lidar(world, **kw)
        assert isinstance(err.value, ValueError) and "\n" not in str(err.value)
    with pytest.raises(ValueError, match="^noise_m"):
        MultiRingLidar(world.client, height_m=1.5, noise_m=-1, rng=np.random.default_rng())
    with pytest.raises(ValueError, match="^method"):
        MultiRingLidar(world.client, height_m=1.5, noise_m=0, rng=None, method="grid")


def test_sim_bench_reports_every_figure(capsys: pytest.CaptureFixture[str]) -> None:
    from wheelnav.bench.sim import main

    assert main(["--json", "--seconds", "0.2"]) == 0
    out = json.loads(capsys.readouterr().out)
    for key in ("rtf_seed_floor", "rtf_large", "raycast_ms", "load_s_seed_floor", "load_s_large"):
        assert out[key] > 0
    assert out["points_per_scan"] > 10_000 and out["method"] == "grid"
    assert out["collisions"] == 0
