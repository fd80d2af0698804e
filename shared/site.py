"""Sites: a building's floor maps (ROS map_server format), doors, elevators and named places.

A site is a folder with a ``site.yaml`` (floors, doors, places, elevators; see
docs/site-format.md)
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


DEFAULT_LEAF_THICKNESS_M = 0.05  # a door leaf, when the site does not say


@dataclass
class Door:
    """A door segment from ``p1`` to ``p2`` on ``floor``."""

    id: str
    floor: str
    p1: tuple[float, float]
    p2: tuple[float, float]
    type: str = "manual"
    motion: str = "sliding"  # how the leaf moves: "hinged" or "sliding"
    swing: str = "left"  # a hinged leaf turns about p1 towards this side of p1 -> p2
    controller: bool = True  # the building reports this door's state (and opens it if powered)
    leaf_thickness_m: float = DEFAULT_LEAF_THICKNESS_M

    @property
    def width_m(self) -> float:
        """The opening's width: the distance from p1 to p2."""
        return math.hypot(self.p2[0] - self.p1[0], self.p2[1] - self.p1[1])

    @property
    def clear_width_m(self) -> float:
        """The opening's free width: a hinged leaf standing open at its hinge (``p1``) has
        half its thickness inside the opening."""
        if self.motion != "hinged":
            return self.width_m
        return self.width_m - self.leaf_thickness_m / 2

    @property
    def pass_centre(self) -> tuple[float, float]:
        """The middle of the free opening (:attr:`clear_width_m`), where a pass crosses: a
        quarter of a hinged leaf's thickness from the segment's middle towards ``p2``."""
        mx, my = (self.p1[0] + self.p2[0]) / 2, (self.p1[1] + self.p2[1]) / 2
        if self.motion != "hinged":
            return mx, my
        w, shift = self.width_m, self.leaf_thickness_m / 4
        return mx + (self.p2[0] - self.p1[0]) / w * shift, my + (
            self.p2[1] - self.p1[1]
        ) / w * shift

    def open_leaf(self) -> tuple[tuple[float, float], tuple[float, float]] | None:
        """A hinged leaf opened fully (90 degrees about ``p1``, to its ``swing`` side) as a
        segment from the hinge to its tip; None for a sliding door. Maps draw the opening
        free, yet an open leaf stands there like a short wall."""
        if self.motion != "hinged":
            return None
        w = self.width_m
        ux, uy = (self.p2[0] - self.p1[0]) / w, (self.p2[1] - self.p1[1]) / w
        side = -1.0 if self.swing == "right" else 1.0
        tip = (self.p1[0] - side * uy * w, self.p1[1] + side * ux * w)
        return self.p1, tip


@dataclass
class Place:
    """A named pose goals can refer to."""

    name: str
    floor: str
    x: float
    y: float
    theta: float = 0.0


Segment = tuple[tuple[float, float], tuple[float, float]]


@dataclass
class Elevator:
    """A lift car: its centre and size on the map and its door segment on each floor served.

    ``theta`` is the heading that points out of the car through its door; the car has the
    same ``x, y`` on every floor it serves.
    """

    id: str
    floors: list[str]
    x: float
    y: float
    theta: float
    width: float
    depth: float
    doors: dict[str, Segment]

    def serves(self, floor: str) -> bool:
        return floor in self.floors

    def door(self, floor: str) -> Segment:
        """The car door segment (p1, p2) on ``floor``; SiteError if the lift does not stop there."""
        if floor not in self.doors:
            raise SiteError(
                f"elevator {self.id}: does not serve floor {floor!r} "
                f"(floors: {', '.join(self.floors)})"
            )
        return self.doors[floor]

    def door_centre(self, floor: str) -> tuple[float, float]:
        """Middle of the car door segment on ``floor``."""
        (x1, y1), (x2, y2) = self.door(floor)
        return (x1 + x2) / 2.0, (y1 + y2) / 2.0

    def door_normal(self, floor: str) -> tuple[float, float]:
        """Unit normal of the car door on ``floor``, pointing out of the car."""
        (x1, y1), (x2, y2) = self.door(floor)
        length = math.hypot(x2 - x1, y2 - y1)
        nx, ny = -(y2 - y1) / length, (x2 - x1) / length
        cx, cy = self.door_centre(floor)
        side = (cx - self.x) * nx + (cy - self.y) * ny
        if abs(side) < 1e-9:  # car centre on the door line: trust theta
            side = math.cos(self.theta) * nx + math.sin(self.theta) * ny
        return (nx, ny) if side >= 0 else (-nx, -ny)

    def entry_pose(self, floor: str, standoff_m: float = 1.0) -> tuple[float, float, float]:
        """The pose ``standoff_m`` outside the car door on its normal, facing into the car."""
        cx, cy = self.door_centre(floor)
        nx, ny = self.door_normal(floor)
        return cx + nx * standoff_m, cy + ny * standoff_m, math.atan2(-ny, -nx)

    def inside_pose(self) -> tuple[float, float, float]:
        """The car centre, facing out through the door."""
        return self.x, self.y, self.theta


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
    elevators: list[Elevator] = field(default_factory=list)

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

    def elevator(self, id: str) -> Elevator:
        """The elevator called ``id``; SiteError if there is none."""
        for lift in self.elevators:
            if lift.id == id:
                return lift
        known = ", ".join(lift.id for lift in self.elevators) or "none"
        raise SiteError(f"site {self.name}: no elevator {id!r} (elevators: {known})")


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
    yaw = origin[2]
    if isinstance(yaw, bool) or not isinstance(yaw, int | float) or not math.isfinite(yaw):
        raise SiteError(f"{yaml_path}: origin yaw must be a finite number (radians), got {yaw!r}")
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
    grid = GridMap(np.flipud(cells).copy(), float(res), tuple(float(v) for v in origin))
    return grid if yaw == 0 else _unrotate(grid)


