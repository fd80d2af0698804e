"""The bundled multi-floor sites: doors on gaps, widths, lifts, places reachable."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import ndimage

from shared.site import SiteError, load_site
from tests.conftest import ROOT


@pytest.mark.parametrize("name", ["two_floors", "seed_floor", "two_ways"])
def test_doors_sit_on_gaps_and_lifts_serve_their_floors(name: str) -> None:
    site = load_site(ROOT / "sites" / name)
    for door in site.doors:
        grid = site.floor(door.floor).map
        t = np.linspace(0.1, 0.9, 9)[:, None]
        pts = np.asarray(door.p1) + (np.asarray(door.p2) - np.asarray(door.p1)) * t
        cells = [grid.to_cell(x, y) for x, y in pts]
        assert all(grid.cells[r, c] == 0 for r, c in cells), door.id  # the gap is free
        assert 0.8 - 1e-6 <= math.dist(door.p1, door.p2) <= 1.5 + 1e-6, door.id
    for lift in site.elevators:
        for floor in lift.floors:
            x, y, theta = lift.entry_pose(floor, 1.5)
            grid = site.floor(floor).map
            r, c = grid.to_cell(x, y)
            assert grid.cells[r, c] == 0, (lift.id, floor)
            cx, cy = lift.door_centre(floor)
            assert math.cos(theta) * (cx - x) + math.sin(theta) * (cy - y) > 0  # faces the car


def test_two_floors_has_what_the_planner_issue_asks_for() -> None:
    site = load_site(ROOT / "sites" / "two_floors")
    assert len(site.doors) >= 8 and len(site.elevators) == 2
    assert {d.type for d in site.doors} == {"manual", "automatic", "powered"}
    for floor in ("1", "2"):  # every place reachable for the chair on its floor
        grid = site.floor(floor).map
        free = ndimage.distance_transform_edt(grid.cells == 0, sampling=grid.resolution) > 0.375
        labels, _n = ndimage.label(free)
        places = [p for p in site.places.values() if p.floor == floor]
        ids = {labels[grid.to_cell(p.x, p.y)] for p in places}
        assert len(ids) == 1 and 0 not in ids, floor


def test_bad_elevator_is_refused(tmp_path) -> None:
    from sim.sitegen import write_map

    write_map(np.zeros((40, 40), bool), tmp_path, "f1")
    (tmp_path / "site.yaml").write_text(
        "floors: [{name: '1', map: f1.yaml}]\n"
        "elevators: [{id: l1, floors: ['1', '9'], car: {x: 1, y: 1, theta: 0, width: 1.6,"
        " depth: 2}, doors: {'1': {p1: [1, 0], p2: [1, 2]}}}]\n"
    )
    with pytest.raises(SiteError, match="9"):
        load_site(tmp_path)
