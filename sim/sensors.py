"""Simulated sensors: a planar LiDAR by batched pybullet ray casting.

Points are returned in the sensor frame (x forward, y left, z up), float32, with
Gaussian range noise from a seeded generator; beams that hit nothing are left out.
"""

from __future__ import annotations

import math

import numpy as np
import pybullet as pb

MAX_RAYS_PER_BATCH = 16383  # pybullet answers at most 16383 rays per rayTestBatch call


class PlanarLidar:
    """A horizontal scanner of ``beams`` rays over ``fov_deg`` centred on the chair's heading."""

    def __init__(
        self,
        client: int,
        beams: int,
        fov_deg: float,
        range_m: float,
        height_m: float,
        noise_m: float,
        rng: np.random.Generator,
    ) -> None:
        self.client = client
        self.range_m = range_m
        self.height_m = height_m
        self.noise_m = noise_m
        self.rng = rng
        fov = math.radians(fov_deg)
        full_circle = fov >= 2 * math.pi - 1e-9
        self.angles = (
            np.linspace(-math.pi, math.pi, beams, endpoint=False)
            if full_circle
            else np.linspace(-fov / 2, fov / 2, beams)
        )
        self._dirs = np.stack([np.cos(self.angles), np.sin(self.angles)], axis=1)

    def scan(self, x: float, y: float, theta: float, base_z: float = 0.0) -> np.ndarray:
        """Ray-cast from pose (x, y, theta) on a floor at ``base_z``; returns (N, 3) float32
        points in the sensor frame."""
        c, s = math.cos(theta), math.sin(theta)
        world_dirs = self._dirs @ np.array([[c, s], [-s, c]])
        origin = np.array([x, y, base_z + self.height_m])
        starts = np.broadcast_to(origin, (len(self.angles), 3))
        ends = starts.copy()
        ends[:, :2] += world_dirs * self.range_m
        fractions = np.empty(len(self.angles))
        for i in range(0, len(self.angles), MAX_RAYS_PER_BATCH):
            hits = pb.rayTestBatch(
                starts[i : i + MAX_RAYS_PER_BATCH].tolist(),
                ends[i : i + MAX_RAYS_PER_BATCH].tolist(),
                physicsClientId=self.client,
            )
            fractions[i : i + len(hits)] = [h[2] if h[0] >= 0 else 1.0 for h in hits]
        hit = fractions < 1.0
        ranges = fractions[hit] * self.range_m
        if self.noise_m > 0:
            ranges = ranges + self.rng.normal(0.0, self.noise_m, ranges.shape)
        pts = np.zeros((int(hit.sum()), 3), dtype=np.float32)
        pts[:, :2] = self._dirs[hit] * ranges[:, None]
        return pts
