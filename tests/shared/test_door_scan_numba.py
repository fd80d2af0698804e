"""The compiled doorway finder against its numpy reference, on scans of drawn rooms.

Random walls with a doorway of random width (some with a hinged leaf standing open at a
random angle, a closed leaf behind the face, or a post in the gap), range noise and
random sensor places: the two find the same doorways (count, order, open, reveal seen)
with every coordinate within 1e-9 m, and the same stretches.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from shared import door_scan_numba
from shared.config import DoorScanConfig
from shared.door_scan import find_doorways, find_doorways_numpy, planar_scan, segment

Segment = tuple[tuple[float, float], tuple[float, float]]


def cast(walls: list[Segment], rng: np.random.Generator, n: int = 1440) -> np.ndarray:
    """A planar scan from the origin: the nearest hit per beam, 1 cm of range noise."""
    a = np.linspace(-np.pi, np.pi, n, endpoint=False)
    d = np.stack([np.cos(a), np.sin(a)], axis=1)
    best = np.full(n, np.inf)
    for p, q in walls:
        p, q = np.asarray(p, float), np.asarray(q, float)
        e = q - p
        den = d[:, 0] * (-e[1]) - d[:, 1] * (-e[0])
        ok = np.abs(den) > 1e-12
        t = np.where(ok, (p[0] * (-e[1]) - p[1] * (-e[0])) / np.where(ok, den, 1.0), np.inf)
        u = np.where(ok, (d[:, 0] * p[1] - d[:, 1] * p[0]) / np.where(ok, den, 1.0), -1.0)
        hit = ok & (t > 0) & (u >= 0) & (u <= 1)
        best = np.where(hit, np.minimum(best, t), best)
    seen = np.isfinite(best)
    r = best[seen] + rng.normal(0.0, 0.01, seen.sum())
    return d[seen] * r[:, None]


def room(rng: np.random.Generator) -> tuple[list[Segment], str]:
    """A wall with a doorway (plain, a hinged leaf open, a closed leaf or a post in it), a
    room beyond, side walls, the sensor at the origin; and which kind it is."""
    width = rng.uniform(0.5, 1.8)
    y0 = rng.uniform(-1.5, 0.5)
    wall_x = rng.uniform(1.0, 4.0)
    walls: list[Segment] = [
        ((wall_x, -4.0), (wall_x, y0)),
        ((wall_x, y0 + width), (wall_x, 4.0)),
        ((wall_x + rng.uniform(1.0, 4.0), -4.0), (wall_x + 4.0, 4.0)),
        ((-3.0, -4.0), (wall_x + 5.0, -4.0)),
        ((-3.0, 4.0), (wall_x + 5.0, 4.0)),
    ]
    if rng.random() < 0.5:  # a thick wall: the jambs' reveals show its thickness
        depth = rng.uniform(0.1, 0.3)
        walls += [((wall_x, y0), (wall_x + depth, y0))]
        walls += [((wall_x, y0 + width), (wall_x + depth, y0 + width))]
    kind = ("plain", "leaf", "closed", "post")[rng.integers(4)]
    if kind == "leaf":  # a hinged leaf open towards the sensor, hinged at one jamb
        hinge_y = y0 if rng.random() < 0.5 else y0 + width
        angle = rng.uniform(math.radians(78), math.radians(102))
        side = 1.0 if hinge_y == y0 else -1.0
        tip = (wall_x - width * math.sin(angle), hinge_y + side * width * math.cos(angle))
        walls.append(((wall_x, hinge_y), tip))
    elif kind == "closed":  # a closed leaf a few cm behind the face
        walls.append(((wall_x + 0.05, y0), (wall_x + 0.05, y0 + width)))
    elif kind == "post":  # a post in the gap
        y = y0 + rng.uniform(0.2, 0.8) * width
        walls.append(((wall_x, y - 0.05), (wall_x, y + 0.05)))
    return walls, kind


def rotated(walls: list[Segment], theta: float, shift: np.ndarray) -> list[Segment]:
    c, s = math.cos(theta), math.sin(theta)

    def move(p: tuple[float, float]) -> tuple[float, float]:
        x, y = p[0] - shift[0], p[1] - shift[1]
        return (c * x - s * y, s * x + c * y)

    return [(move(p), move(q)) for p, q in walls]


def same(a, b) -> None:
    assert len(a) == len(b)
    for x, y in zip(a, b, strict=True):
        assert x.open == y.open
        assert (x.depth is None) == (y.depth is None)
        for name in ("left", "right", "centre", "direction", "normal"):
            assert np.allclose(getattr(x, name), getattr(y, name), rtol=0, atol=1e-9), name
        assert x.width == pytest.approx(y.width, abs=1e-9)
        if x.depth is not None:
            assert x.depth == pytest.approx(y.depth, abs=1e-9)


def test_the_compiled_finder_finds_what_the_reference_finds_in_random_rooms() -> None:
    rng = np.random.default_rng(2026)
    found = {"plain": 0, "leaf": 0, "closed": 0, "post": 0, "reveal": 0}
    stretched = 0
    for _ in range(200):
        drawn, kind = room(rng)
        walls = rotated(drawn, rng.uniform(-math.pi, math.pi), rng.uniform(-0.8, 0.8, 2))
        scan = cast(walls, rng)
        reference = find_doorways_numpy(scan)
        same(find_doorways(scan), reference)
        found[kind] += len(reference)
        found["reveal"] += sum(w.depth is not None for w in reference)
        flat = planar_scan(scan)
        params = door_scan_numba.params(DoorScanConfig())
        ours = door_scan_numba.stretches(flat, params)
        theirs = segment(flat)
        assert len(ours) == len(theirs)
        for row, s in zip(ours, theirs, strict=True):
            assert np.allclose(row[0:4], [*s.a, *s.b], rtol=0, atol=1e-9)
            assert np.allclose(row[4:8], [*s.direction, *s.normal], rtol=0, atol=1e-9)
            assert row[9] == s.count
        stretched += len(theirs)
    # the rooms showed doorways of each kind (a post fills its gap: rarely one) and walls
    assert min(found["plain"], found["leaf"], found["reveal"]) >= 8 and found["closed"] >= 3, found
    assert stretched >= 400


def test_a_scan_with_too_few_returns_has_no_doorway_either_way() -> None:
    for scan in (np.zeros((0, 2)), np.array([[1.0, 0.0]]), np.array([[1.0, 0.0], [0.0, 1.0]])):
        assert find_doorways(scan) == find_doorways_numpy(scan) == []
