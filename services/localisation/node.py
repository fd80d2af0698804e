"""Localisation service: publishes the chair's pose on the floor map.

Odometry mode for now: the pose is the start pose moved by odometry increments. It is
a lockstep participant of the first stage, so the pose for a tick is out before the
controller acts on that tick.
"""

from __future__ import annotations

from services.localisation.core import OdometryLocaliser
from shared.messages import Clock, Odometry, Pose2D, PoseEstimate
from shared.service import Service
from shared.site import SiteError, load_site

NAME = "localisation"


def main(argv: list[str] | None = None) -> None:
    with Service(NAME, __doc__.splitlines()[0], argv) as svc:
        cfg, keys, bus = svc.cfg, svc.keys, svc.bus
        try:
            s = cfg.sim.start
            loc = OdometryLocaliser(
                *load_site(cfg.site).start_pose(s.place, s.x, s.y, s.theta, s.floor)
            )
        except SiteError as exc:
            svc.log.error("cannot start: %s", exc)
            raise SystemExit(2) from None
        latest: dict[str, Odometry] = {}

        def on_odom(msg: Odometry) -> None:
            latest["odom"] = msg

        def step(clock: Clock) -> None:
            odom = latest.pop("odom", None)
            if odom is None:
                return
            x, y, theta = loc.update(odom.pose.x, odom.pose.y, odom.pose.theta)
            floor = loc.floor or odom.pose.floor
            bus.publish(
                pose_key, PoseEstimate(odom.stamp, Pose2D(x, y, theta, floor), loc.covariance)
            )

        bus.subscribe(svc.declare("subscribes", keys.odom), Odometry, on_odom)
        pose_key = svc.declare("publishes", keys.pose)
        svc.every(50.0, step)
        svc.wait()


if __name__ == "__main__":
    main()
