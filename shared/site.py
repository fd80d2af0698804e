"""Sites: a building's floor maps (ROS map_server format) and its doors and named places.

A site is a folder with a ``site.yaml`` (floors, doors, places; see docs/site-format.md)
or a plain map_server YAML; both load into a :class:`Site`. Maps are read exactly as
map_server reads them (trinary, scale or raw mode, ``negate``, thresholds, alpha =
unknown), and stored with row 0 at the bottom so that cell ``(row, col)`` has its centre
at ``origin + ((col + 0.5) * res, (row + 0.5) * res)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from PIL import Image

from shared.config import ConfigError, read_yaml

OCCUPIED, FREE, UNKNOWN = 100, 0, -1
DOOR_TYPES = ("manual", "automatic", "powered")


class SiteError(ConfigError):
    """A site or map file that is missing or malformed (one line, naming file and key)."""


@dataclass
class GridMap:
    """An occupancy grid: int8 cells (100 occupied, 0 free, -1 unknown), row 0 at the bottom."""

    cells: np.ndarray
    resolution: float
    origin: tuple[float, float, float]

    @property
    def shape(self) -> tuple[int, int]:
        return self.cells.shape

    def occupied(self, unknown_is_occupied: bool = True) -> np.ndarray:
        """Boolean obstacle mask (unknown cells count as obstacles unless told otherwise)."""
        occ = self.cells >= 65
        return occ | (self.cells < 0) if unknown_is_occupied else occ

    def to_cell(self, x: float, y: float) -> tuple[int, int]:
        """The (row, col) of the cell holding world point (x, y) (may lie outside the grid)."""
        col = math.floor((x - self.origin[0]) / self.resolution)
        row = math.floor((y - self.origin[1]) / self.resolution)
        return row, col

    def to_world(self, cells: np.ndarray) -> np.ndarray:
        """World (x, y) of cell centres for an (N, 2) array of (row, col)."""
        cells = np.asarray(cells, dtype=float)
        x = self.origin[0] + (cells[:, 1] + 0.5) * self.resolution
        y = self.origin[1] + (cells[:, 0] + 0.5) * self.resolution
        return np.stack([x, y], axis=1)

    def contains(self, row: int, col: int) -> bool:
        return 0 <= row < self.cells.shape[0] and 0 <= col < self.cells.shape[1]


@dataclass
class Door:
    """A door segment from ``p1`` to ``p2`` on ``floor``."""

    id: str
    floor: str
    p1: tuple[float, float]
    p2: tuple[float, float]
    type: str = "manual"


@dataclass
class Place:
    """A named pose goals can refer to."""

    name: str
    floor: str
    x: float
    y: float
    theta: float = 0.0


@dataclass
class Floor:
    name: str
    elevation: float
    map: GridMap
    map_path: Path


@dataclass
class Site:
    """Everything the fleet knows about a building."""

    name: str
    root: Path
    floors: dict[str, Floor]
    doors: list[Door] = field(default_factory=list)
    places: dict[str, Place] = field(default_factory=dict)

    @property
    def default_floor(self) -> str:
        return next(iter(self.floors))

    def floor(self, name: str) -> Floor:
        """The floor called ``name`` ("" means the first); SiteError if there is none."""
        if not name:
            return self.floors[self.default_floor]
        if name not in self.floors:
            raise SiteError(
                f"site {self.name}: no floor {name!r} (floors: {', '.join(self.floors)})"
            )
        return self.floors[name]

    def start_pose(
        self, place: str, x: float, y: float, theta: float, floor: str
    ) -> tuple[float, float, float, str]:
        """(x, y, theta, floor) of the named ``place``, or of the given pose if it is empty."""
        if place:
            p = self.place(place)
            return p.x, p.y, p.theta, p.floor
        return x, y, theta, self.floor(floor).name

    def place(self, name: str) -> Place:
        if name not in self.places:
            known = ", ".join(self.places) or "none"
            raise SiteError(f"site {self.name}: no place {name!r} (places: {known})")
        return self.places[name]


# --------------------------------------------------------------------------------------
# Loading
# --------------------------------------------------------------------------------------


def load_map(yaml_path: str | Path) -> GridMap:
    """Load a map_server map (YAML + PGM/PNG image) exactly as map_server interprets it."""
    yaml_path = Path(yaml_path)
    meta = read_yaml(yaml_path)
    for key in ("image", "resolution", "origin"):
        if key not in meta:
            raise SiteError(f"{yaml_path}: missing key {key!r}")
    known = {"image", "resolution", "origin", "negate", "occupied_thresh", "free_thresh", "mode"}
    unknown = sorted(set(meta) - known)
    if unknown:
        raise SiteError(f"{yaml_path}: unknown key {unknown[0]!r}")
    res = meta["resolution"]
    if not isinstance(res, int | float) or res <= 0:
        raise SiteError(f"{yaml_path}: resolution must be > 0, got {res!r}")
    origin = meta["origin"]
    if not (isinstance(origin, list) and len(origin) == 3):
        raise SiteError(f"{yaml_path}: origin must be [x, y, yaw], got {origin!r}")
    mode = meta.get("mode", "trinary")
    if mode not in ("trinary", "scale", "raw"):
        raise SiteError(f"{yaml_path}: mode must be trinary, scale or raw, got {mode!r}")
    occ_th = float(meta.get("occupied_thresh", 0.65))
    free_th = float(meta.get("free_thresh", 0.196))
    negate = bool(meta.get("negate", 0))
    image_path = (yaml_path.parent / meta["image"]).resolve()
    if not image_path.is_file():
        raise SiteError(f"{yaml_path}: image {meta['image']!r} not found at {image_path}")
    try:
        img = Image.open(image_path)
        img.load()
    except Exception as exc:
        raise SiteError(f"{image_path}: cannot read image ({exc})") from None
    cells = _interpret(img, mode, negate, occ_th, free_th)
    return GridMap(np.flipud(cells).copy(), float(res), tuple(float(v) for v in origin))


def _interpret(
    img: Image.Image, mode: str, negate: bool, occ_th: float, free_th: float
) -> np.ndarray:
    """map_server's pixel rule: mean of the colour channels, alpha 0 = unknown."""
    arr = np.asarray(img)
    alpha = None
    if arr.ndim == 3:
        if img.mode in ("LA", "RGBA"):
            alpha = arr[..., -1]
            arr = arr[..., :-1]
        arr = arr.mean(axis=2)
    arr = arr.astype(np.float64)
    if mode == "raw":
        cells = np.clip(arr, -128, 127).astype(np.int8)
        return cells
    occ = arr / 255.0 if negate else (255.0 - arr) / 255.0
    cells = np.full(arr.shape, UNKNOWN, dtype=np.int8)
    cells[occ > occ_th] = OCCUPIED
    cells[occ < free_th] = FREE
    if mode == "scale":
        mid = (occ >= free_th) & (occ <= occ_th)
        cells[mid] = np.rint(99 * (occ[mid] - free_th) / (occ_th - free_th)).astype(np.int8)
    if alpha is not None:
        cells[alpha == 0] = UNKNOWN
    return cells


