"""Controller service: turns the current path and pose into velocity commands.

Steps at ``controller.rate_hz`` of fleet time (a lockstep participant after the
localisation), publishes a Twist and a FollowStatus every step. A pose older than
``controller.pose_timeout_s`` gives a zero command.
"""

from __future__ import annotations

from services.controller.core import PathFollower
from shared.messages import Clock, FollowStatus, Path, PoseEstimate, Twist
from shared.service import Service

NAME = "controller"


def main(argv: list[str] | None = None) -> None:
    with Service(NAME, __doc__.splitlines()[0], argv) as svc:
        cfg, keys, bus = svc.cfg, svc.keys, svc.bus
        follower = PathFollower(cfg.controller, cfg.robot)
        latest: dict[str, PoseEstimate] = {}

        def on_pose(msg: PoseEstimate) -> None:
            latest["pose"] = msg

        def on_path(msg: Path) -> None:
            follower.set_path(msg.path_id, msg.waypoints, msg.v_ref, msg.reverse)
            svc.log.info("path %s: %d waypoints", msg.path_id or "(stop)", len(msg.waypoints))

        def step(clock: Clock) -> None:
            pose = latest.get("pose")
            if pose is None:
                cmd_v, cmd_w, state = 0.0, 0.0, "no_pose"
                status = FollowStatus(clock.stamp, follower.path_id, state, 0.0, 0.0, 0.0)
            else:
                fresh = clock.stamp - pose.stamp <= cfg.controller.pose_timeout_s and not pose.lost
                p = pose.pose
                cmd = follower.step(p.x, p.y, p.theta, fresh)
                cmd_v, cmd_w = cmd.v, cmd.w
                status = FollowStatus(
                    clock.stamp,
                    follower.path_id,
                    cmd.state,
                    cmd.progress,
                    cmd.distance_to_goal,
                    cmd.cross_track,
                )
            bus.publish(cmd_key, Twist(clock.stamp, cmd_v, cmd_w))
            bus.publish(status_key, status)

        bus.subscribe(svc.declare("subscribes", keys.pose), PoseEstimate, on_pose)
        bus.subscribe(svc.declare("subscribes", keys.path), Path, on_path)
        cmd_key = svc.declare("publishes", keys.cmd_vel)
        status_key = svc.declare("publishes", keys.follow_status)
        svc.every(cfg.controller.rate_hz, step)
        svc.wait()


if __name__ == "__main__":
    main()
