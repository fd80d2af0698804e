"""Building bridge service: an Open-RMF building's doors and lifts on wheelnav's building keys.

Where the building emulator serves the doors and lifts in simulation, this bridge serves
them from a real building run by Open-RMF (docs/building-bridge.md): the chair's
DoorRequest and LiftRequest on ``door_request`` / ``lift_request`` go out as CDR on the
building's ``adapter_door_requests`` / ``adapter_lift_requests``, and each CDR message on
``door_states`` / ``lift_states`` comes back as a DoorState / LiftState on ``door_state``
/ ``lift_state``. The Open-RMF topics are reached as zenoh-bridge-ros2dds or rmw_zenoh
names them (``rmf_bridge.key_format``, ``rmf_bridge.namespace``, ``rmf_bridge.domain_id``);
on rmw_zenoh keys each request carries the attachment rmw_zenoh_cpp's subscribers expect
(``rmf_bridge.rmw_zenoh_attachment``: services/rmf_bridge/attachment.py).
Only the site's doors with a controller and its lifts, only this chair's requests
(services/rmf_bridge/bridge.py). A request the chair stops renewing is ended when its lease
runs out (``building.door_session_lease_s``, ``building.lift_session_lease_s``), and
everything still held when the bridge stops. A bad message (malformed CDR, a value out of
range, a door or lift the site does not list) is dropped, counted and logged: the first 10
of each kind, then every 100th; an unlisted door or lift once per name (a building
reports all its doors, the site may map only some). Runs on wall time only (``clock: wall``).
"""

from __future__ import annotations

import sys
import time

import zenoh

from services.rmf_bridge.attachment import NONE, AttachmentWriter
from services.rmf_bridge.bridge import Outgoing, RmfBridge
from services.rmf_bridge.endpoints import NAME, PUBLISHES, ROS_PUBLISHES, ROS_SUBSCRIBES, SUBSCRIBES
from services.rmf_bridge.errors import KINDS, BridgeError, UnknownName
from services.rmf_bridge.ros_keys import (
    DOOR_STATES,
    LIFT_STATES,
    NAMESPACE_DEPTH,
    TOPICS,
    beyond_secured,
    ros_key,
)
from shared.config import ConfigError, FleetConfig
from shared.messages import Clock, DoorRequest, LiftRequest
from shared.service import EXIT_CONFIG, Service
from shared.site import load_site


def make_bridge(cfg: FleetConfig) -> RmfBridge:
    """The bridge for the fleet config's site and chair; ConfigError naming what is wrong."""
    section = cfg.rmf_bridge
    section.validate()
    if cfg.clock != "wall":
        raise ConfigError(f"clock: the building bridge runs on wall time, got {cfg.clock!r}")
    site = load_site(cfg.site)  # SiteError is a ConfigError
    try:
        return RmfBridge(
            robot=cfg.robot.name,
            doors=[d.id for d in site.doors if d.controller],
            lifts=[lift.id for lift in site.elevators],
            floors=list(site.floors),
            door_names=section.door_names,
            lift_names=section.lift_names,
            floor_names=section.floor_names,
            door_lease_s=cfg.building.door_session_lease_s,
            lift_lease_s=cfg.building.lift_session_lease_s,
        )
    except ValueError as exc:
        raise ConfigError(f"rmf_bridge: {exc}") from None