def load_site(path: str | Path) -> Site:
    """Load a site folder (with site.yaml), a site.yaml, or a plain map_server YAML."""
    path = Path(path)
    if path.is_dir():
        path = path / "site.yaml"
        if not path.is_file():
            raise SiteError(f"{path.parent}: no site.yaml in this folder")
    if not path.is_file():
        raise SiteError(f"{path}: no such site or map file")
    data = read_yaml(path)
    if "image" in data:
        grid = load_map(path)
        floor = Floor("1", 0.0, grid, path)
        return Site(path.stem, path.parent, {"1": floor})
    return _parse_site(path, data)


def _parse_site(path: Path, data: dict) -> Site:
    known = {"name", "floors", "doors", "places", "elevators"}
    unknown = sorted(set(data) - known)
    if unknown:
        raise SiteError(f"{path}: unknown key {unknown[0]!r} (known: {', '.join(sorted(known))})")
    floors: dict[str, Floor] = {}
    for i, f in enumerate(data.get("floors") or []):
        where = f"{path}: floors[{i}]"
        name = str(_need(f, "name", where))
        map_path = path.parent / str(_need(f, "map", where))
        floors[name] = Floor(name, float(f.get("elevation", 0.0)), load_map(map_path), map_path)
    if not floors:
        raise SiteError(f"{path}: no floors")
    first = next(iter(floors))
    doors = []
    for i, d in enumerate(data.get("doors") or []):
        where = f"{path}: doors[{i}]"
        kind = d.get("type", "manual")
        if kind not in DOOR_TYPES:
            raise SiteError(f"{where}.type: must be one of {', '.join(DOOR_TYPES)}, got {kind!r}")
        floor = str(d.get("floor", first))
        if floor not in floors:
            raise SiteError(f"{where}.floor: no floor {floor!r}")
        p1, p2 = (
            _point(_need(d, "p1", where), f"{where}.p1"),
            _point(_need(d, "p2", where), f"{where}.p2"),
        )
        doors.append(Door(str(_need(d, "id", where)), floor, p1, p2, kind))
    places = {}
    for name, p in (data.get("places") or {}).items():
        where = f"{path}: places.{name}"
        floor = str(p.get("floor", first))
        if floor not in floors:
            raise SiteError(f"{where}.floor: no floor {floor!r}")
        places[str(name)] = Place(
            str(name),
            floor,
            float(_need(p, "x", where)),
            float(_need(p, "y", where)),
            float(p.get("theta", 0.0)),
        )
    return Site(str(data.get("name", path.parent.name)), path.parent, floors, doors, places)


def _need(d: dict, key: str, where: str):
    if not isinstance(d, dict) or key not in d:
        raise SiteError(f"{where}: missing key {key!r}")
    return d[key]


def _point(value, where: str) -> tuple[float, float]:
    if not (isinstance(value, list) and len(value) == 2):
        raise SiteError(f"{where}: expected [x, y], got {value!r}")
    return float(value[0]), float(value[1])
