"""Sites and maps: map_server's pixel rules, site.yaml, and one-line errors."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from shared.site import FREE, OCCUPIED, UNKNOWN, SiteError, load_map, load_site
from tests.conftest import ROOT


def write_map(folder: Path, pixels: np.ndarray, **meta) -> Path:
    Image.fromarray(pixels.astype(np.uint8)).save(folder / "m.pgm")
    lines = {
        "image": "m.pgm",
        "resolution": 0.1,
        "origin": [1.0, 2.0, 0.0],
        "negate": 0,
        "occupied_thresh": 0.65,
        "free_thresh": 0.196,
        **meta,
    }
    text = "\n".join(f"{k}: {v}" for k, v in lines.items())
    (folder / "m.yaml").write_text(text + "\n")
    return folder / "m.yaml"


def test_trinary_rule_and_orientation(tmp_path: Path) -> None:
    # top image row = largest y; black = occupied, white = free, mid grey = unknown
    pixels = np.array([[0, 254, 205], [254, 254, 254]])
    grid = load_map(write_map(tmp_path, pixels))
    assert grid.cells.shape == (2, 3)
    assert grid.cells[1].tolist() == [OCCUPIED, FREE, UNKNOWN]  # image top row -> row 1
    assert grid.cells[0].tolist() == [FREE, FREE, FREE]
    assert grid.to_cell(1.05, 2.15) == (1, 0)
    assert np.allclose(grid.to_world(np.array([[1, 0]])), [[1.05, 2.15]])


def test_negate(tmp_path: Path) -> None:
    grid = load_map(write_map(tmp_path, np.array([[0, 254]]), negate=1))
    assert grid.cells[0].tolist() == [FREE, OCCUPIED]


def test_plain_map_yaml_is_a_site(tmp_path: Path) -> None:
    site = load_site(write_map(tmp_path, np.full((4, 4), 254)))
    assert list(site.floors) == ["1"]


def test_bundled_site_loads() -> None:
    site = load_site(ROOT / "sites" / "two_rooms")
    assert site.place("room_b").x == 10.5
    assert site.doors[0].id == "door_ab"
    grid = site.floor("1").map
    r, c = grid.to_cell(6.2, 2.7)
    assert grid.cells[r, c] == FREE  # the doorway is open
    r, c = grid.to_cell(6.2, 1.0)
    assert grid.cells[r, c] == OCCUPIED


@pytest.mark.parametrize(
    ("content", "message"),
    [
        ("resolution: 0.1\norigin: [0, 0, 0]\n", "missing key 'image'"),
        ("image: nope.pgm\nresolution: 0.1\norigin: [0, 0, 0]\n", "image 'nope.pgm' not found"),
        ("image: m.pgm\nresolution: -1\norigin: [0, 0, 0]\n", "resolution must be > 0"),
        ("image: m.pgm\nresolution: 0.1\norigin: [0, 0]\n", "origin must be"),
        ("image: m.pgm\nresolution: 0.1\norigin: [0, 0, 0]\ncolour: red\n", "unknown key 'colour'"),
    ],
)
def test_bad_maps(tmp_path: Path, content: str, message: str) -> None:
    Image.fromarray(np.full((2, 2), 254, np.uint8)).save(tmp_path / "m.pgm")
    (tmp_path / "m.yaml").write_text(content)
    with pytest.raises(SiteError, match=message):
        load_map(tmp_path / "m.yaml")


def test_missing_site(tmp_path: Path) -> None:
    with pytest.raises(SiteError, match="no site.yaml"):
        load_site(tmp_path)
    with pytest.raises(SiteError, match="no such site"):
        load_site(tmp_path / "x.yaml")
