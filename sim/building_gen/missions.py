"""Missions on a generated building, each with the outcome its construction implies.

A mission is a start pose, a goal place and the faults the building emulator plays
(doors stuck closed, lifts out of service or held by someone else). Whether the chair
can succeed is decided on the plan's topology (:class:`~sim.building_gen.topology.Topology`):
success when a route remains with the faulty doors and lifts taken out, failure when
none does. Each mission is written as a scenario ``wheelnav mission FILE`` runs.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import yaml

from sim.building_gen.options import MISSION_KINDS, GenOptions
from sim.building_gen.plan import BuildingPlan, PlaceSpec
from sim.building_gen.topology import Route, Topology

DOOR_TIMEOUT_S = 20.0  # navigator.door_timeout_s of stuck-door missions
LIFT_TIMEOUT_S = 30.0  # navigator.lift_timeout_s of busy-lift missions
LIFT_REASON = "lift|no route|elevator"
MAX_PAIRS = 400  # place pairs tried per mission before the kind counts as impossible

_MULTI = (
    "same_floor",
    "cross_floor",
    "door_stuck_alt",
    "door_stuck_no_way",
    "lift_out_of_service",
    "lift_busy",
    "lift_all_out_of_service",
    "same_floor",
)
_SINGLE = ("same_floor", "door_stuck_alt", "door_stuck_no_way", "same_floor", "door_stuck_alt")


@dataclass
class MissionSpec:
    """One mission: where from and to, what is broken, and what must happen."""

    name: str
    kind: str
    expect: str  # success | failure
    expect_reason: str | None  # regex the navigator's reason must match (failures)
    start: dict  # {x, y, theta, floor}
    goal: dict  # {place: NAME}
    start_place: str
    goal_place: str
    seed: int
    time_limit_s: float
    route_m: float
    description: str
    stuck_doors: list[str] = field(default_factory=list)
    lifts: dict[str, dict] = field(default_factory=dict)
    navigator: dict[str, float] = field(default_factory=dict)
    # people standing in the world the map does not show, as sim.pedestrians entries
    # (GenOptions.world_differs: those on the start's and the goal's floors)
    pedestrians: list[dict] = field(default_factory=list)

    def scenario(self, site: str, world_site: str | None = None) -> dict:
        """The scenario YAML content, with ``site`` (and ``world_site``, the world the
        simulator builds where it differs from the map) relative to the scenario's folder."""
        data: dict = {
            "name": self.name,
            "description": self.description,
            "kind": self.kind,
            "site": site,
            **({"world_site": world_site} if world_site else {}),
            "seed": self.seed,
            "time_limit_s": self.time_limit_s,
            "start": self.start,
            "goal": self.goal,
            "expect": self.expect,
        }
        if self.expect_reason:
            data["expect_reason"] = self.expect_reason
        config: dict = {}
        if self.navigator:
            config["navigator"] = dict(self.navigator)
        building: dict = {}
        if self.stuck_doors:
            building["doors"] = {
                d: {"start_open": False, "fault": "stuck_closed"} for d in self.stuck_doors
            }
        if self.lifts:
            building["lifts"] = {k: dict(v) for k, v in self.lifts.items()}
        if building:
            config["building"] = building
        if self.pedestrians:
            config["sim"] = {"pedestrians": [dict(p) for p in self.pedestrians]}
        if config:
            data["config"] = config
        return data


def time_limit(length_m: float, doors: int, rides: int, extra_s: float = 0.0) -> float:
    """A generous limit: 120 s + 1 s/m + 60 s per door + 150 s per lift ride (+ waits)."""
    total = 120.0 + length_m + 60.0 * doors + 150.0 * rides + extra_s
    return float(math.ceil(total / 10.0) * 10)


@dataclass
class _Draft:
    """What a mission maker found, before it is named and numbered."""

    kind: str
    start: PlaceSpec
    goal: PlaceSpec
    route: Route
    expect: str = "success"
    reason: str | None = None
    stuck: list[str] = field(default_factory=list)
    lifts: dict[str, dict] = field(default_factory=dict)
    navigator: dict[str, float] = field(default_factory=dict)
    limit_s: float = 0.0
    note: str = ""


