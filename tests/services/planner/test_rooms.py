"""Room segmentation and door detection: the bundled site, corridors, furniture, raw paths."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from services.planner.grid_astar import astar
from services.planner.path_doors import detect_doors_along_path
from services.planner.room_segmentation import RoomMap, segment_rooms
from shared.site import load_site
from sim.sitegen import draw
from tests.conftest import ROOT

RES = 0.05
T = 0.2  # wall thickness

# A 30 m x 2 m corridor (y 5.4..7.4) with four 7.4 m x 5 m rooms below it, each reached
# through its own door in the corridor wall (y 5.2..5.4): (door centre x, door width).
CORRIDOR_DOORS = [(3.9, 0.8), (11.4, 1.0), (19.0, 1.2), (26.6, 1.5)]


def box(w: float, h: float) -> list[tuple[float, float, float, float]]:
    return [(0, 0, w, T), (0, h - T, w, h), (0, 0, T, h), (w - T, 0, w, h)]


def corridor_map() -> np.ndarray:
    w, h = 30.4, 7.6
    walls = box(w, h) + [(0, 5.2, w, 5.4)] + [(x, 0, x + T, 5.4) for x in (7.6, 15.2, 22.8)]
    gaps = [(cx - dw / 2, 5.2, cx + dw / 2, 5.4) for cx, dw in CORRIDOR_DOORS]
    return draw((w, h), walls, gaps, RES)


def segment(occ: np.ndarray) -> RoomMap:
    return segment_rooms(occ, RES, (0.0, 0.0))


def assert_consistent(rm: RoomMap, occ: np.ndarray) -> None:
    """Labels 0 on obstacles, 1..N rooms matching the graph, normals pointing from a to b."""
    assert rm.labels.shape == occ.shape and rm.labels.dtype == np.int32
    assert not rm.labels[occ].any()
    assert set(np.unique(rm.labels)) - {0} == set(rm.graph.nodes)
    for d in rm.doorways:
        assert d.room_a < d.room_b and rm.graph.has_edge(d.room_a, d.room_b)
        assert math.isclose(math.hypot(*d.normal), 1.0)
        assert math.isclose(math.dist(d.p1, d.p2), d.width, abs_tol=1e-9)
        x, y = d.centre
        nx_, ny_ = d.normal
        assert rm.room_at(x - 0.6 * nx_, y - 0.6 * ny_) == d.room_a
        assert rm.room_at(x + 0.6 * nx_, y + 0.6 * ny_) == d.room_b
        assert rm.room_at(x, y) == 0  # the door gap belongs to no room


def test_two_rooms_site_one_doorway() -> None:
    grid = load_site(ROOT / "sites" / "two_rooms").floor("").map
    occ = grid.occupied()
    rm = segment_rooms(occ, grid.resolution, grid.origin[:2])
    assert_consistent(rm, occ)
    assert len(rm.graph) == 2 and len(rm.doorways) == 1
    (door,) = rm.doorways
    assert math.dist(door.centre, (6.2, 2.7)) < 0.1
    assert abs(door.width - 1.0) < 0.1
    assert abs(abs(door.normal[0]) - 1.0) < 1e-6
    assert {rm.room_at(2.0, 2.7), rm.room_at(10.5, 2.7)} == {1, 2}  # the site's two places
    assert rm.graph.edges[1, 2]["doorway"] == 0


def test_corridor_with_four_rooms() -> None:
    occ = corridor_map()
    rm = segment(occ)
    assert_consistent(rm, occ)
    assert len(rm.graph) == 5 and len(rm.doorways) == 4
    corridor = rm.room_at(1.0, 6.4)
    assert all(rm.room_at(x, 6.4) == corridor for x in np.arange(0.5, 30.0, 0.5))
    assert rm.graph.degree(corridor) == 4
    assert 59.0 < rm.graph.nodes[corridor]["area_m2"] < 61.0
    doors = sorted(rm.doorways, key=lambda d: d.centre)
    for (cx, width), door in zip(CORRIDOR_DOORS, doors, strict=True):
        assert math.dist(door.centre, (cx, 5.3)) < 0.15
        assert abs(door.width - width) < 0.1
        assert abs(door.normal[1]) == pytest.approx(1.0)
        assert corridor in (door.room_a, door.room_b)


def test_l_corridor_and_furnished_room_make_no_false_doors() -> None:
    w, h = 20.0, 16.0
    walls = box(w, h) + [
        (2.2, 0, 2.4, 13.8),  # the L corridor: x 0.2..2.2 up, then y 13.8..15.8 across
        (2.4, 13.6, w, 13.8),
        (5.0, 5.0, 6.5, 5.8),  # a table
        (7.5, 9.0, 7.9, 9.4),  # a pillar
        (3.2, 3.0, 3.6, 3.4),  # a pillar 0.8 m from the wall
        (8.0, 1.5, 9.0, 2.4),  # a cabinet 0.9 m from the corner
    ]
    occ = draw((w, h), walls, [(2.2, 6.0, 2.4, 6.9)], RES)
    rm = segment(occ)
    assert_consistent(rm, occ)
    assert len(rm.graph) == 2 and len(rm.doorways) == 1
    (door,) = rm.doorways
    assert math.dist(door.centre, (2.3, 6.45)) < 0.15 and abs(door.width - 0.9) < 0.1
    assert rm.room_at(1.2, 1.0) == rm.room_at(1.2, 14.8) == rm.room_at(19.0, 14.8)


def test_pillar_in_a_corridor_is_not_a_door() -> None:
    # A 3 m corridor with a 0.6 m pillar in the middle: two 1.1 m passages, no wall.
    w, h = 20.0, 3.4
    occ = draw((w, h), box(w, h) + [(10.0, 1.3, 10.6, 2.1)], [], RES)
    rm = segment(occ)
    assert len(rm.graph) == 1 and rm.doorways == []


def test_wide_opening_is_not_a_door() -> None:
    # A room opening on a corridor through 3 m, next to a room behind a 1 m door: the
    # 3 m opening joins room and corridor into one room (documented choice).
    w, h = 20.0, 9.4
    walls = box(w, h) + [(0, 7.0, w, 7.2), (8.0, 0, 8.2, 7.2)]
    occ = draw((w, h), walls, [(2.0, 7.0, 5.0, 7.2), (12.0, 7.0, 13.0, 7.2)], RES)
    rm = segment(occ)
    assert_consistent(rm, occ)
    assert len(rm.graph) == 2 and len(rm.doorways) == 1
    assert math.dist(rm.doorways[0].centre, (12.5, 7.1)) < 0.15
    assert rm.room_at(4.0, 3.0) == rm.room_at(15.0, 8.2) != rm.room_at(15.0, 3.0)


def test_narrow_corridor_is_one_room_with_its_doors() -> None:
    # A 1.5 m corridor, narrower than the widest door, still is a room of its own.
    w, h = 24.0, 7.1
    walls = box(w, h) + [(0, 5.2, w, 5.4)] + [(x, 0, x + T, 5.4) for x in (8.0, 16.0)]
    gaps = [(cx - 0.45, 5.2, cx + 0.45, 5.4) for cx in (4.0, 12.0, 20.0)]
    rm = segment(draw((w, h), walls, gaps, RES))
    assert len(rm.graph) == 4 and len(rm.doorways) == 3
    corridor = rm.room_at(1.0, 6.2)
    assert rm.graph.degree(corridor) == 3
    assert all(abs(d.width - 0.9) < 0.1 for d in rm.doorways)


def test_staggered_doors_on_a_narrow_corridor_make_no_false_door() -> None:
    # A 1.4 m corridor with doors on both sides that overlap in x: the corridor's
    # cross-sections between them look like openings, but toward opposite sides.
    w, h = 24.0, 11.8
    walls = box(w, h) + [(0, 5.0, w, 5.2), (0, 6.6, w, 6.8)]
    walls += [(x, 0, x + T, 5.2) for x in (8.0, 16.0)] + [(x, 6.6, x + T, h) for x in (6.0, 18.0)]
    gaps = [(3.0, 5.0, 4.4, 5.2), (10.0, 5.0, 11.0, 5.2), (20.0, 5.0, 21.2, 5.2)]
    gaps += [(4.0, 6.6, 5.2, 6.8), (10.6, 6.6, 12.1, 6.8), (19.5, 6.6, 20.5, 6.8)]
    occ = draw((w, h), walls, gaps, RES)
    rm = segment(occ)
    assert_consistent(rm, occ)
    assert len(rm.graph) == 7 and len(rm.doorways) == 6
    corridor = rm.room_at(1.0, 5.9)
    assert all(rm.room_at(x, 5.9) == corridor for x in np.arange(0.5, 23.6, 0.5))
    for x0, y0, x1, _ in gaps:
        assert any(math.dist(d.centre, ((x0 + x1) / 2, y0 + 0.1)) < 0.1 for d in rm.doorways)


def test_two_doors_between_the_same_rooms_and_a_blocked_gap() -> None:
    w, h = 14.0, 6.0
    wall = box(w, h) + [(6.8, 0, 7.0, h)]
    rm = segment(draw((w, h), wall, [(6.8, 1.0, 7.0, 2.0), (6.8, 4.0, 7.0, 4.8)], RES))
    assert len(rm.graph) == 2 and len(rm.doorways) == 2
    edge = rm.graph.edges[1, 2]
    assert sorted(edge["doorways"]) == [0, 1] and edge["width"] == pytest.approx(1.0, abs=0.1)
    assert rm.doorways[edge["doorway"]].width == edge["width"]
    # A 0.5 m gap is too narrow for the chair: two rooms, no doorway between them.
    rm = segment(draw((w, h), wall, [(6.8, 1.0, 7.0, 1.5)], RES))
    assert len(rm.graph) == 2 and rm.doorways == [] and rm.graph.number_of_edges() == 0


def test_slanted_wall_door_and_sensor_specks() -> None:
    n = 200
    rr, cc = np.mgrid[0:n, 0:n]
    across, along = (rr - cc) / math.sqrt(2), (rr + cc) / math.sqrt(2)
    occ = (np.abs(across) <= 2) & (np.abs(along - along.max() / 2) >= 10)  # 1.0 m gap
    occ[[0, -1], :] = occ[:, [0, -1]] = True
    occ |= np.random.default_rng(0).random(occ.shape) < 0.002  # single-cell specks
    rm = segment(occ)
    assert len(rm.graph) == 2 and len(rm.doorways) == 1
    (door,) = rm.doorways
    assert math.dist(door.centre, (5.0, 5.0)) < 0.1 and abs(door.width - 1.0) < 0.1
    assert abs(door.normal[0] + door.normal[1]) < 0.05  # across the x = y wall


@settings(max_examples=15, deadline=None)
@given(
    width=st.floats(0.75, 1.75),
    y=st.floats(0.2, 4.0),  # from flush with the bottom wall up
    thickness=st.sampled_from([0.05, 0.1, 0.2, 0.4]),
)
# The widest door flush with the bottom wall, in a wall a cell thick: the cut's saddle
# fell on the free cell beside the wall, where no chord is short enough (one room).
@example(width=1.75, y=0.21875, thickness=0.05)
def test_door_width_and_centre_in_a_wall(width: float, y: float, thickness: float) -> None:
    w, h = 12.0, 6.0
    wall = box(w, h) + [(6.0, 0, 6.0 + thickness, h)]
    occ = draw((w, h), wall, [(6.0, y, 6.0 + thickness, y + width)], RES)
    drawn = (round((y + width) / RES) - round(y / RES)) * RES  # the width as rasterised
    rm = segment(occ)
    assert len(rm.graph) == 2 and len(rm.doorways) == 1
    (door,) = rm.doorways
    assert abs(door.width - drawn) < 0.06
    assert math.dist(door.centre, (6.0 + thickness / 2, y + width / 2)) < 0.1


def test_rejects_bad_arguments() -> None:
    with pytest.raises(ValueError):
        segment_rooms(np.zeros((10, 10), dtype=bool), 0.0, (0.0, 0.0))
    with pytest.raises(ValueError):
        segment_rooms(np.zeros((10, 10), dtype=bool), RES, (0.0, 0.0), 1.8, 0.7)
    rm = segment_rooms(np.ones((10, 10), dtype=bool), RES, (0.0, 0.0))
    assert len(rm.graph) == 0 and rm.doorways == []


# --------------------------------------------------------------------------------------
# Doors along a raw path
# --------------------------------------------------------------------------------------


def cells_to_xy(cells: np.ndarray) -> np.ndarray:
    return np.stack([(cells[:, 1] + 0.5) * RES, (cells[:, 0] + 0.5) * RES], axis=1)


def test_path_from_room_to_room_crosses_two_doors() -> None:
    occ = corridor_map()
    start, goal = (int(2.5 / RES), int(3.9 / RES)), (int(2.5 / RES), int(19.0 / RES))
    path = cells_to_xy(astar(occ, start, goal))  # raw A*: hugs the jambs, no inflation
    doors = detect_doors_along_path(occ, RES, (0.0, 0.0), path)
    assert len(doors) == 2
    for (cx, width), door, way in zip(
        (CORRIDOR_DOORS[0], CORRIDOR_DOORS[2]), doors, (1.0, -1.0), strict=True
    ):
        assert math.dist(door.centre, (cx, 5.3)) < 0.15
        assert abs(door.width - width) < 0.1
        assert door.normal == pytest.approx((0.0, way))  # the way the path goes through
        assert math.isclose(math.dist(door.p1, door.p2), door.width)
        crossing = path[door.index : door.index + 2, 1]
        assert crossing.min() <= 5.3 + 0.15 and crossing.max() >= 5.3 - 0.15
    assert doors[0].index < doors[1].index and doors[0].distance < doors[1].distance
    assert doors[1].distance < 2.0 * 17.0


def test_path_along_the_corridor_and_through_rooms_finds_nothing() -> None:
    occ = corridor_map()
    along = np.array([[0.5, 6.4], [29.9, 6.4], [29.9, 7.0], [0.6, 7.0]])
    assert detect_doors_along_path(occ, RES, (0.0, 0.0), along) == []
    # Past a pillar in a corridor and beside a table: narrow, but not doors.
    w, h = 20.0, 3.4
    pillar = draw((w, h), box(w, h) + [(10.0, 1.3, 10.6, 2.1)], [], RES)
    assert detect_doors_along_path(pillar, RES, (0.0, 0.0), [[1.0, 0.75], [19.0, 0.75]]) == []


def test_path_through_a_door_beside_a_room_corner() -> None:
    # The door's right jamb is a 0.4 m stub before the partition: the corner between the
    # stub and the partition must not pass for the door.
    w, h = 16.0, 9.0
    walls = box(w, h) + [(0, 5.0, w, 5.2), (8.0, 0, 8.2, 5.2)]
    occ = draw((w, h), walls, [(6.8, 5.0, 7.6, 5.2), (9.0, 5.0, 10.0, 5.2)], RES)
    path = np.array([[6.0, 2.0], [7.5, 4.6], [7.5, 5.6], [9.5, 5.8], [9.5, 3.0]])
    doors = detect_doors_along_path(occ, RES, (0.0, 0.0), path)
    assert [round(d.width, 2) for d in doors] == [0.8, 1.0]
    assert math.dist(doors[0].centre, (7.2, 5.1)) < 0.05
    assert math.dist(doors[1].centre, (9.5, 5.1)) < 0.05
    rm = segment(occ)
    assert len(rm.graph) == 3 and len(rm.doorways) == 2


def test_path_crossing_a_door_at_a_slant_and_back() -> None:
    occ = corridor_map()
    path = np.array([[17.5, 2.0], [19.4, 6.8], [22.0, 6.8], [18.7, 6.0], [18.0, 3.0]])
    doors = detect_doors_along_path(occ, RES, (0.0, 0.0), path, min_door_m=0.7)
    assert [d.index for d in doors] == [0, 3]
    assert all(math.dist(d.centre, (19.0, 5.3)) < 0.15 for d in doors)
    assert all(abs(d.width - 1.2) < 0.1 for d in doors)
    assert doors[0].normal[1] > 0.99 and doors[1].normal[1] < -0.99
    assert detect_doors_along_path(occ, RES, (0.0, 0.0), path[:1]) == []