def main(argv: list[str] | None = None) -> None:
    with Service(NAME, __doc__.splitlines()[0], argv) as svc:
        cfg, keys, bus = svc.cfg, svc.keys, svc.bus
        try:
            bridge = make_bridge(cfg)
        except ConfigError as exc:
            print(f"wheelnav-{NAME}: config error: {exc}", file=sys.stderr)
            raise SystemExit(EXIT_CONFIG) from None
        section = cfg.rmf_bridge
        for names in (bridge.doors, bridge.lifts, bridge.floors):
            if names.unused:
                svc.log.warning(
                    "rmf_bridge.%s_names: no such %s in the site (or none the building"
                    " reports): %s",
                    names.kind,
                    names.kind,
                    ", ".join(names.unused),
                )
        if cfg.transport.security.dir and beyond_secured(section.key_format, section.namespace):
            svc.log.warning(
                "rmf_bridge.namespace %s: a secured router lets through namespaces of at most "
                "%d levels; the building's keys will be dropped (docs/building-bridge.md)",
                section.namespace,
                NAMESPACE_DEPTH,
            )
        ros = {
            t: ros_key(t, section.key_format, section.namespace, section.domain_id) for t in TOPICS
        }
        # requests are few and each matters (an OPEN, an END_SESSION): block, never drop
        publishers = {
            t: bus.session.declare_publisher(
                svc.declare("publishes", ros[t]), congestion_control=zenoh.CongestionControl.BLOCK
            )
            for t in ROS_PUBLISHES
        }
        # rmw_zenoh_cpp's subscribers drop a sample without its attachment; each publisher
        # numbers its own samples under a GID of its own, as rmw_zenoh_cpp's do
        layout = section.rmw_zenoh_attachment if section.key_format == "rmw_zenoh" else NONE
        attachments = {t: AttachmentWriter(layout) for t in ROS_PUBLISHES}

        def send(out: Outgoing) -> None:
            publishers[out.topic].put(out.payload, attachment=attachments[out.topic].next())
            if out.why:
                svc.log.warning("let go for the chair: %s", out.why)

        unknown: set[str] = set()  # each door or lift the site does not list: logged once

        def refused(where: str, exc: BridgeError) -> None:
            n = bridge.counts[exc.kind]
            if isinstance(exc, UnknownName):
                if str(exc) in unknown:
                    return
                unknown.add(str(exc))
            elif n > 10 and n % 100:
                return
            svc.log.warning("dropped a message on %s (%d %s so far): %s", where, n, exc.kind, exc)

        def requests(convert, name: str, field: str):
            """A handler sending the chair's requests out as ``convert`` makes them."""

            def on_request(req) -> None:
                try:
                    out = convert(req, time.time())
                except BridgeError as exc:
                    refused(keys.key(f"{name}_request", **{name: getattr(req, field)}), exc)
                    return
                if out is not None:
                    send(out)

            return on_request

        def states(convert, name: str, field: str):
            """A handler publishing the building's states as ``convert`` reads them."""

            def on_state(key: str, payload: bytes) -> None:
                try:
                    state = convert(payload, time.time())
                except BridgeError as exc:
                    refused(key, exc)
                    return
                bus.publish(keys.key(f"{name}_state", **{name: getattr(state, field)}), state)

            return on_state

        on_request = {
            "door_request": (DoorRequest, requests(bridge.door_request, "door", "door_name")),
            "lift_request": (LiftRequest, requests(bridge.lift_request, "lift", "lift_name")),
        }
        on_state = {
            DOOR_STATES: states(bridge.door_state, "door", "door_name"),
            LIFT_STATES: states(bridge.lift_state, "lift", "lift_name"),
        }

        def check_leases(clock: Clock) -> None:
            for out in bridge.expire(clock.stamp):
                send(out)

        # what it declares is what a secured router lets it do (endpoints.py)
        for name in SUBSCRIBES:
            bus.subscribe(svc.declare("subscribes", keys.key(name)), *on_request[name])
        for t in ROS_SUBSCRIBES:
            bus.subscribe_raw(svc.declare("subscribes", ros[t]), on_state[t])
        for name in PUBLISHES:
            svc.declare("publishes", keys.key(name))
        svc.log.info(
            "%d doors, %d lifts of site %s; building keys: %s, attachment: %s%s",
            len(bridge.doors),
            len(bridge.lifts),
            cfg.site,
            section.key_format,
            layout,
            "".join(f", {t.name} GID {a.gid.hex()}" for t, a in attachments.items())
            if layout != NONE
            else "",
        )
        svc.every(section.lease_check_hz, check_leases)
        try:
            svc.wait()
        finally:
            with bus.lock:
                for out in bridge.release_all(time.time()):
                    send(out)
            counts = bridge.counts
            svc.log.info(
                "%d states in, %d requests out, %d of other chairs, %d leases ended; dropped: %s",
                counts["states_in"],
                counts["requests_out"],
                counts["foreign"],
                counts["expired"],
                ", ".join(f"{counts[k]} {k}" for k in KINDS),
            )


if __name__ == "__main__":
    main()