class MissionPlanner:
    """Chooses missions on a plan; all randomness from ``rng``."""

    def __init__(self, plan: BuildingPlan, topo: Topology, rng: np.random.Generator) -> None:
        self.plan, self.topo, self.rng = plan, topo, rng
        self.places = [p for f in plan.floors for p in f.places]
        self.makers: dict[str, Callable[[], _Draft | None]] = {
            "same_floor": self._same_floor,
            "cross_floor": self._cross_floor,
            "door_stuck_alt": self._door_stuck_alt,
            "door_stuck_no_way": self._door_stuck_no_way,
            "lift_out_of_service": lambda: self._lift_fault("lift_out_of_service"),
            "lift_busy": lambda: self._lift_fault("lift_busy"),
            "lift_all_out_of_service": self._lift_all_out,
        }
        self.series_wanted = True

    def kinds(self, opts: GenOptions) -> list[str]:
        """The kinds to draw, in order: ``mission_kinds`` or the default mix."""
        if opts.mission_kinds:
            return [k for k in MISSION_KINDS for _ in range(opts.mission_kinds.get(k, 0))]
        cycle = _MULTI if len(self.plan.floors) > 1 else _SINGLE
        return [cycle[i % len(cycle)] for i in range(opts.missions)]

    def plan_missions(self, opts: GenOptions, seed: int) -> list[MissionSpec]:
        """Draw the missions; a kind this building cannot offer becomes a same_floor one."""
        out: list[MissionSpec] = []
        for kind in self.kinds(opts):
            draft = self.makers[kind]()
            if draft is None:
                draft = self._same_floor() or self._cross_floor()
            if draft is not None:
                out.append(self._finish(draft, len(out), seed))
        return out

    # ---- helpers -----------------------------------------------------------------------

    def _pairs(self, keep: Callable[[PlaceSpec, PlaceSpec], bool]) -> Iterator[tuple]:
        """Place pairs (start, goal) passing ``keep``, in random order."""
        pairs = [(a, b) for a in self.places for b in self.places if a is not b and keep(a, b)]
        for i in self.rng.permutation(len(pairs))[:MAX_PAIRS]:
            yield pairs[int(i)]

    def _finish(self, d: _Draft, index: int, seed: int) -> MissionSpec:
        s = d.start
        start = {
            "x": round(s.x, 3),
            "y": round(s.y, 3),
            "theta": round(float(self.rng.uniform(-math.pi, math.pi)), 4),
            "floor": s.floor,
        }
        via = ", ".join(d.route.doors) or "no door"
        rides = f"; lifts {', '.join(d.route.lifts)}" if d.route.lifts else ""
        description = (
            f"{d.kind}: {s.name} -> {d.goal.name} via {via}{rides} "
            f"(about {d.route.length_m:.0f} m){d.note}; expect {d.expect}"
        )
        limit = d.limit_s or time_limit(d.route.length_m, len(d.route.doors), len(d.route.lifts))
        return MissionSpec(
            name=f"{self.plan.name}_m{index:02d}_{d.kind}",
            kind=d.kind,
            expect=d.expect,
            expect_reason=d.reason,
            start=start,
            goal={"place": d.goal.name},
            start_place=s.name,
            goal_place=d.goal.name,
            seed=(seed * 100 + index) % 2**31,
            time_limit_s=limit,
            route_m=d.route.length_m,
            description=description,
            stuck_doors=d.stuck,
            lifts=d.lifts,
            navigator=d.navigator,
        )

    # ---- the kinds ---------------------------------------------------------------------

    def _same_floor(self) -> _Draft | None:
        """Place to place on one floor through at least one door (doors in series first)."""
        series = {inner for f in self.plan.floors for _, inner, _ in f.series}
        if self.series_wanted and series:
            self.series_wanted = False
            for a, b in self._pairs(lambda a, b: a.floor == b.floor and b.kind == "inner"):
                route = self.topo.route(a, b)
                if route and route.doors and not route.lifts:
                    return _Draft("same_floor", a, b, route, note=" through doors in series")
        for a, b in self._pairs(lambda a, b: a.floor == b.floor and a.area != b.area):
            route = self.topo.route(a, b)
            if route and route.doors and not route.lifts:
                return _Draft("same_floor", a, b, route)
        return None

    def _cross_floor(self) -> _Draft | None:
        for a, b in self._pairs(lambda a, b: a.floor != b.floor):
            route = self.topo.route(a, b)
            if route and route.lifts:
                return _Draft("cross_floor", a, b, route)
        return None

    def _door_stuck_alt(self) -> _Draft | None:
        """A door on the natural route stuck closed, with another way round."""
        spare = self.topo.spare_doors()
        if not spare:
            return None
        for a, b in self._pairs(lambda a, b: a.area != b.area):
            route = self.topo.route(a, b)
            doors = [d for d in route.doors if d in spare] if route else []
            for i in self.rng.permutation(len(doors)):
                door = doors[int(i)]
                alt = self.topo.route(a, b, doors=frozenset({door}))
                if alt is None:
                    continue
                extra = DOOR_TIMEOUT_S + alt.length_m + 60.0 * len(alt.doors)
                limit = time_limit(route.length_m, len(route.doors), len(alt.lifts), extra)
                return _Draft(
                    "door_stuck_alt",
                    a,
                    b,
                    route,
                    stuck=[door],
                    navigator={"door_timeout_s": DOOR_TIMEOUT_S},
                    limit_s=limit,
                    note=f"; {door} stuck closed, way round via {', '.join(alt.doors)}",
                )
        return None

    def _door_stuck_no_way(self) -> _Draft | None:
        """The only door into the goal's room stuck closed: the chair must give up."""
        for a, b in self._pairs(lambda a, b: a.area != b.area):
            door = self.topo.single_door(b.area)
            if door is None:
                continue
            route = self.topo.route(a, b)
            if not route or self.topo.route(a, b, doors=frozenset({door})) is not None:
                continue
            limit = time_limit(route.length_m, len(route.doors), len(route.lifts), DOOR_TIMEOUT_S)
            return _Draft(
                "door_stuck_no_way",
                a,
                b,
                route,
                expect="failure",
                reason=door,
                stuck=[door],
                navigator={"door_timeout_s": DOOR_TIMEOUT_S},
                limit_s=limit,
                note=f"; {door}, the only door in, stuck closed",
            )
        return None

    def _lift_fault(self, kind: str) -> _Draft | None:
        """The lift of the natural route out of service or held; another one still serves."""
        for a, b in self._pairs(lambda a, b: a.floor != b.floor):
            route = self.topo.route(a, b)
            if not route or not route.lifts:
                continue
            lift = route.lifts[0]
            alt = self.topo.route(a, b, lifts=frozenset({lift}))
            if alt is None:
                continue
            if kind == "lift_busy":
                behaviour, nav = {"busy_until_s": 100000.0}, {"lift_timeout_s": LIFT_TIMEOUT_S}
                extra, note = LIFT_TIMEOUT_S + 150.0, "held by another user"
            else:
                behaviour, nav, extra, note = {"fault": "out_of_service"}, {}, 0.0, "out of service"
            extra += alt.length_m + 60.0 * len(alt.doors)
            limit = time_limit(route.length_m, len(route.doors), len(alt.lifts), extra)
            return _Draft(
                kind,
                a,
                b,
                route,
                lifts={lift: behaviour},
                navigator=nav,
                limit_s=limit,
                note=f"; {lift} {note}, {', '.join(alt.lifts)} still serves",
            )
        return None

    def _lift_all_out(self) -> _Draft | None:
        """Every lift that could take the chair to the goal's floor out of service."""
        for a, b in self._pairs(lambda a, b: a.floor != b.floor):
            route = self.topo.route(a, b)
            if not route:
                continue
            both = [x.id for x in self.plan.lifts if a.floor in x.floors and b.floor in x.floors]
            out = frozenset(both)
            if self.topo.route(a, b, lifts=out) is not None:
                out = frozenset(x.id for x in self.plan.lifts if b.floor in x.floors)
            if self.topo.route(a, b, lifts=out) is not None:
                continue
            ids = sorted(out)
            limit = time_limit(route.length_m, len(route.doors), 0, 150.0)
            return _Draft(
                "lift_all_out_of_service",
                a,
                b,
                route,
                expect="failure",
                reason=LIFT_REASON,
                lifts={x: {"fault": "out_of_service"} for x in ids},
                limit_s=limit,
                note=f"; {', '.join(ids)} out of service, no way up or down",
            )
        return None


def write_missions(
    missions: list[MissionSpec], folder: Path, site: str = "..", world_site: str | None = None
) -> list[Path]:
    """One scenario YAML per mission in ``folder`` (stale ones removed); their paths.
    ``world_site``: the world the simulator builds instead of ``site``, if it differs."""
    folder.mkdir(parents=True, exist_ok=True)
    for old in sorted(folder.glob("*.yaml")):
        old.unlink()
    paths = []
    for i, m in enumerate(missions):
        path = folder / f"m{i:02d}_{m.kind}.yaml"
        path.write_text(yaml.safe_dump(m.scenario(site, world_site), sort_keys=False, width=100))
        paths.append(path)
    return paths
