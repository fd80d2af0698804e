"""Door checkpoints fit the space around each door (issue 13 failure modes 3 and 4).

Built on drawn maps (sim.sitegen), planned by the real route planner: the approach pose
leaves the chair's rear clear of what stands behind it, and the exit pose leaves the
controller's stop zone clear ahead of the chair, whatever the room's depth, the furniture
or a second door in series.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from services.planner.grid_planner import Planner
from services.planner.routes import RoutePlanner
from shared.config import ControllerConfig, PlannerConfig, RobotConfig
from shared.site import load_site
from sim.sitegen import draw, write_map

ROBOT = RobotConfig()
STOP = ControllerConfig().stop_distance_m


def make_site(folder: Path, walls, gaps, doors, size, keys=None) -> object:
    """A one-floor site; ``keys``: extra site keys per door id (type, motion, swing)."""
    write_map(draw(size, walls, gaps), folder, "floor1")
    site = {
        "name": "t",
        "floors": [{"name": "1", "elevation": 0.0, "map": "floor1.yaml"}],
        "doors": [
            {"id": i, "floor": "1", "p1": list(p1), "p2": list(p2), "type": "manual"}
            | (keys or {}).get(i, {})
            for i, p1, p2 in doors
        ],
    }
    (folder / "site.yaml").write_text(yaml.safe_dump(site))
    return load_site(folder)


def routes_for(site) -> RoutePlanner:
    return RoutePlanner(
        Planner(site, ROBOT, PlannerConfig()), site, PlannerConfig(), stop_distance_m=STOP
    )


def strip_free(site, pose, ahead_m: float, behind_m: float) -> bool:
    """The chair's strip (clearance half width) from ``behind_m`` behind the pose point to
    ``ahead_m`` ahead of it is free on the map (doors count as closed)."""
    grid = site.floor("1").map
    occ = grid.occupied(True)
    x, y, th = pose
    c, s = math.cos(th), math.sin(th)
    half = ROBOT.clearance_half_width_m
    for a in np.arange(-behind_m, ahead_m + 1e-9, 0.025):
        for b in np.arange(-half, half + 1e-9, 0.025):
            r, col = grid.to_cell(x + a * c - b * s, y + a * s + b * c)
            if occ[r, col]:
                return False
    return True


def test_exit_pose_of_a_door_into_a_shallow_furnished_room(tmp_path: Path) -> None:
    # failure mode 4: the pass's fixed end lies inside the stop zone of the wall or the
    # furniture of a small room ("2.15 of 2.24 m" for 60 s). A 0.9 m door at x = 4; a
    # cupboard 1.6 m past the door plane, across the way.
    t = 0.2
    walls = [(0, 0, 8, t), (0, 5 - t, 8, 5), (0, 0, t, 5), (8 - t, 0, 8, 5), (3.9, 0, 4.1, 5)]
    walls.append((5.6, 1.5, 6.4, 3.5))  # the cupboard
    gaps = [(3.9, 2.05, 4.1, 2.95)]
    site = make_site(tmp_path, walls, gaps, [("d", (4.0, 2.05), (4.0, 2.95))], (8, 5))
    route = routes_for(site).route((1.5, 2.5), "1", (7.2, 4.2), "1")
    (cp,) = route.checkpoints
    fp = ROBOT.footprint
    assert strip_free(site, cp.exit, fp.front + STOP, 0.0)
    assert cp.exit[0] - 4.0 >= fp.rear  # the chair's rear is past the door plane
    assert strip_free(site, cp.approach, 0.0, fp.rear)


def test_doors_in_series_leave_room_between_them(tmp_path: Path) -> None:
    # failure mode 3: a room between an inner and an outer door 1.5 m apart; the second
    # door's approach pose must lie in that room, the first door's exit before it, and the
    # chair's strip clear of the second (closed) door at both.
    t = 0.2
    walls = [(0, 0, 10, t), (0, 5 - t, 10, 5), (0, 0, t, 5), (10 - t, 0, 10, 5)]
    walls += [(3.9, 0, 4.1, 5), (5.4, 0, 5.6, 5)]
    gaps = [(3.9, 2.05, 4.1, 2.95), (5.4, 2.05, 5.6, 2.95)]
    doors = [("outer", (4.0, 2.05), (4.0, 2.95)), ("inner", (5.5, 2.05), (5.5, 2.95))]
    site = make_site(tmp_path, walls, gaps, doors, (10, 5))
    route = routes_for(site).route((1.5, 2.5), "1", (8.5, 2.5), "1")
    outer, inner = route.checkpoints
    fp = ROBOT.footprint
    assert 4.0 + fp.rear <= outer.exit[0] <= inner.approach[0] + 1e-6
    assert inner.approach[0] + fp.front <= 5.5
    assert strip_free(site, outer.exit, fp.front, 0.0)  # closed inner door not reached
    assert strip_free(site, inner.approach, 0.0, fp.rear)


@pytest.mark.parametrize("room_m, in_sweep", [(2.0, True), (3.6, False)])
def test_a_leaf_that_sweeps_the_approach_pose_is_marked(
    tmp_path: Path, room_m: float, in_sweep: bool
) -> None:
    # campaign b1005.m08: in a 2 m room between two doors in series, the inner door's
    # powered leaf opens towards the chair; its approach pose lies in the leaf's sweep
    # (there is no room to wait behind it) and the checkpoint says so, for the navigator
    # to open the door before the chair comes into the room. In a deep room the pose
    # stands behind the sweep instead.
    t, x0 = 0.2, 4.0
    x1 = x0 + room_m
    walls = [(0, 0, 12, t), (0, 5 - t, 12, 5), (0, 0, t, 5), (12 - t, 0, 12, 5)]
    walls += [(x0 - 0.1, 0, x0 + 0.1, 5), (x1 - 0.1, 0, x1 + 0.1, 5)]
    gaps = [(x0 - 0.1, 2.0, x0 + 0.1, 3.0), (x1 - 0.1, 2.0, x1 + 0.1, 3.0)]
    doors = [("outer", (x0, 2.0), (x0, 3.0)), ("inner", (x1, 2.0), (x1, 3.0))]
    keys = {"inner": {"type": "powered", "motion": "hinged", "swing": "left"}}
    site = make_site(tmp_path, walls, gaps, doors, (12, 5), keys)
    route = routes_for(site).route((1.5, 2.5), "1", (x1 + 2.5, 2.5), "1")
    outer, inner = route.checkpoints
    assert not outer.in_sweep
    assert inner.in_sweep is in_sweep
    leaf = 1.0
    front_to_plane = x1 - inner.approach[0] - ROBOT.footprint.front
    assert (front_to_plane < leaf) is in_sweep


def test_a_pass_ends_before_the_open_leaf_of_the_next_door_in_series(tmp_path: Path) -> None:
    # campaign b2000.m08: two doors in series 2.9 m apart, the second 0.185 m to one side
    # and its hinged leaf standing open towards the chair, 0.39 m beside the first door's
    # centre line; the first door's pass ended with the chair's front 0.2 m beside the
    # leaf, its corner 3.7 cm from it (the depth strip missed the leaf, drawn a cell out of
    # its opening, by 1.5 cm)
    t = 0.2
    walls = [(0, 0, 10, t), (0, 5 - t, 10, 5), (0, 0, t, 5), (10 - t, 0, 10, 5)]
    walls += [(3.9, 0, 4.1, 5), (6.8, 0, 7.0, 5)]
    gaps = [(3.9, 2.0, 4.1, 3.05), (6.8, 2.135, 7.0, 3.285)]
    doors = [("first", (4.0, 2.0), (4.0, 3.05)), ("second", (6.9, 2.135), (6.9, 3.285))]
    keys = {
        "first": {"motion": "sliding"},
        "second": {"motion": "hinged", "swing": "left"},
    }
    site = make_site(tmp_path, walls, gaps, doors, (10, 5), keys)
    (leaf,) = [d.open_leaf() for d in site.doors if d.id == "second"]
    assert leaf[1][0] == pytest.approx(5.75)  # the leaf stands from x 6.9 back to 5.75
    route = routes_for(site).route((1.5, 2.525), "1", (8.5, 2.7), "1")
    first = route.checkpoints[0]
    assert first.id == "first"
    front = first.exit[0] + ROBOT.footprint.front
    assert front <= 5.75, f"the pass ends with the front {front - 5.75:.2f} m beside the leaf"


@pytest.mark.parametrize("corridor_m", [1.5, 1.8])
def test_approach_from_a_corridor_keeps_the_rear_off_the_far_wall(
    tmp_path: Path, corridor_m: float
) -> None:
    # the door on the side wall of a corridor: the approach pose keeps the chair's rear
    # off the corridor's far wall and its front short of the door plane
    t = 0.2
    top = 3.0 + corridor_m + t
    walls = [(0, 0, 10, t), (0, top, 10, top + t), (0, 0, t, top + t), (10 - t, 0, 10, top + t)]
    walls.append((0, 2.9, 10, 3.1))  # the wall between the room (below) and the corridor
    gaps = [(4.55, 2.9, 5.45, 3.1)]
    site = make_site(tmp_path, walls, gaps, [("d", (4.55, 3.0), (5.45, 3.0))], (10, top + t))
    route = routes_for(site).route((1.0, 3.1 + corridor_m / 2), "1", (5.0, 1.2), "1")
    (cp,) = route.checkpoints
    fp = ROBOT.footprint
    assert strip_free(site, cp.approach, 0.0, fp.rear)
    assert cp.approach[1] - 3.0 >= fp.front  # the front stops short of the door plane


@pytest.mark.parametrize("width", [0.80, 0.85])
@pytest.mark.parametrize("y0", [2.0, 2.0125, 2.03])
def test_a_narrow_door_in_open_space_gets_the_preferred_poses(
    tmp_path: Path, width: float, y0: float
) -> None:
    # found by the campaign (b1.m07, a 0.85 m door): the strip the free depth is measured
    # in is as wide as the chair's clearance (0.75 m) and, in a narrow doorway, touched
    # the jambs' cells, so the depth was 0 on both sides: the approach fell to its least
    # (front 5 cm short of the plane, beside the open leaf) and the pass ended with the
    # rear barely out of the doorway, in rooms 4 m deep. The map's opening is a cell
    # narrower than the site's door, as a drawing rasterised at 5 cm may well be.
    t = 0.2
    walls = [(0, 0, 10, t), (0, 5 - t, 10, 5), (0, 0, t, 5), (10 - t, 0, 10, 5), (4.9, 0, 5.1, 5)]
    gaps = [(4.9, y0 + 0.05, 5.1, y0 + width)]
    site = make_site(tmp_path, walls, gaps, [("d", (5.0, y0), (5.0, y0 + width))], (10, 5))
    route = routes_for(site).route((1.5, 2.5), "1", (8.5, 2.5), "1")
    (cp,) = route.checkpoints
    cfg = PlannerConfig()
    assert 5.0 - cp.approach[0] == pytest.approx(cfg.door_standoff_m, abs=0.06)
    assert cp.exit[0] - 5.0 == pytest.approx(cfg.door_exit_m, abs=0.06)


def test_an_obstacle_the_map_lacks_moves_the_approach_pose(tmp_path: Path) -> None:
    # world-differs campaign b7002w.m05: a cupboard the map lacks stood beside a hall
    # door's approach pose (behind the sweep of a leaf opening towards the chair), 1.5 cm
    # into the chair's strip there; Phase 0 found no manoeuvre to the pose (three
    # attempts) and the mission failed. The points a failed Phase 0 marks come with the
    # re-plan: the pose is fitted to the space they leave.
    t = 0.2
    walls = [(0, 0, 10, t), (0, 5 - t, 10, 5), (0, 0, t, 5), (10 - t, 0, 10, 5), (4.9, 0, 5.1, 5)]
    gaps = [(4.9, 2.0, 5.1, 3.0)]
    keys = {"d": {"motion": "hinged", "swing": "left"}}
    site = make_site(tmp_path, walls, gaps, [("d", (5.0, 2.0), (5.0, 3.0))], (10, 5), keys)
    routes = routes_for(site)
    (mapped,) = routes.route((1.0, 2.5), "1", (8.5, 2.5), "1").checkpoints
    fp = ROBOT.footprint
    assert not mapped.in_sweep and mapped.approach[0] - fp.rear < 2.75  # beside the cupboard
    # the cupboard's edge, as a scan shows it: x 2.0-2.75 along y = 2.86
    cupboard = [(float(x), 2.86, "1") for x in np.arange(2.0, 2.76, 0.05)]
    (moved,) = routes.request((1.0, 2.5), "1", (8.5, 2.5), "1", blocked=cupboard).checkpoints
    assert moved.approach[0] - fp.rear >= 2.75 + 0.05  # the rear clear of the cupboard
    assert moved.approach[0] + fp.front <= 5.0  # the front short of the door plane
    assert moved.in_sweep  # no room behind the leaf's sweep now
    (again,) = routes.route((1.0, 2.5), "1", (8.5, 2.5), "1").checkpoints
    assert again.approach == mapped.approach  # the marks held for that request only


@pytest.mark.parametrize("door_type", ["manual", "powered"])
def test_a_chair_waits_behind_a_manual_leaf_only_where_it_can_get_there(
    tmp_path: Path, door_type: str
) -> None:
    # world-differs campaign b7200w.m04 and b7101w.m07: the pose behind the sweep of a
    # manual leaf opening towards the chair, 2 m from the door, lay between a table and
    # a wall, 7.5 and 10 cm beside the chair; no docking got there, and the recoveries
    # gave up. A manual leaf moves only by hand, so the chair waits behind its sweep only
    # where there is room around that pose; else at the preferred standoff, in the sweep
    # (the room the building promises next to every door). A powered leaf opens by
    # itself: behind its sweep still, where the chair fits.
    t = 0.2
    walls = [(0, 0, 10, t), (0, 5 - t, 10, 5), (0, 0, t, 5), (10 - t, 0, 10, 5), (4.9, 0, 5.1, 5)]
    walls.append((2.5, 2.9, 3.5, 3.5))  # the table, 7.5 cm beside the pose behind the leaf
    gaps = [(4.9, 2.0, 5.1, 3.0)]
    keys = {"d": {"type": door_type, "motion": "hinged", "swing": "left"}}
    site = make_site(tmp_path, walls, gaps, [("d", (5.0, 2.0), (5.0, 3.0))], (10, 5), keys)
    (cp,) = routes_for(site).route((1.0, 2.5), "1", (8.5, 2.5), "1").checkpoints
    fp = ROBOT.footprint
    behind = 5.0 - (fp.front + 1.0 + 0.25)  # the pose behind the leaf's sweep
    if door_type == "manual":
        assert cp.approach[0] == pytest.approx(5.0 - PlannerConfig().door_standoff_m, abs=0.06)
        assert cp.in_sweep
    else:
        assert cp.approach[0] == pytest.approx(behind, abs=0.06)
        assert not cp.in_sweep


def test_a_chair_waits_behind_a_manual_leaf_where_that_has_more_room_than_beside_it(
    tmp_path: Path,
) -> None:
    # campaign seeds 8400-8411, b8402.m05: an 0.80 m manual door hinged 10 cm from a side
    # wall, its leaf opening towards the chair. Behind the leaf's sweep the strip had
    # 13.5 cm more room a side than the chair needs, under the 15 cm asked for, so the
    # approach pose went into the sweep, beside the open leaf, where the chair has 1.25 cm
    # more (the leaf's face 6.25 cm from its side): docking there came to 1.5 cm from the
    # leaf. Behind the sweep is the roomier place to wait, so the chair waits there.
    t = 0.2
    walls = [(0, 0, 10, t), (0, 5 - t, 10, 5), (0, 0, t, 5), (10 - t, 0, 10, 5), (4.9, 0, 5.1, 5)]
    walls.append((t, 1.75, 4.9, 1.9))  # the side wall, 10 cm beyond the hinge
    gaps = [(4.9, 2.0, 5.1, 2.8)]
    keys = {"d": {"motion": "hinged", "swing": "left"}}
    site = make_site(tmp_path, walls, gaps, [("d", (5.0, 2.0), (5.0, 2.8))], (10, 5), keys)
    (cp,) = routes_for(site).route((1.0, 3.5), "1", (8.5, 2.5), "1").checkpoints
    fp = ROBOT.footprint
    behind = 5.0 - (fp.front + 0.8 + 0.25)  # the pose behind the leaf's sweep
    assert not cp.in_sweep
    assert cp.approach[0] == pytest.approx(behind, abs=0.06)


def test_a_leaf_swung_away_from_the_chair_is_said_so(tmp_path: Path) -> None:
    """A hinged leaf swinging left of p1 -> p2 (here: into x < 5) opens towards a chair
    coming from x > 5 and away from one coming from x < 5; the smooth pass runs on the
    free opening's middle beside a leaf that stands beyond the door (campaign b8900.m01
    with smooth: 4.8 cm from such a leaf on the door's middle line, 5 cm asked)."""
    t = 0.2
    walls = [(0, 0, 10, t), (0, 5 - t, 10, 5), (0, 0, t, 5), (10 - t, 0, 10, 5), (4.9, 0, 5.1, 5)]
    gaps = [(4.9, 2.0, 5.1, 3.0)]
    keys = {"d": {"motion": "hinged", "swing": "left"}}
    site = make_site(tmp_path, walls, gaps, [("d", (5.0, 2.0), (5.0, 3.0))], (10, 5), keys)
    routes = routes_for(site)
    (towards,) = routes.route((1.0, 2.5), "1", (8.5, 2.5), "1").checkpoints
    (away,) = routes.route((8.5, 2.5), "1", (1.0, 2.5), "1").checkpoints
    assert not towards.leaf_away and away.leaf_away
    assert away.approach[1] == pytest.approx(2.5 + 0.05 / 4)  # on the free opening's middle
