"""Routes: legs of path joined by door and elevator checkpoints, across rooms and floors.

On one floor, the route is found by one A* over the whole floor (door openings are free
space in the map), which is optimal across every room at once; the declared doors it
crosses become checkpoints, in order. The legs between them are then planned again with
every declared door closed, so that no leg slips through a door without a checkpoint.
The seed instead ran Dijkstra over (room, entry door) states with A* per room; the
whole-floor A* finds the same or a shorter route without needing a room graph, and the
landmark heuristic keeps it fast. A blocked door is closed for the first search too, so
the route avoids it or there is none.

Between floors, every available elevator serving both floors is tried (leg to its entry
on the start floor, a ride, leg from its exit on the goal floor) and the cheapest kept.

Rooms serve two ends: each floor is segmented once (:mod:`services.planner.room_segmentation`)
to tag every waypoint as in a room or a corridor, and on a floor whose site declares no
doors, the doors detected along the plain A* path (:mod:`services.planner.path_doors`)
stand in for the declared ones.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from services.planner import errors
from services.planner.door_poses import (
    LEAF_CLEAR_M,
    PoseRoom,
    approach_distance,
    exit_distance,
    free_depth,
)
from services.planner.grid_planner import Plan, Planner, block_segment, with_open_leaves
from services.planner.path_doors import detect_doors_along_path
from services.planner.room_segmentation import RoomMap, segment_rooms
from shared.config import PlannerConfig
from shared.site import Door, Site

Pose = tuple[float, float, float]
Segment = tuple[tuple[float, float], tuple[float, float]]

DOORWAY_DEPTH_M = 0.3  # how far past the door plane a doorway's jambs and frame may reach


@dataclass
class Checkpoint:
    """A door or elevator between two legs, with the poses the mission tree drives to."""

    kind: str  # "door" or "elevator"
    id: str
    floor: str
    approach: Pose  # door: on the normal at the standoff, facing the door
    exit: Pose  # door: the far side, same heading; elevator: outside the car on to_floor
    pass_distance_m: float
    door_type: str = ""
    width_m: float = 0.0
    to_floor: str = ""
    centre: tuple[float, float] = (0.0, 0.0)  # the door's (or car door's) middle
    controller: bool = True  # the building reports the door's state (else: LiDAR alone)
    in_sweep: bool = False  # the approach pose lies in the sweep of a leaf opening towards it
    leaf_away: bool = False  # a hinged leaf stands open beyond the door (swings away)


@dataclass
class Route:
    """``legs[0]``, ``checkpoints[0]``, ``legs[1]``, ... (one more leg than checkpoints)."""

    legs: list[Plan]
    checkpoints: list[Checkpoint] = field(default_factory=list)

    @property
    def length_m(self) -> float:
        return sum(leg.length_m for leg in self.legs) + sum(
            c.pass_distance_m for c in self.checkpoints if c.kind == "door"
        )


class RoutePlanner:
    """Routes on a site, with doors and elevators that can be marked unavailable."""

    def __init__(
        self, planner: Planner, site: Site, cfg: PlannerConfig, stop_distance_m: float = 0.25
    ) -> None:
        self.planner = planner
        self.stop_distance_m = stop_distance_m
        self.site = site
        self.cfg = cfg
        self.blocked_doors: set[str] = set()
        self.unavailable_lifts: set[str] = set()
        self.marked_at: dict[str, float] = {}  # when each was marked unavailable (stamp)
        self._points: dict[str, list[tuple[float, float]]] = {}  # this request's obstacles
        self.rooms = {
            name: segment_rooms(
                f.map.occupied(True), f.map.resolution, (f.map.origin[0], f.map.origin[1])
            )
            for name, f in site.floors.items()
        }
        self.corridors = {name: corridor_rooms(rm) for name, rm in self.rooms.items()}

    def set_door_blocked(self, door_id: str, blocked: bool, stamp: float | None = None) -> None:
        """Mark a door or lift unavailable (or available again); a mark with a ``stamp``
        is dropped by :meth:`expire` ``unavailable_retry_s`` later."""
        if door_id not in {d.id for d in self.site.doors} | {e.id for e in self.site.elevators}:
            raise errors.BadRequest(f"no door or elevator called {door_id!r} in this site")
        target = (
            self.unavailable_lifts
            if door_id in {e.id for e in self.site.elevators}
            else self.blocked_doors
        )
        (target.add if blocked else target.discard)(door_id)
        if blocked and stamp is not None:
            self.marked_at[door_id] = stamp
        else:
            self.marked_at.pop(door_id, None)

    def expire(self, now: float) -> list[str]:
        """Drop the unavailable marks made ``cfg.unavailable_retry_s`` or more before
        ``now`` (a door stuck then may have been fixed); the ids made available again."""
        old = [i for i, at in self.marked_at.items() if now - at >= self.cfg.unavailable_retry_s]
        for door_id in old:
            self.set_door_blocked(door_id, False)
        return old

    def request(
        self,
        start: tuple[float, float],
        start_floor: str,
        goal: tuple[float, float] | None,
        goal_floor: str,
        place: str = "",
        avoid: list[str] = (),
        blocked: list[tuple[float, float, str]] = (),
        stamp: float | None = None,
        untraversed: list[tuple[float, float, str]] = (),
    ) -> Route:
        """A route to ``goal`` on ``goal_floor`` or to the named ``place`` (one is needed),
        treating the doors and lifts in ``avoid`` as unavailable for this request, and the
        points in ``blocked`` and ``untraversed`` (x, y, floor) as obstacles where a way
        round them exists (``untraversed`` given up first); with a ``stamp``, marks older
        than ``unavailable_retry_s`` are dropped first."""
        if stamp is not None:
            self.expire(stamp)
        if place:
            gx, gy, _theta, goal_floor = self.planner.resolve_place(place)
            goal = (gx, gy)
        elif goal is None:
            raise errors.BadRequest("route request has neither goal nor place")
        saved = (set(self.blocked_doors), set(self.unavailable_lifts))
        # what held the chair may be a closed door on the only way (its procedure opens
        # it), someone who moves on, or a gap the chair could not enter from where it came:
        # the points are a hint, not a wall; each set that shuts every way is dropped
        hints = [list(blocked) + list(untraversed), list(blocked), []]
        hints = [h for i, h in enumerate(hints) if i == 0 or h != hints[i - 1]]
        try:
            for name in avoid:
                self.set_door_blocked(name, True)
            for points in hints[:-1]:
                self._set_points(points)
                try:
                    return self.route(start, start_floor, goal, goal_floor)
                except errors.NoPath:
                    continue
            self._set_points(hints[-1])
            return self.route(start, start_floor, goal, goal_floor)
        finally:
            self.blocked_doors, self.unavailable_lifts = saved
            self._points = {}

    def _set_points(self, points: list[tuple[float, float, str]]) -> None:
        """This request's obstacles, per floor."""
        self._points = {}
        for x, y, floor in points:
            self._points.setdefault(self.planner.floor_name(floor), []).append((x, y))

    def route(
        self,
        start: tuple[float, float],
        start_floor: str,
        goal: tuple[float, float],
        goal_floor: str,
    ) -> Route:
        """The cheapest route; NoPath (naming what is unavailable) if there is none."""
        start_floor = self.planner.floor_name(start_floor)
        goal_floor = self.planner.floor_name(goal_floor or start_floor)
        if start_floor == goal_floor:
            return self.floor_route(start, goal, start_floor)
        best: Route | None = None
        best_cost = math.inf
        reasons = []
        for lift in self.site.elevators:
            if start_floor not in lift.floors or goal_floor not in lift.floors:
                continue
            if lift.id in self.unavailable_lifts:
                reasons.append(f"{lift.id} unavailable")
                continue
            try:
                route = self._via_lift(start, start_floor, goal, goal_floor, lift)
            except errors.PlanError as exc:
                reasons.append(f"{lift.id}: {exc}")
                continue
            cost = route.length_m + self.cfg.elevator_ride_cost_m
            if cost < best_cost:
                best, best_cost = route, cost
        if best is None:
            why = "; ".join(reasons) or "no elevator serves both floors"
            raise errors.NoPath(f"no route from floor {start_floor} to floor {goal_floor} ({why})")
        return best

    def _via_lift(self, start, start_floor, goal, goal_floor, lift) -> Route:
        standoff = self.cfg.elevator_standoff_m
        entry = lift.entry_pose(start_floor, standoff)
        out = lift.entry_pose(goal_floor, standoff)
        first = self.floor_route(start, entry[:2], start_floor, entry[2])
        second = self.floor_route(out[:2], goal, goal_floor)
        inside = lift.inside_pose()
        ride = Checkpoint(
            "elevator",
            lift.id,
            start_floor,
            entry,
            out,
            float(math.hypot(inside[0] - entry[0], inside[1] - entry[1])),
            to_floor=goal_floor,
            centre=lift.door_centre(start_floor),
        )
        return Route(first.legs + second.legs, first.checkpoints + [ride] + second.checkpoints)

    def floor_route(
        self,
        start: tuple[float, float],
        goal: tuple[float, float],
        floor: str,
        arrive_heading: float | None = None,
    ) -> Route:
        """A route on one floor: legs joined by checkpoints for each door crossed.

        The site's declared doors are used where it has any on this floor; on a map without
        annotations the doorways the route passes (narrow passages with walls on both
        sides) are found along the path and become checkpoints the same way.
        """
        doors = [d for d in self.site.doors if d.floor == floor]
        if not doors:
            doors = self.detected_doors(start, goal, floor)
        blocked = [(d.p1, d.p2) for d in doors if d.id in self.blocked_doors]
        try:
            whole = self.planner.plan(start, goal, floor, blocked, self._points.get(floor, ()))
        except errors.NoPath as exc:
            if blocked:
                names = ", ".join(sorted(d.id for d in doors if d.id in self.blocked_doors))
                raise errors.NoPath(f"{exc} (blocked: {names})") from None
            raise
        open_doors = [d for d in doors if d.id not in self.blocked_doors]
        crossed = crossings(whole.waypoints, open_doors)
        if not crossed:
            if arrive_heading is not None:
                return Route([self._leg(start, goal, floor, blocked, "goal", arrive_heading)])
            self._tag_zones(whole, "goal")
            return Route([whole])
        closed = [(d.p1, d.p2) for d in doors]
        checkpoints = [self._door_checkpoint(door, side, floor) for _s, door, side in crossed]
        legs = []
        here = start
        for cp in checkpoints:
            legs.append(self._leg(here, cp.approach[:2], floor, closed, "door", cp.approach[2]))
            here = cp.exit[:2]
        legs.append(self._leg(here, goal, floor, closed, "goal", arrive_heading))
        return Route(legs, checkpoints)

    def detected_doors(
        self, start: tuple[float, float], goal: tuple[float, float], floor: str
    ) -> list[Door]:
        """Doorways along the plain A* path on an unannotated floor, as manual doors."""
        try:
            raw = self.planner.plan(start, goal, floor)
        except errors.PlanError:
            return []
        grid = self.site.floor(floor).map
        found = detect_doors_along_path(
            grid.occupied(self.planner.cfg.unknown_is_occupied),
            grid.resolution,
            (grid.origin[0], grid.origin[1]),
            raw.waypoints,
        )
        return [
            Door(
                f"doorway_{floor}_{d.centre[0]:.1f}_{d.centre[1]:.1f}",
                floor,
                tuple(d.p1),
                tuple(d.p2),
                "manual",
            )
            for d in found
        ]

    def _leg(
        self,
        a,
        b,
        floor: str,
        closed: list[Segment],
        end: str = "goal",
        heading: float | None = None,
    ) -> Plan:
        """A leg that ends standing still at ``b`` (a door's approach pose or the goal),
        with a zone tag per waypoint (``end`` near its end, else room or corridor); with
        ``heading``, it arrives along it (``planner.run_in_m``)."""
        plan = self.planner.plan(
            a, b, floor, closed, self._points.get(floor, ()), heading, self.cfg.run_in_m
        )
        self._tag_zones(plan, end)
        return plan

    def _tag_zones(self, plan: Plan, end: str) -> None:
        """Zone tags: ``end`` within the slow-down radius of the leg's end, else the kind of
        room the waypoint is in (corridor or room)."""
        rooms, corridors = self.rooms[plan.floor], self.corridors[plan.floor]
        radius = self.cfg.door_slow_radius_m if end == "door" else self.cfg.goal_speed_radius_m
        to_end = np.linalg.norm(plan.waypoints - plan.waypoints[-1], axis=1)
        plan.zones = [
            end if d <= radius else ("corridor" if rooms.room_at(x, y) in corridors else "room")
            for (x, y), d in zip(plan.waypoints, to_end, strict=True)
        ]

    def _door_checkpoint(self, door: Door, side: int, floor: str) -> Checkpoint:
        """The door's checkpoint, its poses fitted to the space on both sides of it
        (services/planner/door_poses.py), the other doors of the floor counted closed."""
        centre, normal, width = door_geometry(door)
        n = normal * side  # the direction of travel through the door
        heading = math.atan2(n[1], n[0])
        grid = self.site.floor(floor).map
        occ = with_open_leaves(
            grid.occupied(self.planner.cfg.unknown_is_occupied), self.site, floor
        )
        occ = occ.copy()
        for other in self.site.doors:
            if other.floor == floor and other.id != door.id:
                block_segment(occ, grid, other.p1, other.p2, grid.resolution)
                # and its open leaf where it really stands, a cell thick each side
                # (with_open_leaves draws it a cell out of its opening, for paths through
                # it; campaign b2000.m08: a pass ended with the chair's front corner 3.7 cm
                # beside the open leaf of the next door in series, which the depth strip
                # missed by 1.5 cm)
                leaf = other.open_leaf()
                if leaf is not None:
                    block_segment(occ, grid, leaf[0], leaf[1], grid.resolution)
        # and what held the chair there, which the map lacks (world-differs campaign
        # b7002w.m05: a cupboard beside the approach pose; Phase 0 found no way to it)
        for p in self._points.get(floor, ()):
            block_segment(occ, grid, p, p, grid.resolution / 2)
        fp = self.planner.robot.footprint
        room = PoseRoom(
            fp.front,
            fp.rear,
            self.planner.robot.clearance_half_width_m,
            self.stop_distance_m,
            self.cfg.door_pose_margin_m,
        )
        reach = max(self.cfg.door_standoff_m, self.cfg.door_exit_m) + fp.front + fp.rear + 1.0
        origin = (grid.origin[0], grid.origin[1])

        # through the doorway (a wall's thickness and a frame) the strip keeps off the
        # jambs, which a map rasterised at its resolution may draw a cell or two inside
        doorway = (width / 2 - 2 * grid.resolution, DOORWAY_DEPTH_M)

        def depth(direction: np.ndarray) -> float:
            return free_depth(
                occ, grid.resolution, origin, centre, direction, room.half_width_m, reach, doorway
            )

        swings_left = door.swing == "left"
        towards_chair = door.motion == "hinged" and swings_left == (side < 0)
        leaf = width if towards_chair else 0.0
        wait_leaf = leaf
        if leaf > 0 and door.type == "manual":
            # behind a manual leaf only where the chair can get there (world-differs
            # b7200w.m04, b7101w.m07: a pose 7.5 and 10 cm beside a table, never reached),
            # or where that has a map cell more room a side than the pose in the sweep,
            # beside the open leaf (b8402.m05: 13.5 cm behind an 0.80 m door's sweep, 1.25
            # cm beside its leaf, where docking came to 1.5 cm from it)
            body = fp.front + fp.rear + room.margin_m
            beside_leaf = door.clear_width_m / 2 - room.half_width_m
            more = max(beside_leaf, 0.0) + grid.resolution
            side_m = room.half_width_m + min(self.cfg.door_leaf_wait_side_m, more)
            start = centre - n * (leaf + LEAF_CLEAR_M)  # the chair's front, waiting there
            if free_depth(occ, grid.resolution, origin, start, -n, side_m, body) < body:
                wait_leaf = 0.0
        before = approach_distance(depth(-n), self.cfg.door_standoff_m, room, wait_leaf)
        in_sweep = leaf > 0 and before - room.front_m < leaf + LEAF_CLEAR_M - 1e-6
        after = exit_distance(depth(n), self.cfg.door_exit_m, room)
        line = np.asarray(door.pass_centre)  # the free opening's middle (hinged: a leaf in it)
        approach = self._free_point(line, -n, before, floor, door.id)
        exit_ = self._free_point(line, n, after, floor, door.id)
        return Checkpoint(
            "door",
            door.id,
            floor,
            (approach[0], approach[1], heading),
            (exit_[0], exit_[1], heading),
            float(np.linalg.norm(np.asarray(exit_) - np.asarray(approach))),
            door.type,
            width,
            centre=(float(centre[0]), float(centre[1])),
            controller=door.controller,
            in_sweep=in_sweep,
            leaf_away=door.motion == "hinged" and not towards_chair,
        )

    def _free_point(
        self, centre: np.ndarray, direction: np.ndarray, distance: float, floor: str, door_id: str
    ) -> tuple[float, float]:
        """The point at ``distance`` along ``direction``, pulled in until it is free."""
        for d in np.arange(distance, 0.29, -0.1):
            p = centre + direction * d
            if self.planner.is_free((float(p[0]), float(p[1])), floor):
                return float(p[0]), float(p[1])
        raise errors.NoPath(
            f"door {door_id}: no free pose within {distance:.1f} m of it on one of its sides"
        )


