"""Pure-pursuit path following on an ideal unicycle (no simulator needed)."""

from __future__ import annotations

import math

import numpy as np

from services.controller.pure_pursuit import PathFollower
from shared.config import ControllerConfig, RobotConfig


def drive(
    follower: PathFollower, x: float, y: float, th: float, steps: int = 2000, dt: float = 0.04
):
    track = []
    cmd = None
    for _ in range(steps):
        cmd = follower.step(x, y, th)
        if cmd.state == "arrived":
            break
        x += cmd.v * dt * math.cos(th)
        y += cmd.v * dt * math.sin(th)
        th += cmd.w * dt
        track.append((x, y, cmd.cross_track))
    return x, y, cmd, np.array(track)


def test_follows_an_l_shaped_path_to_the_goal() -> None:
    f = PathFollower(ControllerConfig(), RobotConfig())
    pts = np.array([[0, 0], [4, 0], [4, 3]], dtype=float)
    f.set_path("p1", pts, np.array([0.5, 0.5, 0.0]))
    x, y, cmd, track = drive(f, 0.0, 0.0, 0.0)
    assert cmd.state == "arrived"
    assert math.hypot(x - 4, y - 3) <= ControllerConfig().goal_tolerance_m
    assert np.abs(track[:, 2]).max() < 0.5


def test_turns_on_the_spot_when_facing_away() -> None:
    f = PathFollower(ControllerConfig(), RobotConfig())
    f.set_path("p", np.array([[0.0, 0.0], [3.0, 0.0]]), np.array([0.5, 0.0]))
    cmd = f.step(0.0, 0.0, math.pi)
    assert cmd.v == 0.0 and abs(cmd.w) > 0


def test_idle_and_stale_pose_give_zero_command() -> None:
    f = PathFollower(ControllerConfig(), RobotConfig())
    assert f.step(0, 0, 0).state == "idle"
    f.set_path("p", np.array([[0.0, 0.0], [3.0, 0.0]]), np.array([0.5, 0.0]))
    cmd = f.step(0.0, 0.0, 0.0, pose_fresh=False)
    assert (cmd.v, cmd.w, cmd.state) == (0.0, 0.0, "stale")


def test_speed_limits_respected() -> None:
    robot = RobotConfig(max_speed=0.3, max_turn_rate=0.5)
    f = PathFollower(ControllerConfig(), robot)
    f.set_path("p", np.array([[0.0, 0.0], [5.0, 2.0]]), np.array([2.0, 0.0]))
    cmd = f.step(0.0, 0.0, 0.3)
    assert cmd.v <= 0.3 and abs(cmd.w) <= 0.5


def test_drives_a_path_backwards() -> None:
    f = PathFollower(ControllerConfig(), RobotConfig())
    f.set_path("out", np.array([[0.0, 0.0], [-2.0, 0.0]]), np.array([0.2, 0.0]), reverse=True)
    x, y, th = 0.0, 0.0, 0.0  # facing +x, the path goes to -x: back out
    speeds = []
    for _ in range(400):
        cmd = f.step(x, y, th)
        if cmd.state == "arrived":
            break
        speeds.append(cmd.v)
        x += cmd.v * 0.04 * np.cos(th)
        y += cmd.v * 0.04 * np.sin(th)
        th += cmd.w * 0.04
    assert cmd.state == "arrived" and abs(x + 2.0) <= 0.15
    assert max(speeds) <= 0 and min(speeds) >= -RobotConfig().max_reverse_speed
    assert abs(th) < 0.1  # never turned round


def test_a_path_shorter_than_the_goal_tolerance_ends_at_once() -> None:
    # campaign b1003.m04: a re-plan after a recovery gave a 0.156 m leg; the chair stood
    # within the goal tolerance of its end, so it was given no speed, but not half way
    # along it, so it was never "arrived": it stood "following" for 357 s until the
    # mission's limit.
    f = PathFollower(ControllerConfig(), RobotConfig())
    f.set_path("p", np.array([[0.0, 0.0], [0.08, 0.06], [0.13, 0.06]]), np.array([0.5, 0.5, 0.0]))
    cmd = f.step(0.0, 0.0, 0.2)
    assert cmd.state == "arrived", cmd
