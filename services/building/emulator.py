"""The building emulator's core: every door and lift of a site, stepped together.

Builds a :class:`~services.building.doors.DoorSim` per declared door and a
:class:`~services.building.lifts.LiftSim` per elevator from the site and the
``building`` config (per-id behaviours and faults from the scenario), routes requests
to them, feeds automatic doors the chair's presence, and says which states changed.
Pure: the node supplies time, requests and the chair's pose.
"""

from __future__ import annotations

import math

import numpy as np

from services.building.doors import DoorSim, DoorTiming
from services.building.lifts import LiftSim
from shared.config import BuildingConfig, DoorBehaviour, LiftBehaviour
from shared.messages import (
    BuildingBodies,
    DoorRequest,
    DoorState,
    LiftDoor,
    LiftRequest,
    LiftRequestType,
    LiftState,
)
from shared.site import Site

OTHER_SESSION = "another-user"


class Building:
    """All doors and lifts of one site."""

    def __init__(self, site: Site, cfg: BuildingConfig) -> None:
        known = {d.id for d in site.doors}
        lifts_known = {e.id for e in getattr(site, "elevators", [])}
        for name in cfg.doors:
            if name not in known:
                raise ValueError(f"building.doors.{name}: no such door in site {site.name}")
        for name in cfg.lifts:
            if name not in lifts_known:
                raise ValueError(f"building.lifts.{name}: no such elevator in site {site.name}")
        self.cfg = cfg
        timing = DoorTiming(hold_open_s=cfg.hold_open_s)
        self.doors: dict[str, DoorSim] = {}
        for door in site.doors:
            b = cfg.doors.get(door.id, DoorBehaviour())
            start_open = cfg.starts_open(door.id, door.type)
            self.doors[door.id] = DoorSim(
                door,
                cfg.motion_of(door.id, door.motion),
                timing,
                b.fault or None,
                [(e.at_s, e.action) for e in b.schedule],
                start_open,
                cfg.door_session_lease_s,
            )
        self.door_floor = {d.id: d.floor for d in site.doors}
        self.lifts: dict[str, LiftSim] = {}
        self._busy: dict[str, tuple[float, str]] = {}  # lift -> (when the other user lets
        # it go, the floor it holds the car at)
        for lift in getattr(site, "elevators", []):
            b = cfg.lifts.get(lift.id, LiftBehaviour())
            floors = {f: site.floor(f).elevation for f in lift.floors}
            start = b.start_floor or lift.floors[0]
            self.lifts[lift.id] = LiftSim(
                lift.id,
                floors,
                start,
                fault=b.fault or None,
                session_lease_s=cfg.lift_session_lease_s,
            )
            if b.busy_until_s > 0:  # someone else holds it, doors shut, from the start
                self.lifts[lift.id].request(0.0, self._other(lift.id, start))
                self._busy[lift.id] = (b.busy_until_s, start)

    def request_door(self, now: float, req: DoorRequest) -> bool:
        """Pass a door request on; False if no such door."""
        door = self.doors.get(req.door_name)
        if door is None:
            return False
        door.request(now, req)
        return True

    def request_lift(self, now: float, req: LiftRequest) -> str | None:
        """Pass a lift request on; the refusal reason, or None if accepted."""
        lift = self.lifts.get(req.lift_name)
        if lift is None:
            return f"no lift called {req.lift_name!r}"
        return lift.request(now, req)

    def chair(self, now: float, x: float, y: float, floor: str, speed: float) -> None:
        """Tell automatic doors whether the chair moves inside their sensor zone."""
        for name, door in self.doors.items():
            if door.door.type != "automatic" or self.door_floor[name] != floor:
                continue
            cx = (door.door.p1[0] + door.door.p2[0]) / 2
            cy = (door.door.p1[1] + door.door.p2[1]) / 2
            near = math.hypot(x - cx, y - cy) <= self.cfg.sensor_range_m
            door.set_presence(now, near and abs(speed) > 0.02)

    @staticmethod
    def _other(lift_id: str, floor: str, end: bool = False) -> LiftRequest:
        """A request of the other user of a busy lift (``building.lifts.<id>.busy_until_s``)."""
        kind = LiftRequestType.END_SESSION if end else LiftRequestType.AGV_MODE
        return LiftRequest(0.0, lift_id, OTHER_SESSION, kind, floor, LiftDoor.CLOSED)

    def update(self, now: float) -> None:
        for name, (until, floor) in list(self._busy.items()):
            if now >= until:
                self.lifts[name].request(now, self._other(name, "", end=True))
                del self._busy[name]
            else:  # the other user is alive: it keeps its lease
                self.lifts[name].request(now, self._other(name, floor))
        for door in self.doors.values():
            door.update(now)
        for lift in self.lifts.values():
            lift.update(now)

    def changed_states(self, now: float) -> list[DoorState | LiftState]:
        """States of the doors and lifts whose reported state changed since the last call."""
        out: list[DoorState | LiftState] = []
        out += [d.state(now) for d in self._reporting() if d.changed()]
        out += [lift.state(now) for lift in self.lifts.values() if lift.changed()]
        return out

    def all_states(self, now: float) -> list[DoorState | LiftState]:
        return [d.state(now) for d in self._reporting()] + [
            lift.state(now) for lift in self.lifts.values()
        ]

    def _reporting(self) -> list[DoorSim]:
        """The doors with a controller (the site's ``controller`` key): only they report."""
        return [d for d in self.doors.values() if d.door.controller]

    def bodies(self, now: float) -> BuildingBodies:
        names = list(self.lifts)
        return BuildingBodies(
            now,
            list(self.doors),
            np.array([d.opening for d in self.doors.values()], float),
            names,
            np.array([self.lifts[n].car_elevation for n in names], float),
            np.array([self.lifts[n].door_opening for n in names], float),
        )
