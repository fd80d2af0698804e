"""Global relocalisation with real scans: a kidnapped chair, a prior far off in a large hall,
places too symmetric to tell apart, and the evaluation budget."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from services.localisation.matcher import DistanceField
from services.localisation.relocalise import (
    Relocaliser,
    RelocaliseSettings,
    SearchBounds,
    widening_bounds,
)
from shared.config import load
from shared.geometry import angle_between
from shared.site import Site, load_site
from sim.simulation import Simulation

# generated building 8, one floor: a 20.6 x 25.4 m hall east of a corridor, with a few
# pieces of furniture by its door; its 180 deg twin of a pose is the truth's only rival
HALL_SEED = 8
HALL = (10.6, 1.3, 31.2, 26.7)
TRUTH = (16.0, 8.0, 0.5)  # in the hall, its twin (25.8, 20.0) far off


def scan_at(site: Site, site_file: Path, pose: tuple[float, float, float]) -> np.ndarray:
    """One scan rendered by the simulator at ``pose``: the band of walls, not the floor."""
    x, y, theta = pose
    over = [
        f"site={site_file}",
        "sim.start.place=",
        f"sim.start.x={x}",
        f"sim.start.y={y}",
        f"sim.start.theta={theta}",
    ]
    sim = Simulation(load(None, over), site)
    for _ in range(sim.scan_every):
        result = sim.step()
    sim.close()
    return result.scan[np.abs(result.scan[:, 2]) < 0.5]


@pytest.fixture(scope="module")
def hall(tmp_path_factory) -> tuple[Relocaliser, np.ndarray]:
    """The hall's relocaliser and a scan taken at ``TRUTH``."""
    from sim.building_gen import GenOptions, generate_building

    options = GenOptions(floors=(1, 1), missions=1)
    built = generate_building(HALL_SEED, tmp_path_factory.mktemp("b8"), options)
    halls = [s.carve for f in built.plan.floors for s in f.spaces if s.kind == "hall"]
    assert halls == [pytest.approx(HALL)], "the generator no longer draws this hall"
    site_file = built.site_path / "site.yaml"
    site = load_site(site_file)
    return Relocaliser(DistanceField.for_floor(site, "1")), scan_at(site, site_file, TRUTH)


def assert_near_truth(pose, truth=TRUTH) -> None:
    assert math.hypot(pose[0] - truth[0], pose[1] - truth[1]) < 0.05, pose
    assert angle_between(pose[2], truth[2]) < math.radians(1.0), pose


def test_a_kidnapped_chair_is_found(hall) -> None:
    """The chair was carried 2 m and turned 30 deg while it stood: from the pose it had,
    the widening search finds where it is."""
    reloc, scan = hall
    prior = (TRUTH[0] + 2 * math.cos(1.0), TRUTH[1] + 2 * math.sin(1.0), TRUTH[2] + 0.5236)
    result = reloc.relocalise(scan, prior)
    assert result.ok and result.unambiguous and result.settled, result.reason
    assert_near_truth(result.pose)
    assert result.score > 0.9
    assert result.evaluations <= reloc.settings.max_evaluations


def test_a_prior_5_m_off_in_a_hall_is_found_by_widening(hall) -> None:
    """Within 1, 2 and 4 m of the prior nothing matches; at 8 m the truth does, and the
    confirming 16 m search holds the hall's twin pose too, which matches clearly worse."""
    reloc, scan = hall
    prior = (TRUTH[0] + 3.0, TRUTH[1] + 4.0, TRUTH[2] + 0.1)
    for bounds in widening_bounds(reloc.field, prior)[:3]:
        narrow = reloc.search(scan, prior, bounds)
        assert narrow.settled and narrow.score < reloc.settings.min_score, bounds
    result = reloc.relocalise(scan, prior)
    assert result.ok, result.reason
    assert_near_truth(result.pose)
    assert result.bounds.radius_m == 16.0
    assert result.score - result.rival_score > reloc.settings.margin


def write_floor(folder: Path, size, walls) -> tuple[Site, Path]:
    """A one-floor site of ``walls`` (rectangles, metres)."""
    from sim.sitegen import draw, write_map

    site_file = write_map(draw(size, walls), folder, "floor")
    return load_site(site_file), site_file


def test_a_long_corridor_is_ambiguous(tmp_path) -> None:
    """80 m of uniform corridor: its ends are beyond the scan's band, so every place along
    it (and the chair turned round) looks alike; it must not be guessed."""
    site, site_file = write_floor(tmp_path, (80.0, 2.4), [(0, 0, 80, 0.2), (0, 2.2, 80, 2.4)])
    truth = (40.0, 1.1, 0.05)
    reloc = Relocaliser(DistanceField(site.floor("1").map))
    result = reloc.search(scan_at(site, site_file, truth), truth, SearchBounds(3.0, math.pi))
    assert result.settled and not result.unambiguous and not result.ok
    assert result.score > 0.9 and result.rival_score > result.score - 0.1
    assert "ambiguous" in result.reason


