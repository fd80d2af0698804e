"""Door leaves as pybullet bodies, placed from the building emulator's opening fractions.

A hinged leaf turns about its ``p1`` end by up to 90 degrees towards the side of
``p1 -> p2`` its door's ``swing`` names (left by default); a sliding leaf slides along
the wall past ``p2``. Closed leaves fill the door gap of the map, so the LiDAR sees them
and the chair collides with them.
"""

from __future__ import annotations

import math

import pybullet as pb

from shared.site import Door

LEAF_HEIGHT_M = 2.0


class DoorLeaf:
    """One door's leaf in a pybullet world."""

    def __init__(
        self, client: int, door: Door, motion: str = "hinged", base_z: float = 0.0
    ) -> None:
        self.client = client
        self.base_z = base_z
        self.door = door
        self.motion = motion
        (x1, y1), (x2, y2) = door.p1, door.p2
        self.width = math.hypot(x2 - x1, y2 - y1)
        self.yaw = math.atan2(y2 - y1, x2 - x1)
        shape = pb.createCollisionShape(
            pb.GEOM_BOX,
            halfExtents=[self.width / 2, door.leaf_thickness_m / 2, LEAF_HEIGHT_M / 2],
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
            side = -1.0 if self.door.swing == "right" else 1.0
            yaw = self.yaw + side * opening * math.pi / 2
            cx = x1 + math.cos(yaw) * self.width / 2
            cy = y1 + math.sin(yaw) * self.width / 2
        pb.resetBasePositionAndOrientation(
            self.body,
            [cx, cy, self.base_z + LEAF_HEIGHT_M / 2 + 0.01],
            pb.getQuaternionFromEuler([0, 0, yaw]),
            physicsClientId=self.client,
        )


class LiftBody:
    """A lift in the simulated world: its car doors on every floor it serves.

    The car itself is the free space inside the shaft of each floor's map; what moves is
    the chair's height while it stands in the car. A floor's car door is open only while
    the car stands at that floor.
    """

    def __init__(self, client: int, lift, elevations: dict[str, float]) -> None:
        self.lift = lift
        self.elevations = {f: elevations[f] for f in lift.floors}
        self.leaves = {
            f: DoorLeaf(client, Door(f"{lift.id}@{f}", f, *lift.doors[f]), "sliding", elevations[f])
            for f in lift.floors
        }
        self.car_z = min(self.elevations.values())
        self.door_opening = 0.0

    def set_state(self, car_z: float, door_opening: float) -> None:
        """Move the car to ``car_z`` with its doors open by ``door_opening`` (0..1)."""
        self.car_z, self.door_opening = car_z, door_opening
        for floor, leaf in self.leaves.items():
            at_floor = abs(car_z - self.elevations[floor]) < 0.02
            leaf.set_opening(door_opening if at_floor else 0.0)

    def floor_at(self) -> str | None:
        """The floor the car stands at, if it stands at one."""
        for floor, z in self.elevations.items():
            if abs(self.car_z - z) < 0.02:
                return floor
        return None

    def contains(self, x: float, y: float) -> bool:
        """True if (x, y) lies inside the car's rectangle."""
        lift = self.lift
        dx, dy = x - lift.x, y - lift.y
        c, s = math.cos(lift.theta), math.sin(lift.theta)
        along, across = c * dx + s * dy, -s * dx + c * dy
        return abs(along) <= lift.depth / 2 and abs(across) <= lift.width / 2
