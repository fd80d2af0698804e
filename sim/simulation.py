"""The simulator's core: one floor, one chair, its sensors and its collision bookkeeping.

No I/O and no clock reads: the node calls :meth:`Simulation.step` and publishes what it
returns. Deterministic for a given config and seed.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np
import pybullet as pb

from shared.config import FleetConfig
from shared.site import Site
from sim.doors import DoorLeaf, LiftBody
from sim.lidar3d import MultiRingLidar
from sim.pedestrians import Pedestrian
from sim.robot import Chair, ChairState, WheelOdometry
from sim.sensors import PlanarLidar
from sim.world import World

CLEARANCE_RANGE_M = 2.0
CHAIR_HEIGHT_M = 1.2


@dataclass(frozen=True)
class Opening:
    """A door opening's zone, where clearance is measured apart from the rest: some part
    of the footprint within ``reach`` of the door plane (in the doorway itself, the wall's
    thickness) and the footprint centre within ``side`` of the door's middle."""

    id: str
    width: float
    cx: float
    cy: float
    nx: float
    ny: float
    reach: float
    side: float
    free: float  # the clear width: less half a hinged leaf's thickness, which stands in it


@dataclass
class ClearanceSeen:
    """The smallest clearance in one place (an opening, or away from them), what it was
    to and where the chair stood (true pose x, y, theta)."""

    width: float
    clearance: float = math.inf
    nearest: str = ""
    at: tuple[float, float, float] = (0.0, 0.0, 0.0)
    free: float = 0.0
    entered: bool = False  # the chair's centre stood in the doorway (it passed, or began to)
    outline: float = math.inf  # least clearance while only the outline was in the doorway

    def see(self, clearance: float, nearest: str, at: tuple[float, float, float]) -> None:
        if clearance < self.clearance:
            self.clearance, self.nearest, self.at = clearance, nearest, at

    def see_in_opening(
        self, clearance: float, nearest: str, at: tuple[float, float, float], centre_in: bool
    ) -> None:
        """One measurement in this opening's zone. While the chair's centre stands in the
        doorway it is passing and its centring counts (``clearance``); before that, and
        turning beside it, only its outline is in (``outline``). Until the centre first
        stands in, ``clearance`` reports the outline's least, as a door never passed."""
        if not centre_in:
            self.outline = min(self.outline, clearance)
            if self.entered:
                return
        elif not self.entered:
            self.entered, self.clearance = True, math.inf
        self.see(clearance, nearest, at)


# the doorway: this far either side of the door plane (half a 0.2 m wall and a frame) and
# past the jambs; a chair turning before a door is not in it, its clearance counts as away
OPENING_MARGIN_M = 0.15


def _openings(site: Site, hinged: set[str]) -> dict[str, list[Opening]]:
    """Every door opening per floor: the site's doors (``hinged``: the ids whose leaf
    swings) and each lift's car doors."""
    segments = [
        (d.id, d.floor, d.p1, d.p2, d.leaf_thickness_m if d.id in hinged else 0.0)
        for d in site.doors
    ]
    for lift in getattr(site, "elevators", []):
        segments += [(f"{lift.id}@{f}", f, *lift.doors[f], 0.0) for f in lift.floors]
    out: dict[str, list[Opening]] = {}
    for door_id, floor, (x1, y1), (x2, y2), leaf in segments:
        width = math.hypot(x2 - x1, y2 - y1)
        if width <= 0:
            continue
        nx, ny = -(y2 - y1) / width, (x2 - x1) / width
        out.setdefault(floor, []).append(
            Opening(
                door_id,
                width,
                (x1 + x2) / 2,
                (y1 + y2) / 2,
                nx,
                ny,
                OPENING_MARGIN_M,
                width / 2 + OPENING_MARGIN_M,
                width - leaf / 2,
            )
        )
    return out


def _centre_in(o: Opening, x: float, y: float) -> bool:
    """True if the point (x, y) is in the doorway itself: within the wall's thickness of
    the door plane and between the jambs. A chair whose nose only dips into a doorway it
    does not pass (turning beside it in a corridor) is judged as away from doors."""
    along = (x - o.cx) * o.nx + (y - o.cy) * o.ny
    lateral = (x - o.cx) * o.ny - (y - o.cy) * o.nx
    return bool(abs(along) <= o.reach and abs(lateral) <= o.width / 2)


STANDING_MPS, STANDING_RADPS = 0.01, 0.02  # a chair this slow stands (a kidnapping waits)
KIDNAP_CLEAR_M = 0.05  # a kidnapping puts the chair down at least this far from any wall