def door_geometry(door: Door) -> tuple[np.ndarray, np.ndarray, float]:
    """Centre, unit normal (left of p1 -> p2) and width of a door segment."""
    p1, p2 = np.asarray(door.p1, float), np.asarray(door.p2, float)
    along = p2 - p1
    width = float(np.linalg.norm(along))
    normal = np.array([-along[1], along[0]]) / width
    return (p1 + p2) / 2, normal, width


def crossings(path: np.ndarray, doors: list[Door]) -> list[tuple[float, Door, int]]:
    """Doors whose segment the polyline ``path`` crosses: (arc position, door, +1/-1 side)."""
    found = []
    a, b = path[:-1], path[1:]
    seg_start = np.concatenate([[0.0], np.cumsum(np.linalg.norm(b - a, axis=1))])[:-1]
    for door in doors:
        p, q = np.asarray(door.p1, float), np.asarray(door.p2, float)
        d = b - a
        e = q - p
        denom = d[:, 0] * e[1] - d[:, 1] * e[0]
        with np.errstate(divide="ignore", invalid="ignore"):
            t = ((p[0] - a[:, 0]) * e[1] - (p[1] - a[:, 1]) * e[0]) / denom
            u = ((p[0] - a[:, 0]) * d[:, 1] - (p[1] - a[:, 1]) * d[:, 0]) / denom
        hit = np.flatnonzero((np.abs(denom) > 1e-12) & (t >= 0) & (t < 1) & (u >= 0) & (u <= 1))
        if len(hit):
            i = int(hit[0])
            _centre, normal, _w = door_geometry(door)
            side = 1 if float(np.dot(d[i], normal)) > 0 else -1
            found.append((float(seg_start[i] + t[i] * np.linalg.norm(d[i])), door, side))
    return sorted(found, key=lambda item: item[0])


def corridor_rooms(rooms: RoomMap, elongation: float = 3.0) -> set[int]:
    """Corridors: rooms whose bounding box is ``elongation`` times longer than wide."""
    out = set()
    for room in rooms.graph.nodes:
        cells = np.argwhere(rooms.labels == room)
        if len(cells) == 0:
            continue
        extent = (cells.max(axis=0) - cells.min(axis=0) + 1) * rooms.resolution
        long, short = max(extent), max(min(extent), 1e-6)
        if long / short >= elongation:
            out.add(room)
    return out