# A yaw this close to a multiple of 90 degrees (no pixel moves by more than this many cells
# between the two) is taken as that multiple and resampled exactly with np.rot90.
_QUARTER_TURN_TOL_CELLS = 0.01
_RESAMPLE_CHUNK_ROWS = 256


def _unrotate(grid: GridMap) -> GridMap:
    """``grid`` (whose origin has a yaw) resampled to an axis-aligned grid in the map frame.

    map_server's ``origin`` is the pose of the image's lower-left corner, the image rotated
    counter-clockwise by yaw about it. The result covers the rotated image's bounding box at
    the same resolution; each cell takes the value of the source cell its centre falls in
    (nearest neighbour), cells outside the image are UNKNOWN, and the origin's yaw is 0.
    """
    ox, oy, yaw = grid.origin
    res = grid.resolution
    src = grid.cells
    h, w = src.shape
    quarter = round(yaw / (math.pi / 2))
    if abs(yaw - quarter * math.pi / 2) * math.hypot(h, w) <= _QUARTER_TURN_TOL_CELLS:
        # exact: np.rot90 turns clockwise as printed (row 0 on top); our row 0 is at the
        # bottom, so k=-q is a counter-clockwise turn in the map frame
        q = quarter % 4
        cells = np.ascontiguousarray(np.rot90(src, k=-q))
        # lower-left corner of the turned image, in cells from (ox, oy)
        ddx, ddy = ((0, 0), (-h, 0), (-w, -h), (0, -w))[q]
        return GridMap(cells, res, (ox + ddx * res, oy + ddy * res, 0.0))

    c, s = math.cos(yaw), math.sin(yaw)
    # image corners in the image frame, rotated about the lower-left corner
    corners = [(u * w * res, v * h * res) for u in (0, 1) for v in (0, 1)]
    xs = [c * u - s * v for u, v in corners]
    ys = [s * u + c * v for u, v in corners]
    dx0, dy0 = min(xs), min(ys)  # bounding-box corner relative to (ox, oy)
    # tolerate rounding when an extent is (almost) a whole number of cells
    cols = max(1, math.ceil((max(xs) - dx0) / res - 1e-6))
    rows = max(1, math.ceil((max(ys) - dy0) / res - 1e-6))
    out = np.full((rows, cols), UNKNOWN, dtype=src.dtype)
    dx = dx0 + (np.arange(cols) + 0.5) * res  # cell centres relative to (ox, oy)
    for r0 in range(0, rows, _RESAMPLE_CHUNK_ROWS):
        r1 = min(rows, r0 + _RESAMPLE_CHUNK_ROWS)
        dy = (dy0 + (np.arange(r0, r1) + 0.5) * res)[:, None]
        # rotate back by -yaw into the image frame, then find the source cell
        j = np.floor((c * dx + s * dy) / res).astype(np.int64)
        i = np.floor((-s * dx + c * dy) / res).astype(np.int64)
        inside = (i >= 0) & (i < h) & (j >= 0) & (j < w)
        out[r0:r1][inside] = src[i[inside], j[inside]]
    return GridMap(out, res, (ox + dx0, oy + dy0, 0.0))


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
        door_id = str(_need(d, "id", where))
        if any(door.id == door_id for door in doors):
            raise SiteError(f"{where}.id: duplicate door id {door_id!r}")
        _no_unknown(d, _DOOR_KEYS, where)
        motion = _choice(d, "motion", DOOR_MOTIONS, where)
        swing = _choice(d, "swing", DOOR_SWINGS, where)
        controller = d.get("controller", True)
        if not isinstance(controller, bool):
            raise SiteError(f"{where}.controller: must be true or false, got {controller!r}")
        thickness = _number(d.get("leaf_thickness_m", DEFAULT_LEAF_THICKNESS_M), where)
        width = math.hypot(p2[0] - p1[0], p2[1] - p1[1])
        if not 0 < thickness < width / 4:
            raise SiteError(
                f"{where}.leaf_thickness_m: must be > 0 and under a quarter of the door's "
                f"width ({width / 4:.3f} m), got {thickness!r}"
            )
        doors.append(Door(door_id, floor, p1, p2, kind, motion, swing, controller, thickness))
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
    elevators = _parse_elevators(path, data.get("elevators"), floors)
    name = str(data.get("name", path.parent.name))
    return Site(name, path.parent, floors, doors, places, elevators)


