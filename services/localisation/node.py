"""Localisation service: publishes the chair's pose on the current floor's map.

``localisation.mode: map`` (default) matches every LiDAR scan against the floor map and
uses odometry in between; ``odometry`` dead-reckons from the start pose. It is a
lockstep participant of the first stage, so the pose for a tick is out before the
controller acts on that tick. A pose that stops matching the map is flagged ``lost``
(the controller stops the chair) and searched for on the map until one pose fits
unambiguously (``relocalised`` events), or it stays lost and says why
(``relocalise_failed``); scans that see nothing leave the pose on odometry
(services/localisation/localiser.py).
It saves its pose (``shared.state_store``); restarted, it resumes from it
(``resume.py``) instead of the configured start pose.
"""

from __future__ import annotations

import math
import time

from services.localisation.localiser import MapLocaliser, MapModeSettings, OdometryLocaliser
from services.localisation.matcher import DistanceField
from services.localisation.relocalise import Relocalisation
from services.localisation.resume import SavedPose, resume_from
from shared.messages import Clock, Event, Odometry, PointCloud, Pose2D, PoseEstimate
from shared.scan_band import band_points
from shared.scan_band import warm_up as warm_band
from shared.service import Service
from shared.site import SiteError, load_site
from shared.state_store import StateStore

NAME = "localisation"


def search_event(found: Relocalisation) -> tuple[str, str, str]:
    """(kind, text, level) of the event reporting one search for the pose."""
    where = f"within {found.bounds.radius_m:.1f} m"
    if found.ok:
        x, y, theta = found.pose
        return (
            "relocalised",
            f"pose found by a search {where}: ({x:.2f}, {y:.2f}, "
            f"{math.degrees(theta):.0f} deg), {found.score:.0%} of the scan on walls, "
            f"{found.evaluations} evaluations",
            "info",
        )
    return "relocalise", f"no unambiguous pose {where}: {found.reason}", "warning"