@dataclass
class StepResult:
    """What one step produced: the time, whether a scan is due, and new collisions."""

    stamp: float
    tick: int
    scan: np.ndarray | None = None
    new_collision: bool = False
    events: list[str] = field(default_factory=list)
    kidnapped: str = ""  # a kidnapping done in this step, in words


class Drive(Protocol):
    """What moves the chair: its true ``state``, advanced by ``step(dt, now)``; and
    whether its watchdog has stopped it."""

    state: ChairState
    watchdog_tripped: bool

    def step(self, dt: float, now: float) -> ChairState: ...


class Simulation:
    """Steps the chair on a site floor and measures collisions and clearance.

    ``drive``: made from the start state, what moves the chair instead of the simulated
    one that obeys :meth:`command` (the hardware path's emulated WHILL, sim/wheel_drive.py).
    """

    def __init__(
        self,
        cfg: FleetConfig,
        site: Site,
        drive: Callable[[ChairState], Drive] | None = None,
    ) -> None:
        sim, robot = cfg.sim, cfg.robot
        self.cfg = cfg
        s = sim.start
        x, y, theta, self.floor = site.start_pose(s.place, s.x, s.y, s.theta, s.floor)
        self.elevations = {name: f.elevation for name, f in site.floors.items()}
        self.z = self.elevations[self.floor]
        self.world = World(site.floor(self.floor).map, cfg.planner.unknown_is_occupied, self.z)
        for name, f in site.floors.items():  # every floor, stacked at its elevation
            if name != self.floor:
                self.world.add_floor(f.map, f.elevation, cfg.planner.unknown_is_occupied)
        self.rng = np.random.default_rng(sim.seed)
        start = ChairState(x, y, theta)
        self.chair: Chair | Drive = (
            Chair(
                robot,
                start,
                sim.motor_lag_s,
                sim.watchdog_s,
                sim.caster_disturbance,
                np.random.default_rng([sim.seed, 2]),
            )
            if drive is None
            else drive(start)
        )
        odo_rng = np.random.default_rng([sim.seed, 1])  # its own stream: scans do not shift it
        self.odometry = WheelOdometry(
            ChairState(x, y, theta),
            sim.odom_scale_error,
            sim.odom_turn_bias,
            sim.odom_noise_v,
            sim.odom_noise_w,
            odo_rng,
        )
        self.lidar = PlanarLidar(
            self.world.client,
            sim.lidar_beams,
            sim.lidar_fov_deg,
            sim.lidar_range_m,
            robot.lidar_height_m,
            sim.lidar_noise_m,
            self.rng,
        )
        self.dt = sim.dt
        self.tick = 0
        self.time = 0.0
        self.scan_every = max(1, round(1.0 / (sim.lidar_rate_hz * sim.dt)))
        fp = robot.footprint
        half = [(fp.front + fp.rear) / 2, fp.width / 2, CHAIR_HEIGHT_M / 2]
        self._body_offset = (fp.front - fp.rear) / 2
        shape = pb.createCollisionShape(
            pb.GEOM_BOX, halfExtents=half, physicsClientId=self.world.client
        )
        self.body = pb.createMultiBody(0, shape, physicsClientId=self.world.client)
        if sim.lidar == "vlp16":  # 16 rings x 1800 azimuths, grid ray casting
            self.lidar = MultiRingLidar.for_site(
                self.world,
                site,
                height_m=robot.lidar_height_m,
                noise_m=sim.lidar_noise_m,
                rng=self.rng,
                ignore_ids=[self.body],
                unknown_is_occupied=cfg.planner.unknown_is_occupied,
            )
        self.doors = {
            d.id: DoorLeaf(
                self.world.client,
                d,
                cfg.building.motion_of(d.id, d.motion),
                self.elevations[d.floor],
            )
            for d in site.doors
        }
        self.pedestrians = [
            Pedestrian(
                self.world.client,
                p.waypoints,
                p.speed,
                p.radius,
                self.elevations[site.floor(p.floor).name if p.floor else self.floor],
                p.start_delay_s,
            )
            for p in sim.pedestrians
        ]
        self.lifts = {
            e.id: LiftBody(self.world.client, e, self.elevations)
            for e in getattr(site, "elevators", [])
        }
        for d in site.doors:  # as the building emulator will start them
            if d.id in self.doors and cfg.building.starts_open(d.id, d.type):
                self.doors[d.id].set_opening(1.0)
        self._labels = {leaf.body: f"door {name}" for name, leaf in self.doors.items()}
        for name, lift in self.lifts.items():
            self._labels.update({leaf.body: f"{name} car door" for leaf in lift.leaves.values()})
        self._labels.update({p.body: f"pedestrian {i}" for i, p in enumerate(self.pedestrians)})
        self.kidnaps = sorted(sim.kidnaps, key=lambda k: k.at_s)  # still to do
        self.nearest = ""
        self.collisions = 0
        self.in_collision = False
        self.clearance = math.inf
        self.min_clearance = math.inf
        self.away = ClearanceSeen(0.0)  # away from every door opening
        self.door_clearance: dict[str, ClearanceSeen] = {}  # per opening, by id
        hinged = {name for name, leaf in self.doors.items() if leaf.motion == "hinged"}
        self._openings = _openings(site, hinged)
        self._corners = np.array(
            [
                (fp.front, fp.width / 2),
                (fp.front, -fp.width / 2),
                (-fp.rear, -fp.width / 2),
                (-fp.rear, fp.width / 2),
            ]
        )
        self._corner_list = [(float(a), float(b)) for a, b in self._corners]
        self._place_body()
        self._measure()
        if self.in_collision:
            raise ValueError(
                f"start pose ({start.x:.2f}, {start.y:.2f}) puts the chair inside a wall"
            )

    @property
    def state(self) -> ChairState:
        return self.chair.state

    def set_lifts(self, names: list[str], car_z, door_openings) -> None:
        """Move the lift cars and their doors as the emulator says."""
        for name, z, opening in zip(names, car_z, door_openings, strict=True):
            body = self.lifts.get(name)
            if body is not None:
                body.set_state(float(z), float(opening))

    def set_door_openings(self, names: list[str], openings) -> None:
        """Move the door leaves to the emulator's opening fractions."""
        for name, opening in zip(names, openings, strict=True):
            leaf = self.doors.get(name)
            if leaf is not None:
                leaf.set_opening(float(opening))

    def kidnap(self, x: float, y: float, theta: float) -> bool:
        """Put the chair down at (x, y, theta) on its floor, standing: a kidnapping, which
        its wheels do not feel (the odometry goes on from where it was). False, and the
        chair left where it was, if that pose is within ``KIDNAP_CLEAR_M`` of a wall."""
        s = self.state
        before = (s.x, s.y, s.theta)
        s.x, s.y, s.theta, s.v, s.w = x, y, theta, 0.0, 0.0
        self._place_body()
        if self._closest()[0] > KIDNAP_CLEAR_M:
            self._measure()
            return True
        s.x, s.y, s.theta = before
        self._place_body()
        return False

    def _kidnap_due(self) -> str:
        """Do the next configured kidnapping if its time has come and the chair stands."""
        s = self.state
        standing = abs(s.v) < STANDING_MPS and abs(s.w) < STANDING_RADPS
        if not self.kidnaps or self.time < self.kidnaps[0].at_s or not standing:
            return ""
        k = self.kidnaps.pop(0)
        x0, y0, th0 = s.x, s.y, s.theta
        c, si = math.cos(th0), math.sin(th0)
        to = (x0 + c * k.dx - si * k.dy, y0 + si * k.dx + c * k.dy, th0 + k.dtheta)
        where = f"({to[0]:.2f}, {to[1]:.2f}, {math.degrees(to[2]):.0f} deg)"
        if not self.kidnap(*to):
            return f"not moved to {where}: within {KIDNAP_CLEAR_M} m of a wall"
        return (
            f"the chair was moved from ({x0:.2f}, {y0:.2f}, {math.degrees(th0):.0f} deg) "
            f"to {where} while standing"
        )

    def command(self, v: float, w: float) -> None:
        """A velocity command received now."""
        self.chair.command(v, w, self.time)

    def step(self) -> StepResult:
        """Advance one tick: move, measure clearance, and scan when due."""
        tripped_before = self.chair.watchdog_tripped
        self.chair.step(self.dt, self.time)
        self.odometry.step(self.state.v, self.state.w, self.dt)
        self._ride()
        for person in self.pedestrians:
            person.move_to(self.time + self.dt)
        self.tick += 1
        self.time = self.tick * self.dt
        self._place_body()
        was_colliding = self.in_collision
        self._measure()
        result = StepResult(self.time, self.tick)
        if self.in_collision and not was_colliding:
            self.collisions += 1
            result.new_collision = True
        if self.chair.watchdog_tripped and not tripped_before:
            result.events.append("watchdog: no command, stopping")
        result.kidnapped = self._kidnap_due()
        if self.tick % self.scan_every == 0:
            s = self.state
            result.scan = self.lidar.scan(s.x, s.y, s.theta, self.z)
        return result

    def _ride(self) -> None:
        """Carry the chair with a lift car it stands in; change floor where the car stops."""
        s = self.state
        cx = s.x + self._body_offset * math.cos(s.theta)
        cy = s.y + self._body_offset * math.sin(s.theta)
        for lift in self.lifts.values():
            if self.floor in lift.elevations and lift.contains(cx, cy):
                self.z = lift.car_z
                stop = lift.floor_at()
                if stop is not None:
                    self.floor = stop
                return
        self.z = self.elevations[self.floor]

    def _place_body(self) -> None:
        s = self.state
        cx = s.x + self._body_offset * math.cos(s.theta)
        cy = s.y + self._body_offset * math.sin(s.theta)
        orn = pb.getQuaternionFromEuler([0, 0, s.theta])
        pb.resetBasePositionAndOrientation(
            self.body,
            [cx, cy, self.z + CHAIR_HEIGHT_M / 2 + 0.02],
            orn,
            physicsClientId=self.world.client,
        )

    def _closest(self) -> tuple[float, int | None]:
        """The footprint's distance to the nearest body within ``CLEARANCE_RANGE_M``
        (negative = penetration; inf if none) and that body."""
        client = self.world.client
        lo, hi = pb.getAABB(self.body, physicsClientId=client)
        lo = [lo[0] - CLEARANCE_RANGE_M, lo[1] - CLEARANCE_RANGE_M, lo[2]]
        hi = [hi[0] + CLEARANCE_RANGE_M, hi[1] + CLEARANCE_RANGE_M, hi[2]]
        near = pb.getOverlappingObjects(lo, hi, physicsClientId=client) or []
        best, nearest = math.inf, None
        for body, _link in near:
            if body == self.body:
                continue
            pts = pb.getClosestPoints(self.body, body, CLEARANCE_RANGE_M, physicsClientId=client)
            for p in pts:
                if p[8] < best:
                    best, nearest = p[8], body
        return best, nearest

    def _measure(self) -> None:
        """Footprint clearance to the nearest wall (negative = penetration) and collision flag."""
        best, nearest = self._closest()
        self.nearest = self._labels.get(nearest, "wall") if nearest is not None else ""
        self.clearance = best
        self.min_clearance = min(self.min_clearance, best)
        self.in_collision = best <= 0.0
        s = self.state
        at = (s.x, s.y, s.theta)
        opening = self._opening_at(s.x, s.y, s.theta)
        if opening is None:
            self.away.see(best, self.nearest, at)
            return
        seen = self.door_clearance.setdefault(
            opening.id, ClearanceSeen(opening.width, free=opening.free)
        )
        centre_in = _centre_in(opening, *self._footprint_centre(s))
        seen.see_in_opening(best, self.nearest, at, centre_in)

    @property
    def min_clearance_away(self) -> float:
        """The smallest clearance seen away from every door opening (inf: none yet)."""
        return self.away.clearance

    def _footprint_centre(self, s: ChairState) -> tuple[float, float]:
        """The middle of the footprint's outline at the chair's true pose ``s``."""
        c, n = math.cos(s.theta), math.sin(s.theta)
        mx, my = self._corners.mean(axis=0)
        return float(s.x + mx * c - my * n), float(s.y + mx * n + my * c)

    def _opening_at(self, x: float, y: float, theta: float) -> Opening | None:
        """The door opening (site door or car door on the chair's floor) whose zone the
        footprint at pose (x, y, theta) is in, if any."""
        openings = self._openings.get(self.floor, ())
        if not openings:
            return None
        # plain floats on four corners, in numpy's order of operations (the same values):
        # numpy's calls on 4-element arrays cost more than the arithmetic, every tick
        c, s = math.cos(theta), math.sin(theta)
        px = [x + a * c - b * s for a, b in self._corner_list]
        py = [y + a * s + b * c for a, b in self._corner_list]
        mx = (((0.0 + px[0]) + px[1]) + px[2]) + px[3]
        my = (((0.0 + py[0]) + py[1]) + py[2]) + py[3]
        mx, my = mx / 4, my / 4
        for o in openings:
            along = [(qx - o.cx) * o.nx + (qy - o.cy) * o.ny for qx, qy in zip(px, py, strict=True)]
            if min(along) > o.reach or max(along) < -o.reach:
                continue
            if abs((mx - o.cx) * o.ny - (my - o.cy) * o.nx) <= o.side:
                return o
        return None

    def close(self) -> None:
        self.world.close()
