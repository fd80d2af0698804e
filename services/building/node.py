"""Building emulator service: plays the site's doors and lifts over Open-RMF's protocol.

Publishes each door's DoorState and each lift's LiftState on every change and at
``building.state_rate_hz``, takes DoorRequest/LiftRequest, and (simulation only) tells
the simulator where the door leaves and lift cars are. Automatic doors sense the chair
through the simulator's ground truth: the building is part of the simulated world, not
a navigation service. A lockstep participant of the first stage.
"""

from __future__ import annotations

import numpy as np

from services.building.emulator import Building
from shared.messages import (
    BuildingBodies,
    Clock,
    DoorRequest,
    DoorState,
    LiftRequest,
    Odometry,
)
from shared.service import Service
from shared.site import SiteError, load_site

NAME = "building"


def main(argv: list[str] | None = None) -> None:
    with Service(NAME, __doc__.splitlines()[0], argv) as svc:
        cfg, keys, bus = svc.cfg, svc.keys, svc.bus
        try:
            building = Building(load_site(cfg.site), cfg.building)
        except (SiteError, ValueError) as exc:
            svc.log.error("cannot start: %s", exc)
            raise SystemExit(2) from None
        clock = {"now": 0.0, "last_all": -1e9, "bodies_at": -1e9}

        def on_door_request(req: DoorRequest) -> None:
            if not building.request_door(clock["now"], req):
                svc.log.warning(
                    "request for unknown door %r from %s", req.door_name, req.requester_id
                )

        def on_lift_request(req: LiftRequest) -> None:
            refusal = building.request_lift(clock["now"], req)
            if refusal:
                svc.log.warning("lift request refused: %s", refusal)

        def on_truth(msg: Odometry) -> None:
            building.chair(msg.stamp, msg.pose.x, msg.pose.y, msg.pose.floor, msg.v)

        def publish(state) -> None:
            if isinstance(state, DoorState):
                bus.publish(keys.key("door_state", door=state.door_name), state)
            else:
                bus.publish(keys.key("lift_state", lift=state.lift_name), state)

        def step(c: Clock) -> None:
            now = clock["now"] = c.stamp
            building.update(now)
            for lift in building.lifts.values():
                while lift.expired:
                    at, session = lift.expired.pop(0)
                    svc.log.warning(
                        "lift %s: session %r let go at %.1f s, no request for %g s (its lease)",
                        lift.name,
                        session,
                        at,
                        cfg.building.lift_session_lease_s,
                    )
            for state in building.changed_states(now):
                publish(state)
            if now - clock["last_all"] >= 1.0 / cfg.building.state_rate_hz:
                clock["last_all"] = now
                for state in building.all_states(now):
                    publish(state)
            bodies = building.bodies(now)
            moved = _moved(bodies, clock.get("bodies"))
            if moved or now - clock["bodies_at"] >= 1.0 / cfg.building.state_rate_hz:
                # only what moved, each tick; everything at the state rate (a restarted sim)
                bus.publish(bodies_key, bodies)
                clock["bodies"], clock["bodies_at"] = bodies, now

        bus.subscribe(
            svc.declare("subscribes", keys.key("door_request")), DoorRequest, on_door_request
        )
        bus.subscribe(
            svc.declare("subscribes", keys.key("lift_request")), LiftRequest, on_lift_request
        )
        bus.subscribe(svc.declare("subscribes", keys.ground_truth), Odometry, on_truth)
        bodies_key = svc.declare("publishes", keys.key("building_bodies"))
        svc.declare("publishes", keys.key("door_state"))
        svc.declare("publishes", keys.key("lift_state"))
        svc.log.info("%d doors, %d lifts", len(building.doors), len(building.lifts))
        svc.every(cfg.building.rate_hz, step)
        svc.wait()


def _moved(bodies: BuildingBodies, last: BuildingBodies | None) -> bool:
    """Whether a door leaf, car or car door is somewhere else than in ``last``."""
    return last is None or not (
        np.array_equal(bodies.door_openings, last.door_openings)
        and np.array_equal(bodies.car_elevations, last.car_elevations)
        and np.array_equal(bodies.lift_door_openings, last.lift_door_openings)
    )


if __name__ == "__main__":
    main()
