"""``wheelnav plan`` and ``wheelnav rooms``: JSON fields, negative coordinates, one-line
errors with status 2, and pictures whose known pixels have the documented colours."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from shared.site import GridMap, load_site
from sim.sitegen import draw, write_map
from wheelnav.cli import main
from wheelnav.maptools import pictures
from wheelnav.maptools.cli import join_negative_values

ROOT = Path(__file__).resolve().parents[2]
TWO_ROOMS = str(ROOT / "sites" / "two_rooms")
ROOM_A, ROOM_B = "2.0,2.7", "10.5,2.7"


def run(capsys: pytest.CaptureFixture, *args: str) -> tuple[int, str, str]:
    """``wheelnav ARGS`` in process: (status, stdout, stderr)."""
    code = main(list(args))
    out, err = capsys.readouterr()
    return code, out, err


def run_json(capsys: pytest.CaptureFixture, *args: str) -> tuple[int, dict]:
    code, out, _err = run(capsys, *args, "--json")
    return code, json.loads(out)


@pytest.fixture(scope="module")
def negative_map(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A 12 m x 10 m room at origin (-10, -5) with a wall from its bottom to y = -1."""
    w, h, t = 12.0, 10.0, 0.2
    walls = [(0, 0, w, t), (0, h - t, w, h), (0, 0, t, h), (w - t, 0, w, h), (6.0, 0, 6.2, 4.0)]
    folder = tmp_path_factory.mktemp("negative")
    return write_map(draw((w, h), walls), folder, "floor", origin=(-10.0, -5.0, 0.0))


