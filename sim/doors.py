"""Door leaves as pybullet bodies, placed from the building emulator's opening fractions.

A hinged leaf turns about its ``p1`` end by up to 90 degrees towards the door's left
normal; a sliding leaf slides along the wall past ``p2``. Closed leaves fill the door
gap of the map, so the LiDAR sees them and the chair collides with them.
"""

from __future__ import annotations

import math

import pybullet as pb

from shared.site import Door

LEAF_THICKNESS_M = 0.05
LEAF_HEIGHT_M = 2.0


class DoorLeaf:
    """One door's leaf in a pybullet world."""

    def __init__(self, client: int, door: Door, motion: str = "hinged") -> None:
        self.client = client
        self.door = door
        self.motion = motion
        (x1, y1), (x2, y2) = door.p1, door.p2
        self.width = math.hypot(x2 - x1, y2 - y1)
        self.yaw = math.atan2(y2 - y1, x2 - x1)
        shape = pb.createCollisionShape(
            pb.GEOM_BOX,
            halfExtents=[self.width / 2, LEAF_THICKNESS_M / 2, LEAF_HEIGHT_M / 2],
            physicsClientId=client,
        )
        self.body = pb.createMultiBody(0, shape, physicsClientId=client)
        self.opening = -1.0
        self.set_opening(0.0)

    def set_opening(self, opening: float) -> None:
        """Place the leaf for an opening fraction in [0, 1]."""
        opening = min(1.0, max(0.0, opening))
        if opening == self.opening:
            return
        self.opening = opening
        x1, y1 = self.door.p1
        if self.motion == "sliding":
            shift = opening * self.width + self.width / 2
            cx, cy, yaw = x1 + math.cos(self.yaw) * shift, y1 + math.sin(self.yaw) * shift, self.yaw
        else:
            yaw = self.yaw + opening * math.pi / 2
            cx = x1 + math.cos(yaw) * self.width / 2
            cy = y1 + math.sin(yaw) * self.width / 2
        pb.resetBasePositionAndOrientation(
            self.body,
            [cx, cy, LEAF_HEIGHT_M / 2 + 0.01],
            pb.getQuaternionFromEuler([0, 0, yaw]),
            physicsClientId=self.client,
        )