def main(argv: list[str] | None = None) -> None:
    with Service(NAME, __doc__.splitlines()[0], argv) as svc:
        cfg, keys, bus = svc.cfg, svc.keys, svc.bus
        lc = cfg.localisation
        try:
            site = load_site(cfg.site)
            s = cfg.sim.start
            x, y, theta, floor = site.start_pose(s.place, s.x, s.y, s.theta, s.floor)
            if lc.mode == "map":
                field = DistanceField.for_floor(site, floor)
                loc = MapLocaliser(field, x, y, theta, floor, MapModeSettings.from_config(lc))
                loc.warm_up()
                warm_band()  # each scan's band is taken with it
            else:
                loc = OdometryLocaliser(x, y, theta, floor)
        except (SiteError, ValueError) as exc:
            svc.log.error("cannot start: %s", exc)
            raise SystemExit(2) from None
        pending: dict[str, object] = {}
        state = {
            "lost": False,
            "match_ms": 0.0,
            "saved_at": -float("inf"),
            "searches": 0,
            "given_up": "",
        }
        store = StateStore.from_env(NAME)
        saved: list[SavedPose | None] = [None]  # to resume from, until the first odometry
        try:
            raw = store.load()
            saved[0] = None if raw is None else SavedPose.from_dict(raw)
        except ValueError as exc:
            store.problem = str(exc)
        if store.problem:
            svc.log.warning("starting at the start pose: %s", store.problem)

        def on_odom(msg: Odometry) -> None:
            pending["odom"] = msg

        def on_scan(msg: PointCloud) -> None:
            pending["scan"] = msg

        fields: dict[str, DistanceField] = {}

        def on_initial(msg: PoseEstimate) -> None:
            p = msg.pose
            floor = p.floor or loc.floor
            try:
                if isinstance(loc, MapLocaliser) and floor not in fields:
                    fields[floor] = DistanceField.for_floor(site, floor)
                else:
                    site.floor(floor)  # a floor the site lacks is refused in either mode
            except SiteError as exc:
                svc.log.warning("initial pose refused: %s", exc)
                return
            if isinstance(loc, MapLocaliser):
                loc.reset(fields[floor], p.x, p.y, p.theta, floor)
            else:
                loc.reset(p.x, p.y, p.theta, floor)
            svc.log.info("pose set to (%.2f, %.2f, %.2f) on floor %s", p.x, p.y, p.theta, floor)

        def resume(odom: Odometry) -> None:
            """At the first odometry: carry on from the saved pose if it is this run's."""
            last, saved[0] = saved[0], None
            why = resume_from(last, odom.stamp, lc.resume_within_s)
            if why:
                if last is not None:
                    svc.log.info("starting at the start pose: %s", why)
                return
            try:
                if isinstance(loc, MapLocaliser):
                    f = fields.get(last.floor) or DistanceField.for_floor(site, last.floor)
                    fields[last.floor] = f
                    loc.reset(f, last.x, last.y, last.theta, last.floor, last.odom)
                else:
                    site.floor(last.floor)
                    loc.reset(last.x, last.y, last.theta, last.floor, last.odom)
            except SiteError as exc:
                svc.log.warning("starting at the start pose: saved pose refused: %s", exc)
                return
            text = (
                f"resumed from the pose saved at t = {last.stamp:.2f} s: "
                f"({last.x:.2f}, {last.y:.2f}) on floor {last.floor}"
            )
            svc.log.info("%s", text)
            bus.publish(
                keys.key("events", source=NAME), Event(odom.stamp, NAME, "resumed", text, "info")
            )

        def save(odom: Odometry) -> None:
            if odom.stamp - state["saved_at"] < lc.save_every_s and odom.stamp >= state["saved_at"]:
                return
            state["saved_at"] = odom.stamp
            p = odom.pose
            x, y, theta = loc.pose
            store.save(SavedPose(odom.stamp, x, y, theta, loc.floor, (p.x, p.y, p.theta)).to_dict())

        def event(stamp: float, kind: str, text: str, level: str) -> None:
            (svc.log.info if level == "info" else svc.log.warning)("%s", text)
            bus.publish(keys.key("events", source=NAME), Event(stamp, NAME, kind, text, level))

        def report_searches(stamp: float) -> None:
            """An event per search for the pose since the last scan, and one when it gave up."""
            new = min(loc.searches - state["searches"], len(loc.relocalisations))
            state["searches"] = loc.searches
            for found in loc.relocalisations[len(loc.relocalisations) - new :]:
                kind, text, level = search_event(found)
                event(stamp, kind, text, level)
            if loc.given_up and not state["given_up"]:
                event(stamp, "relocalise_failed", loc.given_up, "error")
            state["given_up"] = loc.given_up

        def step(clock: Clock) -> None:
            odom = pending.pop("odom", None)
            scan = pending.pop("scan", None)
            if odom is None:
                return
            if saved[0] is not None:
                resume(odom)
            if isinstance(loc, MapLocaliser):
                loc.update_odometry(odom.pose.x, odom.pose.y, odom.pose.theta)
                if scan is not None:
                    t0 = time.perf_counter()
                    # a 3-D cloud: keep the band around the sensor's height (walls, not the
                    # floor returns of the downward rings)
                    loc.update_scan(band_points(scan.points, lc.scan_band_m))
                    state["match_ms"] = 1000 * (time.perf_counter() - t0)
                    report_searches(odom.stamp)
                lost = loc.lost
            else:
                loc.update(odom.pose.x, odom.pose.y, odom.pose.theta)
                lost = False
            if lost != state["lost"]:
                state["lost"] = lost
                text = "scans match the map again"
                if lost:
                    why = loc.miss_reason
                    text = "scans no longer match the map" + (f" (the last: {why})" if why else "")
                bus.publish(
                    keys.key("events", source=NAME),
                    Event(
                        odom.stamp,
                        NAME,
                        "lost" if lost else "found",
                        text,
                        "error" if lost else "info",
                    ),
                )
                svc.log.warning("%s", text)
            x, y, theta = loc.pose
            bus.publish(
                pose_key,
                PoseEstimate(odom.stamp, Pose2D(x, y, theta, loc.floor), loc.covariance, lost),
            )
            save(odom)

        bus.subscribe(svc.declare("subscribes", keys.odom), Odometry, on_odom)
        bus.subscribe(svc.declare("subscribes", keys.scan), PointCloud, on_scan)
        bus.subscribe(svc.declare("subscribes", keys.initial_pose), PoseEstimate, on_initial)
        pose_key = svc.declare("publishes", keys.pose)
        svc.log.info("mode %s on floor %s", lc.mode, loc.floor)
        svc.every(lc.rate_hz, step)
        svc.wait()


if __name__ == "__main__":
    main()