def test_a_rectangular_room_is_ambiguous_with_its_twin(tmp_path) -> None:
    """An empty 8 x 5 m room looks the same from a pose and from its half turn about the
    room's centre: searched whole, both match and the result says so."""
    walls = [(0, 0, 8.4, 0.2), (0, 5.2, 8.4, 5.4), (0, 0, 0.2, 5.4), (8.2, 0, 8.4, 5.4)]
    site, site_file = write_floor(tmp_path, (8.4, 5.4), walls)
    truth = (2.5, 1.8, 0.3)
    reloc = Relocaliser(DistanceField(site.floor("1").map))
    whole = widening_bounds(reloc.field, truth)[-1]
    result = reloc.search(scan_at(site, site_file, truth), truth, whole)
    assert result.settled and not result.ok and "ambiguous" in result.reason
    twin = (8.4 - truth[0], 5.4 - truth[1], truth[2] + math.pi)
    poses = [result.pose, result.rival_pose]
    assert any(math.hypot(p[0] - twin[0], p[1] - twin[1]) < 0.05 for p in poses), poses
    assert any(math.hypot(p[0] - truth[0], p[1] - truth[1]) < 0.05 for p in poses), poses


def test_the_budget_bounds_the_search(hall) -> None:
    """A search stops at its budget of evaluations and says the result is not settled (at
    half its need, best first, it holds the truth but has not ruled out rivals); a budget
    below the first level's bounds is refused before any work."""
    reloc, scan = hall
    prior = (TRUTH[0] + 3.0, TRUTH[1] + 4.0, TRUTH[2])
    bounds = SearchBounds(8.0, math.pi)
    full = reloc.search(scan, prior, bounds)
    assert full.ok and full.settled
    for budget in (full.evaluations // 2, full.evaluations // 10):
        cut = reloc.search(scan, prior, bounds, budget=budget)
        assert cut.evaluations <= budget and not cut.settled and not cut.ok
        assert "budget" in cut.reason
    assert_near_truth(reloc.search(scan, prior, bounds, budget=full.evaluations // 2).pose)
    refused = reloc.search(scan, prior, bounds, budget=100)
    assert refused.evaluations == 0 and refused.pose is None and "budget" in refused.reason
    capped = Relocaliser(reloc.field, RelocaliseSettings(max_evaluations=full.evaluations))
    widened = capped.relocalise(scan, prior)  # the widening shares the one budget
    assert widened.evaluations <= full.evaluations and not widened.ok


def test_walls_and_the_world_beyond_the_map_are_never_candidates(hall) -> None:
    reloc, scan = hall
    cells = reloc.candidates(TRUTH, 100.0, None)
    assert cells.any()
    assert (reloc.clearance[cells] >= reloc.settings.clearance_m).all()
    field = reloc.field
    in_wall = (HALL[0] - 0.1, 14.0, 0.0)  # the hall's west wall
    assert field.sample(np.array([in_wall[:2]]))[0][0] < 0
    result = reloc.search(scan, in_wall, SearchBounds(0.1, math.pi))
    assert result.pose is None and "no free cell" in result.reason
    rows, cols = field.field.shape
    beyond = (field.ox + cols * field.res + 5.0, 14.0, 0.0)
    assert reloc.search(scan, beyond, SearchBounds(4.0, math.pi)).pose is None
    allowed = np.zeros_like(field.field, dtype=bool)
    assert not reloc.candidates(TRUTH, 100.0, allowed).any()


def test_a_scan_that_fits_nowhere_is_refused_not_raised(tmp_path) -> None:
    """A ring of points that no place of the room explains (the localisation's warm-up
    searches one at start): one poor hypothesis and no rival is a refusal with its reason
    (it raised AttributeError on the missing rival, and the service never came up)."""
    walls = [(0, 0, 8.4, 0.2), (0, 5.2, 8.4, 5.4), (0, 0, 0.2, 5.4), (8.2, 0, 8.4, 5.4)]
    site, _ = write_floor(tmp_path, (8.4, 5.4), walls)
    reloc = Relocaliser(DistanceField(site.floor("1").map))
    ring = np.linspace(0.0, 2 * math.pi, 64, endpoint=False)
    pts = np.column_stack([1.3 * np.cos(ring), 1.3 * np.sin(ring)])
    result = reloc.search(pts, (4.2, 2.7, 0.0), SearchBounds(0.2, 0.1))
    assert not result.ok and result.reason