@pytest.fixture(scope="module")
def closed_rooms(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Two 5 m x 5 m rooms with a full wall between them: no route from one to the other."""
    w, h, t = 10.0, 5.0, 0.2
    walls = [(0, 0, w, t), (0, h - t, w, h), (0, 0, t, h), (w - t, 0, w, h), (4.9, 0, 5.1, h)]
    return write_map(draw((w, h), walls), tmp_path_factory.mktemp("closed"), "floor")


def test_plan_json_between_two_rooms_passes_the_door(capsys: pytest.CaptureFixture) -> None:
    code, out = run_json(capsys, "plan", TWO_ROOMS, "--start", ROOM_A, "--goal", ROOM_B)
    assert code == 0 and out["ok"] is True
    path = np.array(out["path"])
    assert path.ndim == 2 and path.shape[1] == 2
    assert np.allclose(path[0], (2.0, 2.7), atol=0.05)
    assert np.allclose(path[-1], (10.5, 2.7), atol=0.05)
    assert out["length_m"] > 8.0
    assert math.isclose(
        out["length_m"], np.linalg.norm(np.diff(path, axis=0), axis=1).sum(), abs_tol=0.01
    )
    assert len(out["waypoints"]) == len(out["v_ref"]) >= 2
    assert all(isinstance(v, float | int) for v in out["v_ref"]) and out["v_ref"][-1] == 0
    assert isinstance(out["plan_ms"], float | int) and out["plan_ms"] >= 0
    (door,) = [cp for cp in out["checkpoints"] if cp["id"] == "door_ab"]
    assert door["kind"] == "door"
    assert np.allclose(door["center"], (6.2, 2.7), atol=0.01)
    assert door["approach"][0] < 6.2 < door["exit"][0]  # passed from room_a to room_b
    assert out["radius_m"] == pytest.approx(0.375)  # the chair's: 0.65 / 2 + 0.05


def test_plan_text_names_the_door(capsys: pytest.CaptureFixture) -> None:
    code, out, err = run(capsys, "plan", TWO_ROOMS, "--start", ROOM_A, "--goal", ROOM_B)
    assert code == 0 and err == ""
    assert "door door_ab" in out and "8.50 m" in out


def test_negative_coordinates_in_either_spelling(
    capsys: pytest.CaptureFixture, negative_map: Path
) -> None:
    for start in (["--start", "-8,-3"], ["--start=-8,-3"]):
        code, out = run_json(capsys, "plan", str(negative_map), *start, "--goal", "-1.5,-3.5")
        assert code == 0, out
        assert out["path"][0] == [-8.0, -3.0] and out["path"][-1] == [-1.5, -3.5]
        assert out["length_m"] > math.dist((-8, -3), (-1.5, -3.5))  # round the wall's end


def test_join_negative_values_only_joins_coordinate_options() -> None:
    args = ["plan", "m.yaml", "--start", "-6.5,3", "--goal", "-.5,-2", "--floor", "-1", "--json"]
    assert join_negative_values(args) == [
        "plan",
        "m.yaml",
        "--start=-6.5,3",
        "--goal=-.5,-2",
        "--floor",
        "-1",
        "--json",
    ]


def test_repeat_times_the_plan_n_times(capsys: pytest.CaptureFixture) -> None:
    args = ("plan", TWO_ROOMS, "--start", ROOM_A, "--goal", ROOM_B, "--repeat", "3")
    code, out = run_json(capsys, *args)
    assert code == 0
    assert isinstance(out["plan_ms"], list) and len(out["plan_ms"]) == 3
    assert all(isinstance(t, float | int) and t >= 0 for t in out["plan_ms"])


def test_radius_sets_the_inflation(capsys: pytest.CaptureFixture) -> None:
    args = ("plan", TWO_ROOMS, "--start", ROOM_A, "--goal", ROOM_B)
    code, out = run_json(capsys, *args, "--radius", "0.45")
    assert code == 0 and out["radius_m"] == pytest.approx(0.45)
    code, out = run_json(capsys, *args, "--radius", "0.6")  # 1.2 m: wider than the door
    assert code == 2 and out["ok"] is False and "no path" in out["error"]


def _errors(closed_rooms: Path) -> dict[str, tuple[list[str], str]]:
    return {
        "missing file": (["plan", "no/such/site", "--start", "1,1", "--goal", "2,2"], "no such"),
        "start in a wall": (
            ["plan", TWO_ROOMS, "--start", "6.2,1.0", "--goal", ROOM_B],
            "start (6.20, 1.00) is inside an obstacle; nearest free cell (",
        ),
        "goal outside": (
            ["plan", TWO_ROOMS, "--start", ROOM_A, "--goal", "50,2"],
            "goal (50.00, 2.00) is outside the map",
        ),
        "no route": (
            ["plan", str(closed_rooms), "--start", "2,2.5", "--goal", "8,2.5"],
            "no path from (2.00, 2.50) to (8.00, 2.50)",
        ),
        "bad coordinates": (["plan", TWO_ROOMS, "--start", "2;3", "--goal", ROOM_B], "X,Y"),
        "unknown floor": (
            ["plan", TWO_ROOMS, "--start", ROOM_A, "--goal", ROOM_B, "--floor", "9"],
            "no floor '9'",
        ),
        "radius not > 0": (
            ["plan", TWO_ROOMS, "--start", ROOM_A, "--goal", ROOM_B, "--radius", "-1"],
            "radius",
        ),
        "rooms: missing file": (["rooms", "no/such/site"], "no such"),
        "rooms: unknown floor": (["rooms", TWO_ROOMS, "--floor", "9"], "no floor '9'"),
    }


@pytest.mark.parametrize(
    "case",
    [
        "missing file",
        "start in a wall",
        "goal outside",
        "no route",
        "bad coordinates",
        "unknown floor",
        "radius not > 0",
        "rooms: missing file",
        "rooms: unknown floor",
    ],
)
def test_errors_are_one_line_and_status_2(
    capsys: pytest.CaptureFixture, closed_rooms: Path, case: str
) -> None:
    args, words = _errors(closed_rooms)[case]
    code, out, err = run(capsys, *args)
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and words in err and "Traceback" not in err
    code, out, _err = run(capsys, *args, "--json")
    assert code == 2
    reply = json.loads(out)
    assert reply["ok"] is False and words in reply["error"]


def test_named_free_cell_is_free(capsys: pytest.CaptureFixture) -> None:
    _code, reply = run_json(capsys, "plan", TWO_ROOMS, "--start", "0.1,2.7", "--goal", ROOM_B)
    free = reply["error"].split("nearest free cell (")[1].rstrip(")")
    code, out = run_json(
        capsys, "plan", TWO_ROOMS, "--start", free.replace(" ", ""), "--goal", ROOM_B
    )
    assert code == 0 and out["ok"] is True


def test_no_traceback_from_the_command(closed_rooms: Path) -> None:
    code = "import sys; from wheelnav.cli import main; sys.exit(main())"
    args = ["plan", str(closed_rooms), "--start", "-2,2.5", "--goal", "8,2.5"]
    done = subprocess.run(
        [sys.executable, "-c", code, *args], cwd=ROOT, capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 2
    assert "Traceback" not in done.stderr and done.stderr.count("\n") == 1
    assert "start (-2.00, 2.50) is outside the map" in done.stderr


def test_rooms_json_on_two_rooms(capsys: pytest.CaptureFixture) -> None:
    code, out = run_json(capsys, "rooms", TWO_ROOMS)
    assert code == 0 and out["ok"] is True
    assert len(out["rooms"]) >= 2
    for room in out["rooms"]:
        assert {"id", "centroid", "area_m2"} <= set(room) and room["area_m2"] > 0
    (door,) = [d for d in out["doors"] if math.dist(d["center"], (6.2, 2.7)) < 0.2]
    assert door["id"] == "door_ab"
    assert door["width_m"] == pytest.approx(1.0, abs=0.1)
    assert math.hypot(*door["normal"]) == pytest.approx(1.0)
    assert abs(door["normal"][0]) == pytest.approx(1.0)
    assert len(door["rooms"]) == 2 and door["rooms"][0] != door["rooms"][1]
    centroids = {r["id"]: r["centroid"] for r in out["rooms"]}
    a, b = (centroids[r] for r in door["rooms"])
    assert np.dot(np.subtract(b, a), door["normal"]) > 0  # from its first room to its second


def _pixel(image: Image.Image, grid: GridMap, xy) -> tuple[int, int, int]:
    """The colour at the middle of the picture block of the cell holding ``xy`` (north up,
    ``SCALE`` pixels per cell)."""
    s = pictures.SCALE
    row, col = grid.to_cell(float(xy[0]), float(xy[1]))
    rows = image.height // s
    return image.getpixel((col * s + s // 2, (rows - 1 - row) * s + s // 2))


def test_plan_png_walls_inflation_and_path(capsys: pytest.CaptureFixture, tmp_path: Path) -> None:
    png = tmp_path / "plan.png"
    args = ("plan", TWO_ROOMS, "--start", "2,1.5", "--goal", ROOM_B, "--png", str(png))
    code, out = run_json(capsys, *args)
    assert code == 0 and out["png_scale"] == pictures.SCALE
    grid = load_site(TWO_ROOMS).floor("").map
    image = Image.open(png).convert("RGB")
    assert image.size == (grid.shape[1] * pictures.SCALE, grid.shape[0] * pictures.SCALE)
    assert _pixel(image, grid, (0.05, 0.05)) == pictures.WALL  # the outer wall's corner
    assert _pixel(image, grid, (6.2, 1.0)) == pictures.WALL  # the wall between the rooms
    assert (
        _pixel(image, grid, (0.35, 4.0)) == pictures.INFLATED
    )  # free, within 0.375 m of the west wall
    assert _pixel(image, grid, (3.0, 4.5)) == pictures.FREE
    path = np.array(out["path"])
    for a, b in zip(path[:-1], path[1:], strict=True):
        for t in (0.0, 0.3, 0.5, 0.9, 1.0):
            assert _pixel(image, grid, a + (b - a) * t) == pictures.PATH


def test_rooms_png_colours_each_room(capsys: pytest.CaptureFixture, tmp_path: Path) -> None:
    png = tmp_path / "rooms.png"
    code, _out = run_json(capsys, "rooms", TWO_ROOMS, "--png", str(png))
    assert code == 0
    grid = load_site(TWO_ROOMS).floor("").map
    image = Image.open(png).convert("RGB")
    room_a, room_b = _pixel(image, grid, (2.0, 2.7)), _pixel(image, grid, (10.5, 2.7))
    assert room_a != room_b
    assert pictures.WALL not in (room_a, room_b) and pictures.FREE not in (room_a, room_b)
    assert _pixel(image, grid, (3.0, 4.0)) == room_a and _pixel(image, grid, (11.0, 1.0)) == room_b
    assert _pixel(image, grid, (6.2, 1.0)) == pictures.WALL
    assert _pixel(image, grid, (6.2, 2.7)) == pictures.DOOR