_DOOR_KEYS = (
    "id",
    "floor",
    "p1",
    "p2",
    "type",
    "motion",
    "swing",
    "controller",
    "leaf_thickness_m",
)
DOOR_MOTIONS = ("sliding", "hinged")  # the first is the default
DOOR_SWINGS = ("left", "right")


def _choice(d: dict, key: str, allowed: tuple[str, ...], where: str) -> str:
    """``d[key]`` if it is one of ``allowed``, ``allowed[0]`` when absent; SiteError otherwise."""
    value = d.get(key, allowed[0])
    if value not in allowed:
        raise SiteError(f"{where}.{key}: must be one of {', '.join(allowed)}, got {value!r}")
    return str(value)


_ELEVATOR_KEYS = ("id", "floors", "car", "doors")
_CAR_KEYS = ("x", "y", "theta", "width", "depth")


def _parse_elevators(path: Path, raw, floors: dict[str, Floor]) -> list[Elevator]:
    """The ``elevators:`` list, checked against the site's floors."""
    if raw is None:
        return []
    if not isinstance(raw, list):
        raise SiteError(f"{path}: elevators: expected a list, got {type(raw).__name__}")
    lifts: list[Elevator] = []
    for i, e in enumerate(raw):
        where = f"{path}: elevators[{i}]"
        if not isinstance(e, dict):
            raise SiteError(f"{where}: expected a mapping, got {e!r}")
        _no_unknown(e, _ELEVATOR_KEYS, where)
        lift_id = str(_need(e, "id", where))
        if any(lift.id == lift_id for lift in lifts):
            raise SiteError(f"{where}.id: duplicate elevator id {lift_id!r}")
        served = _need(e, "floors", where)
        if not isinstance(served, list) or not served:
            raise SiteError(f"{where}.floors: expected a non-empty list, got {served!r}")
        served = [str(f) for f in served]
        for f in served:
            if f not in floors:
                raise SiteError(f"{where}.floors: no floor {f!r}")
        if len(set(served)) != len(served):
            raise SiteError(f"{where}.floors: a floor is listed twice in {served}")
        car = _need(e, "car", where)
        if not isinstance(car, dict):
            raise SiteError(f"{where}.car: expected a mapping, got {car!r}")
        _no_unknown(car, _CAR_KEYS, f"{where}.car")
        x, y = (_number(_need(car, k, f"{where}.car"), f"{where}.car.{k}") for k in ("x", "y"))
        theta = _number(car.get("theta", 0.0), f"{where}.car.theta")
        width, depth = (
            _number(_need(car, k, f"{where}.car"), f"{where}.car.{k}") for k in ("width", "depth")
        )
        for key, value in (("width", width), ("depth", depth)):
            if value <= 0:
                raise SiteError(f"{where}.car.{key}: must be > 0, got {value!r}")
        doors = _need(e, "doors", where)
        if not isinstance(doors, dict):
            raise SiteError(f"{where}.doors: expected a mapping floor -> {{p1, p2}}")
        segments: dict[str, Segment] = {}
        for f, d in doors.items():
            dwhere = f"{where}.doors.{f}"
            if str(f) not in served:
                raise SiteError(f"{dwhere}: elevator {lift_id} does not serve floor {str(f)!r}")
            if not isinstance(d, dict):
                raise SiteError(f"{dwhere}: expected {{p1: [x, y], p2: [x, y]}}, got {d!r}")
            _no_unknown(d, ("p1", "p2"), dwhere)
            p1 = _point(_need(d, "p1", dwhere), f"{dwhere}.p1")
            p2 = _point(_need(d, "p2", dwhere), f"{dwhere}.p2")
            if p1 == p2:
                raise SiteError(f"{dwhere}: p1 and p2 are the same point {list(p1)}")
            segments[str(f)] = (p1, p2)
        for f in served:
            if f not in segments:
                raise SiteError(f"{where}.doors: no door for served floor {f!r}")
        lifts.append(Elevator(lift_id, served, x, y, theta, width, depth, segments))
    return lifts


def _no_unknown(d: dict, known: tuple[str, ...], where: str) -> None:
    unknown = sorted(str(k) for k in set(d) - set(known))
    if unknown:
        raise SiteError(f"{where}: unknown key {unknown[0]!r} (known: {', '.join(known)})")


def _number(value, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise SiteError(f"{where}: expected a number, got {value!r}")
    return float(value)


def _need(d: dict, key: str, where: str):
    if not isinstance(d, dict) or key not in d:
        raise SiteError(f"{where}: missing key {key!r}")
    return d[key]


def _point(value, where: str) -> tuple[float, float]:
    if not (isinstance(value, list) and len(value) == 2):
        raise SiteError(f"{where}: expected [x, y], got {value!r}")
    return float(value[0]), float(value[1])
