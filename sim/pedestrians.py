"""Scripted pedestrians: cylinders walking waypoint loops, for obstacle-avoidance tests.

Each pedestrian walks its loop at constant speed (deterministic: position is a function
of time only), so the same scenario gives the same encounters on every run. One given a
single waypoint stands there (the people of a generated world the map does not show).
"""

from __future__ import annotations

import math

import numpy as np
import pybullet as pb

PEDESTRIAN_HEIGHT_M = 1.7


class Pedestrian:
    """A cylinder of ``radius`` walking ``waypoints`` (closed loop) at ``speed`` on a floor;
    with one waypoint (or a loop of no length) it stands there."""

    def __init__(
        self,
        client: int,
        waypoints: list[list[float]],
        speed: float,
        radius: float,
        base_z: float,
        start_delay_s: float = 0.0,
    ) -> None:
        pts = np.asarray(waypoints, dtype=float)
        if pts.ndim != 2 or pts.shape[1] != 2 or len(pts) < 1:
            raise ValueError(
                f"pedestrian waypoints must be [[x, y], ...] with 1+ points, got {waypoints!r}"
            )
        if speed <= 0 or radius <= 0:
            raise ValueError("pedestrian speed and radius must be > 0")
        self.loop = np.vstack([pts, pts[:1]])
        legs = np.linalg.norm(np.diff(self.loop, axis=0), axis=1)
        self.s = np.concatenate([[0.0], np.cumsum(legs)])
        self.speed = speed
        self.base_z = base_z
        self.start_delay_s = start_delay_s
        self.client = client
        shape = pb.createCollisionShape(
            pb.GEOM_CYLINDER, radius=radius, height=PEDESTRIAN_HEIGHT_M, physicsClientId=client
        )
        self.body = pb.createMultiBody(0, shape, physicsClientId=client)
        self.position = (float(pts[0, 0]), float(pts[0, 1]))
        self.move_to(0.0)

    def move_to(self, t: float) -> None:
        """Place the pedestrian where it is at simulation time ``t``."""
        walked = max(0.0, t - self.start_delay_s) * self.speed
        s = math.fmod(walked, self.s[-1]) if self.s[-1] > 0 else 0.0  # 0: standing
        x = float(np.interp(s, self.s, self.loop[:, 0]))
        y = float(np.interp(s, self.s, self.loop[:, 1]))
        self.position = (x, y)
        pb.resetBasePositionAndOrientation(
            self.body,
            [x, y, self.base_z + PEDESTRIAN_HEIGHT_M / 2 + 0.01],
            [0, 0, 0, 1],
            physicsClientId=self.client,
        )
