"""Map origins with a yaw: the image is turned about its lower-left corner, as map_server does.

load_map resamples such a map onto an axis-aligned grid, so a point of the image lands at
origin + R(yaw) (point - origin) in the map frame.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from shared.site import FREE, OCCUPIED, UNKNOWN, GridMap, SiteError, load_map, load_site
from sim.sitegen import draw, write_map

RES = 0.05
ORIGIN = (1.0, -2.0)
SIZE = (4.0, 3.0)  # 80 x 60 cells
# an L with a short leg, plus a block near one corner: no symmetry maps it onto itself
WALLS = [
    (0.5, 0.5, 2.5, 0.8),
    (0.5, 0.5, 0.8, 2.0),
    (3.0, 2.0, 3.4, 2.6),
]
YAWS = [math.pi / 2, math.radians(30), math.radians(-135)]


def _write(folder: Path, yaw: float | str = 0.0) -> Path:
    """The test map with ``origin: [ORIGIN..., yaw]`` (yaw set by editing the YAML)."""
    path = write_map(draw(SIZE, WALLS, resolution=RES), folder, "m", RES, (*ORIGIN, 0.0))
    meta = yaml.safe_load(path.read_text())
    meta["origin"] = [*ORIGIN, yaw]
    text = yaml.safe_dump(meta, sort_keys=False)
    if isinstance(yaw, str):  # a YAML literal such as .nan, written as is
        text = text.replace(f"'{yaw}'", yaw)
    path.write_text(text)
    return path


def _turn(points: np.ndarray, yaw: float) -> np.ndarray:
    """(N, 2) map points of the unturned image, turned about the origin by ``yaw``."""
    c, s = math.cos(yaw), math.sin(yaw)
    d = points - np.array(ORIGIN)
    return np.array(ORIGIN) + d @ np.array([[c, s], [-s, c]])


def _lookup(grid: GridMap, points: np.ndarray) -> np.ndarray:
    """Cell values at (N, 2) map points (UNKNOWN off the grid)."""
    out = np.full(len(points), UNKNOWN, dtype=int)
    for k, (x, y) in enumerate(points):
        r, c = grid.to_cell(x, y)
        if grid.contains(r, c):
            out[k] = grid.cells[r, c]
    return out


def _interior(cells: np.ndarray) -> np.ndarray:
    """Cells whose 3x3 neighbourhood lies in the grid and holds a single value."""
    same = np.zeros(cells.shape, dtype=bool)
    core = cells[1:-1, 1:-1]
    ok = np.ones(core.shape, dtype=bool)
    for dr in (-1, 0, 1):
        for dc in (-1, 0, 1):
            ok &= cells[1 + dr : cells.shape[0] - 1 + dr, 1 + dc : cells.shape[1] - 1 + dc] == core
    same[1:-1, 1:-1] = ok
    return same


@pytest.fixture
def flat(tmp_path: Path) -> GridMap:
    return load_map(_write(tmp_path / "flat"))


def test_yaw_zero_is_unchanged(flat: GridMap) -> None:
    occ = draw(SIZE, WALLS, resolution=RES)
    assert flat.origin == (*ORIGIN, 0.0)
    assert flat.cells.dtype == np.int8
    assert np.array_equal(flat.cells, np.where(occ, OCCUPIED, FREE).astype(np.int8))


@pytest.mark.parametrize("yaw", YAWS, ids=["90deg", "30deg", "-135deg"])
def test_turned_map_puts_every_point_where_map_server_would(
    tmp_path: Path, flat: GridMap, yaw: float
) -> None:
    turned = load_map(_write(tmp_path, yaw))
    assert turned.resolution == RES
    assert turned.origin[2] == 0.0

    # obstacle points (cell centres away from the wall edges) stay obstacles
    occupied = flat.occupied() & _interior(flat.cells)
    assert occupied.sum() > 100
    obstacle_pts = flat.to_world(np.argwhere(occupied))
    mask = turned.occupied()
    for x, y in _turn(obstacle_pts, yaw):
        r, c = turned.to_cell(x, y)
        assert turned.contains(r, c) and mask[r, c], (x, y)

    # many points anywhere in the image: same value unless within one cell of an edge
    rng = np.random.default_rng(7)
    pts = np.array(ORIGIN) + rng.uniform((0, 0), SIZE, size=(4000, 2))
    rows, cols = np.array([flat.to_cell(x, y) for x, y in pts]).T
    keep = _interior(flat.cells)[rows, cols]
    assert keep.sum() > 3000
    expected = flat.cells[rows[keep], cols[keep]]
    got = _lookup(turned, _turn(pts[keep], yaw))
    assert np.array_equal(got, expected)
    assert (expected == FREE).sum() > 2000 and (expected == OCCUPIED).sum() > 50

    # the grid is the turned image's bounding box: nothing of the image is cut off, and
    # what lies outside the image is unknown
    corners = _turn(np.array(ORIGIN) + np.array([[0, 0], [SIZE[0], 0], [0, SIZE[1]], SIZE]), yaw)
    lo, hi = corners.min(axis=0), corners.max(axis=0)
    assert turned.origin[:2] == pytest.approx(tuple(lo), abs=1e-9)
    top_right = np.array(turned.origin[:2]) + np.array(turned.shape[::-1]) * RES
    assert np.all(top_right >= hi - 1e-9) and np.all(top_right < hi + RES)
    outside = _turn(np.array([[ORIGIN[0] - 0.3, ORIGIN[1] + 1.5]]), yaw)  # left of the image
    assert _lookup(turned, outside)[0] == UNKNOWN


@pytest.mark.parametrize("quarters", [1, 2, 3, -1, 5])
def test_quarter_turns_are_exact(tmp_path: Path, flat: GridMap, quarters: int) -> None:
    turned = load_map(_write(tmp_path, quarters * math.pi / 2))
    rows, cols = flat.shape
    assert turned.shape == ((cols, rows) if quarters % 2 else (rows, cols))
    assert (turned.cells == OCCUPIED).sum() == (flat.cells == OCCUPIED).sum()
    assert (turned.cells == UNKNOWN).sum() == 0  # no gaps, nothing outside the image
    # every cell centre lands on a cell centre
    src = np.argwhere(np.ones(flat.shape, dtype=bool))
    got = _lookup(turned, _turn(flat.to_world(src), quarters * math.pi / 2))
    assert np.array_equal(got, flat.cells[src[:, 0], src[:, 1]])


def test_a_rounded_quarter_turn_is_taken_as_exact(tmp_path: Path) -> None:
    exact = load_map(_write(tmp_path / "a", math.pi / 2))
    rounded = load_map(_write(tmp_path / "b", 1.5708))  # as users write it
    assert np.array_equal(rounded.cells, exact.cells)
    assert rounded.origin == pytest.approx(exact.origin)


@pytest.mark.parametrize("yaw", [".nan", ".inf", "-.inf", "north"])
def test_a_bad_yaw_is_a_one_line_error(tmp_path: Path, yaw: str) -> None:
    path = _write(tmp_path, yaw)
    with pytest.raises(SiteError) as err:
        load_map(path)
    msg = str(err.value)
    assert str(path) in msg and "origin" in msg and "\n" not in msg


def test_site_with_a_turned_floor_map(tmp_path: Path, flat: GridMap) -> None:
    yaw = math.pi / 2
    _write(tmp_path, yaw)
    # a place on the free floor between the L and the block, in map-frame coordinates
    px, py = _turn(np.array([[ORIGIN[0] + 2.0, ORIGIN[1] + 1.5]]), yaw)[0]
    site = {
        "name": "turned",
        "floors": [{"name": "1", "elevation": 0.0, "map": "m.yaml"}],
        "places": {"middle": {"floor": "1", "x": float(px), "y": float(py), "theta": 0.0}},
    }
    (tmp_path / "site.yaml").write_text(yaml.safe_dump(site, sort_keys=False))
    loaded = load_site(tmp_path)
    grid = loaded.floor("1").map
    assert grid.origin[2] == 0.0
    assert grid.shape == flat.shape[::-1]
    assert np.array_equal(grid.cells, np.rot90(flat.cells, k=-1))
    place = loaded.place("middle")
    assert _lookup(grid, np.array([[place.x, place.y]]))[0] == FREE
    # the block's centre, turned, is an obstacle in the planner's grid
    block = _turn(np.array([[ORIGIN[0] + 3.2, ORIGIN[1] + 2.3]]), yaw)
    r, c = grid.to_cell(*block[0])
    assert grid.occupied(True)[r, c]
