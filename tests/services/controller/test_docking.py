"""Docking (Phase 0 position correction) in closed loop with a chair model with motor lag."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pytest

from services.controller.docking import Docker, DockLimits
from shared.config import ControllerConfig, NavigatorConfig, RobotConfig
from shared.geometry import wrap_angle

RATE = 25.0
DOCK = DockLimits.from_config(ControllerConfig(), RobotConfig())  # the fleet's limits
LAG_S = 0.25  # first-order motor lag, as the simulator's chair


@dataclass
class Drive:
    """Where the model ended and how it got there."""

    x: float
    y: float
    th: float
    t: float  # seconds
    top: float  # the largest |v|
    turned: float  # radians turned in all
    arrived: bool


def drive(
    docker: Docker,
    x: float,
    y: float,
    th: float,
    limit_s: float = 20.0,
    obstacles: np.ndarray | None = None,
    poses: list[tuple[float, float, float]] | None = None,
) -> Drive:
    """Drive the model (first-order motor lag) until the docker reports arrival or the
    limit; ``obstacles`` (N, 2) are the points the docker is given every cycle; ``poses``
    gets every pose driven through."""
    v = w = top = turned = t = 0.0
    dt = 1.0 / RATE
    while t < limit_s:
        if poses is not None:
            poses.append((x, y, th))
        cmd = docker.step(x, y, th, obstacles=obstacles, period_s=dt)
        if cmd.state == "arrived":
            return Drive(x, y, th, t, top, turned, True)
        v += (cmd.v - v) * dt / LAG_S
        w += (cmd.w - w) * dt / LAG_S
        top, turned = max(top, abs(v)), turned + abs(w) * dt
        x, y, th = x + v * math.cos(th) * dt, y + v * math.sin(th) * dt, th + w * dt
        t += dt
    return Drive(x, y, th, t, top, turned, False)


def run(docker: Docker, x: float, y: float, th: float, limit_s: float = 20.0):
    """Drive the model without points; (x, y, th, seconds, max |v|)."""
    d = drive(docker, x, y, th, limit_s)
    return d.x, d.y, d.th, d.t, d.top


# the seed's Phase 0 tests: target 2.5 m in front of the door (goal at the origin facing +x,
# door at x = 2.5), chair 2.0 m / 3.0 m from the door, 15 deg off, 2.2 m and 10 deg off
SEED_CASES = {
    "too_close_2.0m": (0.5, 0.0, 0.0),
    "too_far_3.0m": (-0.5, 0.0, 0.0),
    "angle_15deg": (0.0, 0.0, math.radians(15)),
    "2.2m_10deg": (0.3, 0.0, math.radians(10)),
}


@pytest.mark.parametrize("case", sorted(SEED_CASES))
def test_seed_cases_end_within_tolerance_in_under_10_s(case: str) -> None:
    docker = Docker(DOCK)
    docker.set_goal(0.0, 0.0, 0.0)
    x, y, th, t, _ = run(docker, *SEED_CASES[case])
    assert math.hypot(x, y) <= 0.15
    assert abs(math.degrees(th)) <= 5.0
    assert t < 10.0


def test_a_sideways_error_is_driven_out_too() -> None:
    docker = Docker(DOCK)
    docker.set_goal(0.0, 0.0, 0.0)
    x, y, th, t, _ = run(docker, -0.3, 0.4, 0.0)  # two turns of 53 deg and 0.5 m
    assert math.hypot(x, y) <= 0.05 + 0.01 and abs(math.degrees(th)) <= 1.0 + 0.5
    assert t < 15.0


def test_backs_up_to_a_target_behind_instead_of_turning_round() -> None:
    docker = Docker(DOCK)
    docker.set_goal(0.0, 0.0, 0.0)
    cmd = docker.step(0.5, 0.0, 0.0)
    assert cmd.v < 0.0 and abs(cmd.w) < 1e-9


def test_speed_cap_holds_for_idle_motion() -> None:
    docker = Docker(DOCK)
    docker.set_goal(-0.12, 0.0, 0.0, max_speed=0.05)
    x, y, th, t, top = run(docker, 0.0, 0.0, 0.0)
    assert top <= 0.05 + 1e-9
    assert abs(x + 0.12) <= 0.05 and t < 10.0


def test_stale_pose_and_no_goal_give_zero() -> None:
    docker = Docker(DOCK)
    assert docker.step(0.0, 0.0, 0.0).state == "idle"
    docker.set_goal(1.0, 0.0, 0.0)
    cmd = docker.step(0.0, 0.0, 0.0, pose_fresh=False)
    assert (cmd.v, cmd.w, cmd.state) == (0.0, 0.0, "stale")


def test_a_pose_across_the_corridor_facing_the_other_way_turns_first_then_backs_up() -> None:
    # facing a closed car door 1.5 m ahead; the goal is 0.5 m nearer it, facing away
    docker = Docker(DOCK)
    docker.set_goal(0.0, 0.5, -math.pi / 2)
    first = docker.step(0.0, 0.0, math.pi / 2)
    assert first.v == 0.0 and abs(first.w) > 0  # turns on the spot first
    x, y, th, t, _ = run(docker, 0.0, 0.0, math.pi / 2)
    assert math.hypot(x, y - 0.5) <= 0.05 + 0.01
    assert abs(math.degrees(wrap_angle(th + math.pi / 2))) <= 1.5
    assert t < 20.0


def test_a_target_just_short_of_a_wall_is_reached_without_nosing_into_it() -> None:
    """Seen in a generated building: 0.26 m from its door pose, facing the target with a
    wall a few centimetres beyond the front's reach, the docker drove forwards into the
    stop zone for ever. With the points in hand it drives the other way or turns first."""
    fp = RobotConfig().footprint
    docker = Docker(DOCK, fp, 0.05)
    docker.set_goal(0.0, 0.0, -math.pi / 2 - 0.3)  # face -y (a door below), forwards nearer
    wall_x = -(fp.front + 0.04)  # a wall 4 cm beyond the front of a chair at the goal facing -x
    wall = np.array([[wall_x, y] for y in np.arange(-2.0, 2.0, 0.05)])
    cmd = docker.step(0.26, 0.0, math.pi, obstacles=wall)  # facing -x, the target ahead
    assert cmd.v <= 0.0  # never forwards into the wall
    without = Docker(DOCK)
    without.set_goal(0.0, 0.0, -math.pi / 2 - 0.3)
    assert without.step(0.26, 0.0, math.pi).v > 0.0  # blind, it drove on


def test_stall_watch_calls_a_leg_blocked_only_without_progress() -> None:
    from services.controller.tracking import StallWatch

    watch = StallWatch(after_s=15.0, progress_m=0.1)
    dist, t = 5.0, 0.0
    while t < 40.0:  # steady progress: never stalled
        dist -= 0.3 * 0.04
        assert not watch.update(dist, 0.04)
        t += 0.04
    stalled_at = None
    for k in range(1000):  # wobbling on the spot for 40 s
        if watch.update(dist + 0.05 * math.sin(k / 5), 0.04) and stalled_at is None:
            stalled_at = k * 0.04
    assert stalled_at is not None and 14.5 <= stalled_at <= 15.5
    watch.reset()
    assert not watch.update(dist, 0.04)


def test_near_the_target_it_does_not_spin_to_face_it() -> None:
    # found by the campaign (b1.m04): stopped by the guard 6 cm short of a target before a
    # door beside a wall, the move stage turned on the spot to face it, then round to back
    # up to it, for 20 s. Within near_m it hands over to the final stage instead.
    docker = Docker(DOCK)
    docker.set_goal(0.0, 0.0, math.pi / 2)
    docker.step(0.0, -0.4, math.radians(70))  # a move from 0.4 m
    cmd = docker.step(0.05, -0.03, math.radians(64))  # 6 cm off, the target 30 deg aside
    assert cmd.v == 0.0 and cmd.w > 0  # turning to the goal heading (90 deg), not away
    assert docker.stage == "final"


def test_a_turn_on_the_spot_goes_the_other_way_round_when_a_corner_would_sweep_a_wall() -> None:
    # campaign b0.m03: in the small room between two doors in series, the turn the short
    # way swung a corner into the open leaf beside it and the guard held it for ever. The
    # rear corners sweep nearly the whole circle of their radius on the long way (270
    # deg), so only a point off the front can be one that the long way leaves alone.
    from shared.config import RobotConfig as Robot

    fp = Robot().footprint
    leaf = np.array([[0.7 * math.cos(a), 0.7 * math.sin(a)] for a in np.radians([38, 40, 42])])
    docker = Docker(DOCK, fp, 0.05)
    docker.set_goal(0.0, 0.0, math.pi / 2)  # a quarter turn left, on the spot
    cmd = docker.step(0.0, 0.0, 0.0, obstacles=leaf)
    # turning left, the front-right corner (0.76 ahead, 0.325 aside) swings into it: go
    # right, where neither front corner comes near it in 270 deg
    turned = docker.step(0.0, 0.0, 0.0, obstacles=leaf)
    assert cmd.w < 0 and turned.w < 0
    clear = Docker(DOCK, fp, 0.05)
    clear.set_goal(0.0, 0.0, math.pi / 2)
    assert clear.step(0.0, 0.0, 0.0, obstacles=np.zeros((0, 2))).w > 0  # the short way


def dock_in_series_room(
    start: tuple[float, float, float],
    goal: tuple[float, float, float],
    keep_out: np.ndarray | None = None,
):
    """Dock in campaign b4.m07's room between two doors in series with the controller's
    safety checks on the room's points in the loop (``keep_out``: the doorway ahead, as the
    navigator sends it); (command, x, y, th, t, nearest gap)."""
    from tests.services.controller.test_manoeuvre import series_room

    occ, (ox, oy) = series_room()
    r, c = np.nonzero(occ)
    walls = np.column_stack((ox + (c + 0.5) * 0.05, oy + (r + 0.5) * 0.05))
    return dock_with_guard(walls, start, goal, keep_out, cell_m=0.05)


def dock_with_guard(
    walls: np.ndarray,
    start: tuple[float, float, float],
    goal: tuple[float, float, float],
    keep_out: np.ndarray | None = None,
    cell_m: float = 0.0,
    v0: float = 0.0,
    truth: np.ndarray | None = None,
    seen: bool = False,
    checks: bool = True,
):
    """Dock among the points ``walls`` with the controller's safety checks in the loop
    (``keep_out``: the doorway ahead, as the navigator sends it); (command, x, y, th, t,
    nearest gap), the gap less half of ``cell_m`` where the points are cell centres.
    ``v0``: the chair's speed at the start (a pass hands over still rolling); ``truth``:
    the points the gap is measured to, where ``walls`` are them as a scan sees them;
    ``seen``: docking and the checks get only the points of ``walls`` a LiDAR at the rear
    axle sees from each pose (:func:`_visible`), not those hidden behind others;
    ``checks``: False runs docking's commands as they are, without the safety checks."""
    from services.controller.safety import guard

    robot, cfg = RobotConfig(), ControllerConfig()
    docker = Docker(DOCK, robot.footprint, robot.side_margin_m)
    docker.set_goal(*goal, keep_out=keep_out)
    (x, y, th), v, w = start, v0, 0.0
    dt, t, nearest = 1.0 / RATE, 0.0, math.inf
    while t < 90.0:
        near = walls[np.hypot(walls[:, 0] - x, walls[:, 1] - y) < 3.0]
        if seen:
            near = _visible(near, x, y)
        cmd = docker.step(x, y, th, obstacles=near, period_s=dt)
        if cmd.state == "arrived":
            break
        dx, dy = near[:, 0] - x, near[:, 1] - y
        local = np.column_stack(
            (dx * math.cos(th) + dy * math.sin(th), -dx * math.sin(th) + dy * math.cos(th), 0 * dx)
        )
        margin = docker.turn_margin(robot.side_margin_m, cfg.precise_side_margin_m)  # as the node
        cv, cw = cmd.v, cmd.w
        if checks:
            cv, cw, _ = guard(
                cmd.v,
                cmd.w,
                cmd.state,
                t,
                True,
                t,
                local,
                robot,
                cfg,
                1.0,
                True,
                margin,
                cmd.turn_left_rad,
            )
        v += (cv - v) * dt / LAG_S
        w += (cw - w) * dt / LAG_S
        x, y, th = x + v * math.cos(th) * dt, y + v * math.sin(th) * dt, th + w * dt
        fp = robot.footprint
        body = local[:, :2]
        if truth is not None:
            tx, ty = truth[:, 0] - x, truth[:, 1] - y
            body = np.column_stack(
                (tx * math.cos(th) + ty * math.sin(th), -tx * math.sin(th) + ty * math.cos(th))
            )
        gap = np.hypot(
            np.maximum(np.maximum(-fp.rear - body[:, 0], body[:, 0] - fp.front), 0),
            np.maximum(np.abs(body[:, 1]) - fp.width / 2, 0),
        )
        nearest = min(nearest, float(gap.min()) - cell_m / 2)
        t += dt
    return cmd, x, y, th, t, nearest


def _visible(points: np.ndarray, x: float, y: float, bin_deg: float = 1.0) -> np.ndarray:
    """The ``points`` a LiDAR at (x, y) sees: in each ``bin_deg`` of bearing, those within
    2 cm of the nearest (the world's edges sampled every 5 mm: 0.3 deg at 1 m)."""
    dx, dy = points[:, 0] - x, points[:, 1] - y
    r = np.hypot(dx, dy)
    a = np.floor(np.degrees(np.arctan2(dy, dx)) / bin_deg).astype(int)
    order = np.lexsort((r, a))
    a_s, r_s = a[order], r[order]
    first = np.r_[True, a_s[1:] != a_s[:-1]]
    nearest = np.maximum.accumulate(np.where(first, np.arange(len(a_s)), 0))
    return points[order[r_s <= r_s[nearest] + 0.02]]


def test_between_two_doors_in_series_it_manoeuvres_where_it_cannot_turn() -> None:
    """Campaign b4.m07: the room between two doors in series is 2.08 x 2.0 m; from the
    first door's exit pose to the second door's approach pose (0.8 m to the right, facing
    the same way) neither pose leaves room to turn on the spot, and the safety checks held
    every turn-drive-turn: the chair stood until the recoveries gave up. Here the docker
    runs with those same safety checks on the room's points."""
    cmd, x, y, th, t, nearest = dock_in_series_room((1.01, 1.33, 0.0), (1.19, 0.53, 0.0))
    assert cmd.state == "arrived", (round(t, 1), round(x, 2), round(y, 2), round(th, 2))
    assert math.hypot(x - 1.19, y - 0.53) <= DOCK.position_tolerance_m
    assert abs(wrap_angle(th)) <= DOCK.heading_tolerance_rad + 1e-3
    assert nearest > 0.0  # never touched a wall


def test_at_the_goal_point_but_turned_away_it_manoeuvres_where_it_cannot_turn() -> None:
    """Campaign b5.m03: in the room between two doors in series the chair backed up onto
    the second door's approach point facing 90 deg off, where neither way round fits; the
    docker planned no manoeuvre because the point was reached (only the heading was not)
    and the safety checks held the turn until the recoveries gave up."""
    cmd, x, y, th, t, nearest = dock_in_series_room((0.6, 0.5, 1.6), (0.6, 0.5, 0.0))
    assert cmd.state == "arrived", (round(t, 1), round(x, 2), round(y, 2), round(th, 2))
    assert math.hypot(x - 0.6, y - 0.5) <= DOCK.position_tolerance_m
    assert abs(wrap_angle(th)) <= DOCK.heading_tolerance_rad + 1e-3
    assert nearest > 0.0


@pytest.mark.parametrize("start", [(0.55, 0.69, 0.0), (0.75, 0.69, 0.0), (0.45, 0.7, 0.0)])
def test_beside_the_goal_line_with_no_room_to_sidestep_it_manoeuvres_onto_it(start) -> None:
    """Campaign b1004.m04: after the first of two doors in series the chair stood 0.157 m
    beside the second door's approach pose, facing the right way; a sidestep would back
    into the first door's jambs, so the docker called it arrived as it stood, three times,
    and Phase 0 failed the mission 7 mm outside its 0.15 m tolerance."""
    goal = (0.6, 0.53, 0.0)
    cmd, x, y, th, t, nearest = dock_in_series_room(start, goal)
    assert cmd.state == "arrived", (round(t, 1), round(x, 2), round(y, 2), round(th, 2))
    assert abs(y - goal[1]) <= DOCK.near_m, round(y - goal[1], 3)
    assert math.hypot(x - goal[0], y - goal[1]) <= 0.1
    assert abs(wrap_angle(th)) <= DOCK.heading_tolerance_rad + 1e-3
    assert nearest > 0.05


@pytest.mark.parametrize("start", [(0.6, 0.627, 0.0), (0.55, 0.44, 0.0)])
def test_beside_the_line_of_a_narrow_door_it_manoeuvres_onto_it(start) -> None:
    """World-differs campaign b7104w.m00: an 0.80 m door drawn 0.097 m along its wall from
    where it stands; lining up on the door seen, the chair stood 0.097 m beside the moved
    approach pose with no room behind for a sidestep. Under ``near_m`` across, the docker
    called it arrived as it stood, and the pass was held by the jamb three times, as an
    0.80 m door leaves 7.5 cm a side. Before a doorway (``keep_out``) what is left across
    is at most a quarter of the slack the doorway leaves: half the slack a side."""
    goal = (0.6, 0.53, 0.0)
    doorway = np.array([[2.08, 0.13, 2.08, 0.93]])  # 0.80 m, centred on the goal's line
    cmd, x, y, th, t, nearest = dock_in_series_room(start, goal, doorway)
    assert cmd.state == "arrived", (round(t, 1), round(x, 2), round(y, 2), round(th, 2))
    slack = (0.80 - RobotConfig().footprint.width) / 2
    assert abs(y - goal[1]) <= slack / 2, round(y - goal[1], 3)
    assert abs(wrap_angle(th)) <= DOCK.heading_tolerance_rad + 1e-3
    assert nearest > 0.0


@pytest.mark.parametrize("start", [(0.0, 0.045, 0.0), (0.03, -0.07, 0.03), (-0.02, 0.09, -0.05)])
def test_a_sideways_error_before_a_door_is_taken_out_by_a_sidestep(start) -> None:
    """Campaign (camp12): 14 of 21 door clearances under their limit came as the chair's
    front entered the doorway 4-5 cm beside its centre line: the final stage left the
    error across the heading (up to near_m) for the pass's pursuit, which had 0.1 m of
    travel to take it out. Here the docker backs up slantwise onto the line and drives
    forwards along it: what is left across is within ``dock_lateral_tolerance_m``."""
    fp = RobotConfig().footprint
    docker = Docker(DOCK, fp, 0.05)
    docker.set_goal(0.0, 0.0, 0.0)
    x, y, th, t, _ = run(docker, *start, limit_s=30.0)
    assert abs(y) <= DOCK.lateral_tolerance_m + 1e-3, (round(x, 3), round(y, 3), round(t, 1))
    assert math.hypot(x, y) <= DOCK.position_tolerance_m + 0.01
    assert abs(wrap_angle(th)) <= DOCK.heading_tolerance_rad + 0.01
    assert t < 15.0


def test_no_sidestep_where_there_is_no_room_behind() -> None:
    """A wall 3 cm behind the chair's rear: the sidestep would back into it; the docker
    ends where it stands, the error across left to the pass (as before)."""
    fp = RobotConfig().footprint
    wall = np.array([[-fp.rear - 0.03 - 0.05, yy] for yy in np.arange(-1.0, 1.0, 0.02)])
    docker = Docker(DOCK, fp, 0.05)
    docker.set_goal(0.0, 0.0, 0.0)
    x = y = th = 0.0
    y = 0.045
    for _ in range(200):
        cmd = docker.step(x, y, th, obstacles=wall)
        assert cmd.v >= 0.0
        if cmd.state == "arrived":
            break
    assert cmd.state == "arrived"


def test_a_turn_nearly_done_checks_only_what_is_left_of_it() -> None:
    """Campaign b3.m03: in a small room, 14 deg short of its heading, the docker checked a
    15 deg turn, found a corner sweeping near the open leaf, turned the long way round
    (340 deg) and ran out Phase 0's 20 s. A point that only a turn further than what is
    left would come near does not send it the long way."""
    fp = RobotConfig().footprint
    point = np.array([[0.7011, 0.5094]])  # left of the front: a 15 deg left turn nears it
    docker = Docker(DOCK, fp, 0.05)
    docker.set_goal(0.0, 0.0, math.radians(10))  # 10 deg to the left: the short way
    cmd = docker.step(0.0, 0.0, 0.0, obstacles=point)
    assert cmd.v == 0.0 and cmd.w > 0.0


def test_a_long_sidestep_beside_a_wall_keeps_a_slant_that_fits() -> None:
    """Campaign b8.m08: 17 cm beside the approach line of an 0.80 m door, a corridor wall
    0.45 m to the other side of the line. Backing up 20 deg slantwise would put the rear
    corner into that wall, so the move stage drove straight back and forth along the
    heading, the error across unchanged, until Phase 0's limit. A shallower slant, backing
    up further, fits."""
    fp = RobotConfig().footprint
    ys = np.arange(-3.0, 3.0, 0.02)
    wall = np.column_stack((np.arange(-3.0, 1.0, 0.02), np.full(200, -0.45)))
    front = np.array([[x, y] for x in (0.9, 1.0, 1.1) for y in ys if abs(y) > 0.4])
    pts = np.vstack((wall, front))
    docker = Docker(DOCK, fp, 0.05)
    docker.set_goal(0.0, 0.0, 0.0)
    d = drive(docker, 0.0, 0.17, 0.0, 30.0, pts)
    x, y, th, t = d.x, d.y, d.th, d.t
    assert d.arrived, (round(t, 1), round(x, 2), round(y, 3), round(th, 2))
    assert abs(y) <= DOCK.lateral_tolerance_m + 1e-3, (round(x, 3), round(y, 3), round(t, 1))


def test_a_target_a_hand_away_is_not_faced_the_long_way_round() -> None:
    """Campaign b0.m07: the path follower left the chair 13 cm short of the approach pose,
    5 cm aside and 11 deg off, a wall (and an open leaf) ahead-left. Facing the target
    was a short turn towards the wall, so the docker went 330 deg the long way round, and
    again, until Phase 0's 20 s ran out. Within a hand's reach the final stage (turn to
    the heading, drive along, sidestep) does it with small turns."""
    fp = RobotConfig().footprint
    wall = np.array([[x, 0.55] for x in np.arange(0.3, 1.5, 0.02)])
    docker = Docker(DOCK, fp, 0.05)
    docker.set_goal(0.0, 0.0, 0.0)
    d = drive(docker, -0.128, -0.052, 0.197, 30.0, wall)
    assert d.arrived and d.t < 12.0, (round(d.t, 1), round(d.x, 3), round(d.y, 3))
    assert math.degrees(d.turned) < 90.0, math.degrees(d.turned)
    assert abs(d.y) <= DOCK.lateral_tolerance_m + 1e-3


def test_arriving_sideways_in_a_narrow_corridor_it_drives_onto_the_line_before_turning() -> None:
    """Campaign b0.m00 at 045f845: a door in the side of a corridor whose far wall is 0.73 m
    behind the approach point; the leg left the chair 12.6 cm short of the door's line,
    facing along the corridor 67 deg off the door. The final stage turned to the heading
    on the spot, and a sidestep had no room behind (the corridor's far wall): it arrived
    12.6 cm across, and the pass swung the nose within 9 cm of a jamb of the 0.90 m door
    (limit 9.5 cm). The error across the goal heading lies along the heading the chair
    has: drive it out first, then turn."""
    fp = RobotConfig().footprint
    grid = [(x, y) for x in np.arange(-1.5, 1.5, 0.05) for y in np.arange(-1.5, 1.5, 0.05)]
    pts = np.array(
        [
            (x, y)
            for x, y in grid
            if (x <= -0.73 and y <= 0.12)  # the corridor's far wall, behind on the right
            or (0.52 <= x <= 0.92 and abs(y) >= 0.87)  # a recess before the door's wall
            or (0.97 <= x <= 1.12 and abs(y) >= 0.47)  # the door's wall (b0's map, cells)
        ]
        + [(1.045, y) for y in np.arange(-0.45, 0.46, 0.02)]  # the door, closed
    )
    docker = Docker(DOCK, fp, 0.05)
    docker.set_goal(0.0, 0.0, 0.0)
    d = drive(docker, -0.014, 0.126, math.radians(-67), 30.0, pts)
    assert d.arrived, (round(d.t, 1), round(d.x, 3), round(d.y, 3), round(d.th, 2))
    assert abs(d.y) <= DOCK.lateral_tolerance_m + 1e-3, (round(d.x, 3), round(d.y, 3))
    assert d.t < 12.0


def test_far_from_the_goal_the_final_stage_does_not_shift_across() -> None:
    """Campaign b4.m04 at 618c17e: a target 2.1 m away that did not fit the margin sent
    the move stage to the final stage (boxed in both ways), whose drive along the heading
    to take out the error across, meant for a goal within reach, backed the chair 0.2 m
    away from the corridor it was to enter. Far from the goal it turns first (the move
    stage towards the target, nearly the goal's heading, whose own footprint holds the
    wall whichever way the chair drives there), and never backs away."""
    fp = RobotConfig().footprint
    wall = np.array([[0.37, y] for y in np.arange(-1.0, 1.0, 0.02)])  # 4.5 cm beside it
    docker = Docker(DOCK, fp, 0.05)
    docker.set_goal(0.0, 0.0, math.pi / 2)
    cmd = docker.step(0.2, -2.1, math.radians(10), obstacles=wall)
    assert cmd.v == 0.0 and cmd.w > 0.0  # turning towards the goal, not driving
    poses: list[tuple[float, float, float]] = []
    # 20.5 s since the drive there is checked along its way (a manoeuvre onto the line)
    end = drive(docker, 0.2, -2.1, math.radians(10), 30.0, obstacles=wall, poses=poses)
    assert end.arrived, end
    assert min(y for _, y, _ in poses) >= -2.1 - 0.01  # never backed away from the goal


def test_a_turn_is_not_sent_the_long_way_round_into_what_stands_behind() -> None:
    """Campaign b3.m03 at 65eb10a: 12 deg short of its heading before a door, the short
    way would sweep a corner near a point; the docker checked the first 15 deg of the
    long way only and turned 345 deg the other way round, where the guard stopped it
    twice 4.3 cm from a wall (the campaign's 5 cm limit away from doors). The long way
    is taken only if the whole of it is clear."""
    fp = RobotConfig().footprint
    ahead_left = np.array([[0.68, 0.45]])  # a 12 deg left turn brings the corner to it
    behind = np.array([[-0.75, y] for y in np.arange(-0.3, 0.31, 0.02)])  # a wall behind
    docker = Docker(DOCK, fp, 0.05)
    docker.set_goal(0.0, 0.0, math.radians(12))
    cmd = docker.step(0.0, 0.0, 0.0, obstacles=np.vstack((ahead_left, behind)))
    assert cmd.v == 0.0 and cmd.w == 0.0  # neither way keeps the margin: a stop to plan
    cmd = docker.step(0.0, 0.0, 0.0, obstacles=np.vstack((ahead_left, behind)), period_s=0.1)
    assert cmd.v < 0.0 and cmd.w == 0.0  # a manoeuvre: back up from the point first
    # a half turn: the first 15 deg of 170 to the left bring the front-left corner to a
    # point 35 deg off the nose that 190 deg to the right never comes near: taken
    left = np.array([[0.75 * math.cos(math.radians(35)), 0.75 * math.sin(math.radians(35))]])
    half = Docker(DOCK, fp, 0.05)
    half.set_goal(0.0, 0.0, math.radians(170))
    assert half.step(0.0, 0.0, 0.0, obstacles=left).w < 0.0


B10_START = (40.23, 7.58, math.radians(-168))  # in the room between d1_012 and d1_011


def b10_series_room(leaves: bool) -> tuple[tuple, tuple, np.ndarray]:
    """Generated building 10's floor 1 as camp22 drew it (before the vestibule rule and the
    furniture's passage beside open leaves): d1_011's p1, width and leaf thickness, its
    approach pose (facing +y) and the map's LiDAR scan from ``B10_START`` (the open leaves
    drawn in with ``leaves``), saved in ``tests/fixtures/manoeuvre/b10_series_room_scan.npz``."""
    from pathlib import Path

    scan = np.load(Path(__file__).parents[2] / "fixtures/manoeuvre/b10_series_room_scan.npz")
    points = scan["leaves_mm" if leaves else "walls_mm"] / 1000.0
    door = (tuple(scan["p1"]), float(scan["width"]), float(scan["leaf_thickness"]))
    return door, tuple(scan["goal"]), points


def across_after_planning(goal, points) -> tuple[float, str]:
    """How far across the goal's line the docker's manoeuvre from ``B10_START`` ends (the
    goal faces +y: across is along x), and its note."""
    docker = Docker(DOCK, RobotConfig().footprint, RobotConfig().side_margin_m)
    docker.set_goal(*goal)
    docker.step(*B10_START, obstacles=points, period_s=0.1)
    docker._plan(*B10_START, points)
    assert docker._via, docker.plan_note
    return abs(docker._via[-1][0] - goal[0]), docker.plan_note


def test_a_manoeuvre_that_reaches_the_goal_at_a_smaller_margin_beats_one_that_stops_short() -> None:
    """Camp22 b10.m00 (generated building 10): in the room between doors d1_012 and d1_011
    in series, d1_011's 0.95 m leaf open into it, the approach pose did not fit at the
    search's first margin (0.08 m) and that search ended at any pose within its 0.15 m
    slack, 0.13 m beside the door's line; the docker took it and Phase 0 failed three
    times, "not within 0.15 m". At 0.05 m the pose fits and the manoeuvre ends on the
    line: that one is taken."""
    _door, goal, points = b10_series_room(leaves=True)
    across, note = across_after_planning(goal, points)
    assert across <= 0.05, note


def test_a_manoeuvre_onto_a_pose_beside_a_leaf_seen_through_range_noise() -> None:
    """Camp22 b10.m00 again, with the leaf as the simulator's LiDAR shows it: its face
    9 cm beyond the chair's side at the approach pose, the points scattered up to 5 cm
    nearer by range noise. On 5 cm cells grown by the margin and half a cell the pose did
    not fit even at 0.025 m; a last search at no margin (the grid is conservative, the
    guard keeps its own) ends on the door's line."""
    (p1, width, thickness), goal, walls = b10_series_room(leaves=False)
    rng = np.random.default_rng(3)
    face = p1[0] - thickness / 2  # the leaf stands along x = p1's, inward
    ys = rng.uniform(p1[1] - width, p1[1], 2500)
    leaf = np.column_stack((face - np.abs(rng.normal(0.0, 0.015, ys.size)), ys))
    across, note = across_after_planning(goal, np.vstack((walls, leaf)))
    assert across <= 0.05, note


def _wall(x1: float, y1: float, x2: float, y2: float) -> np.ndarray:
    n = max(2, int(math.hypot(x2 - x1, y2 - y1) / 0.025) + 1)
    return np.column_stack([np.linspace(x1, x2, n), np.linspace(y1, y2, n)])


def test_a_manoeuvre_before_a_door_stays_on_its_side_of_the_door() -> None:
    # camp23 b6.m04: from one door's exit to the next door's approach across a 1.8 m deep
    # room (doors in series), the manoeuvre went out through the open doorway it was to
    # pass next and turned in it, 0.076 m from a jamb where 0.182 m was needed. The door
    # it docks before is a wall to the manoeuvre (``keep_out``).
    from shared.config import RobotConfig as Robot

    points = np.vstack(
        [
            _wall(12.75, 24.4, 12.75, 25.3),  # the room's west wall, the doorway (1.1 m)
            _wall(12.75, 26.4, 12.75, 27.6),
            _wall(12.5, 23.0, 12.5, 25.3),  # its far face, on the corridor
            _wall(12.5, 26.4, 12.5, 29.0),
            _wall(12.5, 25.3, 12.75, 25.3),  # the jambs
            _wall(12.5, 26.4, 12.75, 26.4),
            _wall(10.9, 23.0, 10.9, 29.0),  # the corridor's far wall
            _wall(14.55, 24.4, 14.55, 26.3),  # the east wall and the door just passed
            _wall(14.55, 27.2, 14.55, 27.6),
            _wall(12.75, 24.4, 14.55, 24.4),
            _wall(12.75, 27.6, 14.55, 27.6),
            _wall(12.65, 25.275, 13.75, 25.275),  # the door's leaf, open into the room
            _wall(12.65, 25.325, 13.75, 25.325),
        ]
    )
    door = np.array([[12.65, 25.3, 12.65, 26.4]])
    docker = Docker(DOCK, Robot().footprint, 0.05)
    docker.set_goal(13.65, 25.8625, math.pi, keep_out=door)
    poses: list[tuple[float, float, float]] = []
    end = drive(docker, 13.81, 26.75, math.pi, 90.0, obstacles=points, poses=poses)
    fp = Robot().footprint
    front = [x + fp.front * math.cos(th) for x, _y, th in poses]
    assert min(front) > 12.75 - 0.05  # its nose never past the room's wall into the doorway
    assert end.arrived and math.hypot(end.x - 13.65, end.y - 25.8625) <= DOCK.position_tolerance_m


def test_the_turn_check_keeps_the_wide_margin_until_a_manoeuvre_is_searched_for() -> None:
    # camp23 b2.m00: at a door 10 cm from a room's corner the turn onto the approach heading
    # passes 4.65 cm from the wall; held at 5 cm, the docker searches a manoeuvre, and where
    # its conservative grid finds none the turn itself is the last way left (2 cm)
    from shared.config import RobotConfig as Robot

    docker = Docker(DOCK, Robot().footprint, 0.05)
    assert docker.turn_margin(0.05, 0.02) == 0.05  # idle
    docker.set_goal(0.0, 0.0, math.pi / 2)
    assert docker.turn_margin(0.05, 0.02) == 0.05  # docking, no search yet
    boxed = np.vstack([_wall(-0.6, -0.5, -0.6, 0.5), _wall(0.9, -0.5, 0.9, 0.5)])
    docker._plan(0.0, 0.0, 0.0, boxed)  # a search, whatever it finds
    assert docker.turn_margin(0.05, 0.02) == 0.02
    docker.clear()
    assert docker.turn_margin(0.05, 0.02) == 0.05


def test_a_goal_beside_a_leaf_is_driven_to_facing_it_not_turned_round_for() -> None:
    """Door bench (0.80 m hinged, map 10 cm off, stop-turn-go lining up on the door seen):
    after the sidestep the goal lay 0.4 m ahead with an open leaf 3 cm beside the front of
    a chair standing there. The footprint at the goal facing the way it drove held the
    leaf, so the docker turned round to back up to it, and as range noise moved the
    leaf's points in and out of its margin it flipped between the two for 20 s. Where the
    goal's own footprint holds a point, the way of driving cannot avoid it: it drives to
    the goal facing it."""
    fp = RobotConfig().footprint
    leaf = np.array([[x, fp.width / 2 + 0.03] for x in np.arange(0.42, 1.2, 0.02)])
    docker = Docker(DOCK, fp, 0.05)
    docker.set_goal(0.0, 0.0, 0.0)
    end = drive(docker, -0.40, -0.01, 0.05, limit_s=20.0, obstacles=leaf)
    assert end.arrived, end
    assert end.turned < math.pi / 2, end  # never round to face away


def test_beside_a_door_line_and_a_leaf_seen_through_range_noise_it_manoeuvres_onto_it() -> None:
    """World-differs b7200w.m04: lined up on the door the map draws, the chair stood 0.11 m
    beside the line of the 1.0 m door it saw, 5.5 cm from the face of the leaf standing
    open towards it, with the room behind and to the left free. The search found a way at
    0.025 m on the map's walls, but none through the scan's range noise (1 cm): on 5 cm
    cells every point counts as its whole cell and the pose as anywhere in its own, 7 cm
    added to the margin, and a point scattered into the next cell takes 5 cm more; the
    pass was held by the leaf until three recoveries gave up."""
    rng = np.random.default_rng(7)

    def surface(x1: float, y1: float, x2: float, y2: float) -> np.ndarray:
        line = np.repeat(_wall(x1, y1, x2, y2), 4, axis=0)  # four rings see each spot
        return line + rng.normal(0.0, 0.01, line.shape)

    points = np.vstack(
        [
            surface(12.0, 22.4, 13.8, 22.4),  # the wall with the doorway (13.8 to 14.8)
            surface(14.8, 22.4, 16.9, 22.4),
            surface(13.8, 22.4, 13.8, 22.6),  # its jambs
            surface(14.8, 22.4, 14.8, 22.6),
            surface(14.77, 22.4, 14.77, 21.4),  # the leaf, open towards the chair
            surface(16.9, 18.5, 16.9, 22.4),  # the room's east wall
            surface(14.8, 19.45, 14.8, 20.45),  # a table behind on the right
            surface(14.8, 20.45, 15.4, 20.45),
            surface(12.4, 20.2, 12.4, 20.6),  # a cabinet on the left
        ]
    )
    doorway = np.array([[13.8, 22.4, 14.8, 22.4]])
    goal = (14.3, 21.4, math.pi / 2)
    cmd, x, y, th, t, nearest = dock_with_guard(
        points, (14.39, 21.36, math.radians(91)), goal, doorway
    )
    assert cmd.state == "arrived", (round(t, 1), round(x, 2), round(y, 2), round(th, 2))
    slack = (1.0 - RobotConfig().footprint.width) / 2
    assert abs(x - goal[0]) <= slack / 4, round(x - goal[0], 3)
    assert abs(wrap_angle(th - goal[2])) <= DOCK.heading_tolerance_rad + 1e-3
    assert nearest > 0.0


def test_in_a_corner_by_a_door_it_manoeuvres_where_the_search_needs_more_than_60k_poses() -> None:
    """Campaign b6005.m00: the approach pose of an 0.80 m door stands 0.55 m from the wall
    at the room's corner, and the chair, held on its way there, was sent to it by a
    recovery. The points are the controller's scan at that moment. A manoeuvre exists, but
    the search at the first margin needs 97k expansions and at the second 67k; each was
    cut at 60k and together they used up the 120k budget, so "no manoeuvre": the chair
    turned to the goal heading where it stood, drove along it and stopped 0.79 m beside
    the pose, three times, and the mission failed."""
    from pathlib import Path

    scan = np.load(Path(__file__).parents[2] / "fixtures/manoeuvre/b6005_corner_scan.npz")
    points = scan["points_mm"] / 1000.0
    start, goal = tuple(scan["pose"]), tuple(scan["goal"])
    cmd, x, y, th, t, nearest = dock_with_guard(points, start, goal)
    assert cmd.state == "arrived", (round(t, 1), round(x, 2), round(y, 2), round(th, 2))
    assert math.hypot(x - goal[0], y - goal[1]) <= DOCK.position_tolerance_m, (x, y)
    assert abs(wrap_angle(th - goal[2])) <= DOCK.heading_tolerance_rad + 1e-3
    assert nearest > 0.0


@pytest.mark.parametrize(
    "start",
    [(24.6, 43.9, -1.6818), (24.45, 44.65, math.radians(-78)), (24.596, 44.65, -3.029)],
    ids=["mission_start", "manoeuvre_start", "held_6_deg_off"],
)
def test_the_last_degrees_of_a_turn_beside_an_open_leaf_are_not_held(
    start: tuple[float, float, float],
) -> None:
    """World-differs campaign b7300w.m04: the approach pose of a hinged door stands 1 m
    before it in the room, with the open leaf 0.4 m to the right of the chair's front and a
    wall's corner behind on the same side. The docker's last turn on the spot, 6.5 deg to
    go, swept clear, but the safety check looked 15 deg ahead (as far as the chair turns in
    ``turn_check_s``), where the front corner met the leaf: held, and three recoveries
    ended where they began. The points are the world's map of the room (5 cm cells) and
    both faces of the 5 cm leaf; the starts are the mission's, the manoeuvre's and the
    held pose."""
    from pathlib import Path

    room = np.load(Path(__file__).parents[2] / "fixtures/manoeuvre/b7300w_leaf_room.npz")
    points = np.concatenate((room["walls_mm"], room["leaf_mm"])) / 1000.0
    goal = (24.45, 44.66, math.pi)
    cmd, x, y, th, t, nearest = dock_with_guard(points, start, goal, cell_m=0.05)
    assert cmd.state == "arrived", (round(t, 1), round(x, 3), round(y, 3), round(th, 3))
    reach = NavigatorConfig().position_tolerance_m  # what the navigator's Correct accepts
    assert math.hypot(x - goal[0], y - goal[1]) <= reach, (x, y)
    assert abs(wrap_angle(th - goal[2])) <= DOCK.heading_tolerance_rad + 1e-3
    assert nearest > 0.0


def test_the_drive_to_a_pose_keeps_the_margin_along_its_way_not_only_at_its_end() -> None:
    """Campaign seeds 8100-8111, b8108.m01: a recovery docked the chair onto its route
    through a 0.95 m gap between a wall and a cupboard. The target lay 2 m ahead, 11 deg
    off the goal heading, so the move stage drove straight at it, checking the footprint
    only at its end: the front corner passed 4.2 cm from the wall (limit 5 cm), with the
    guard's precise strip (2 cm) letting it by. The way there is checked at the docker's
    margin too; where it fails, the docker plans a manoeuvre, and drives each of its poses
    the way the search planned (a 1.15 m back-up beyond the reverse reach had the chair
    turn round twice)."""
    wall = np.vstack(
        [
            _wall(18.2, 11.0, 18.2, 15.5),
            _wall(19.15, 13.8, 19.15, 14.5),  # the cupboard
            _wall(19.15, 13.8, 19.95, 13.8),
            _wall(19.15, 14.5, 19.95, 14.5),
        ]
    )
    start, goal = (19.088, 12.107, math.radians(101.4)), (18.67, 14.08, math.radians(91.0))
    cmd, x, y, th, t, nearest = dock_with_guard(wall, start, goal)
    assert cmd.state == "arrived", (round(t, 1), round(x, 2), round(y, 2), round(th, 2))
    assert math.hypot(x - goal[0], y - goal[1]) <= DOCK.position_tolerance_m
    assert nearest >= 0.05, round(nearest, 4)
    assert abs(th - goal[2]) < math.pi, round(math.degrees(th), 1)  # not turned round


def _scan_fixture(name: str) -> tuple[np.ndarray, tuple, tuple]:
    """(points m, start pose, goal pose) of a controller's scan saved in a campaign
    mission, ``tests/fixtures/manoeuvre/<name>.npz``."""
    from pathlib import Path

    scan = np.load(Path(__file__).parents[2] / f"fixtures/manoeuvre/{name}.npz")
    return scan["points_mm"] / 1000.0, tuple(scan["pose"]), tuple(scan["goal"])


def _edge(x1: float, y1: float, x2: float, y2: float) -> np.ndarray:
    """Points every 5 mm along a straight edge of the world (a gap measured to them is
    within a millimetre of the gap to the edge)."""
    n = max(2, int(math.hypot(x2 - x1, y2 - y1) / 0.005) + 1)
    return np.column_stack([np.linspace(x1, x2, n), np.linspace(y1, y2, n)])


def test_a_manoeuvre_beside_an_open_leaf_turns_where_it_was_planned_to() -> None:
    """Campaign seeds 8100-8111, b8105.m00: after an 0.80 m hinged door whose leaf stands
    open along the side wall of a 2.5 x 2.1 m vestibule, the chair stood beside the leaf's
    tip and planned a manoeuvre to the second door: drive 5 cm on, then turn. Each pose of
    a manoeuvre counted as reached within 3 cm, so the turn began 2.6 cm short of where it
    was planned and the rear corner swept past the leaf's tip 4.3 cm from it (limit 5 cm;
    4.6 cm in the mission). The points are the controller's scan at that moment; the gap
    is measured to the world: the vestibule's walls and both faces of the 5 cm leaf."""
    points, start, goal = _scan_fixture("b8105_vestibule_scan")
    world = np.vstack(
        [
            _edge(26.375, 13.95, 26.375, 14.75),  # the leaf, hinged at (26.4, 13.95)
            _edge(26.375, 14.75, 26.425, 14.75),
            _edge(26.425, 14.05, 26.425, 14.75),
            _edge(26.5, 14.05, 26.5, 16.15),  # the vestibule's walls
            _edge(24.0, 14.05, 24.0, 16.15),
            _edge(24.0, 14.05, 25.6, 14.05),
            _edge(24.0, 16.15, 26.5, 16.15),
        ]
    )
    cmd, x, y, th, t, nearest = dock_with_guard(points, start, goal, truth=world)
    assert cmd.state == "arrived", (round(t, 1), round(x, 2), round(y, 2), round(th, 2))
    assert math.hypot(x - goal[0], y - goal[1]) <= DOCK.position_tolerance_m, (x, y)
    assert nearest >= 0.05, round(nearest, 4)


def test_a_manoeuvre_that_ends_short_of_the_goal_is_driven_as_planned() -> None:
    """Campaign seeds 8200-8211, b8210.m01: after a sliding door the chair stood in a
    2.8 m vestibule, facing the second door, an 0.80 m hinged one whose leaf stands open
    along the vestibule's side wall. Turn-drive-turn to the approach pose 0.74 m ahead
    swept the front corner at the leaf, so docking planned a manoeuvre; the search's goal
    did not fit its grid, and it ended 12 cm beside the goal: turn 5 deg away from the
    leaf, drive 0.65 m. Docking took the turn, then drove straight to the goal itself,
    the way the search had not checked, and the front corner came to 2.4 cm from the
    leaf. The points are the controller's scan at the start; the gap is measured to the
    world: the leaf's faces, the jambs and the vestibule's walls (cells of 5 cm)."""
    points, start, goal = _scan_fixture("b8210_vestibule_scan")
    world = np.vstack(
        [
            _edge(28.0, 34.625, 28.8, 34.625),  # the leaf, hinged at (28.0, 34.65)
            _edge(28.8, 34.625, 28.8, 34.675),
            _edge(28.1, 34.675, 28.8, 34.675),
            _edge(28.1, 34.65, 28.1, 34.75),  # the second door's jambs
            _edge(27.9, 34.65, 28.1, 34.65),
            _edge(28.1, 33.2, 28.1, 33.85),
            _edge(27.9, 33.85, 28.1, 33.85),
            _edge(28.1, 34.75, 30.9, 34.75),  # the vestibule's walls
            _edge(30.9, 34.65, 30.9, 34.75),
        ]
    )
    cmd, x, y, th, t, nearest = dock_with_guard(points, start, goal, v0=0.19, truth=world)
    assert nearest >= 0.05, (round(nearest, 4), round(x, 3), round(y, 3), round(th, 3))
    assert cmd.state == "arrived", (round(t, 1), round(x, 2), round(y, 2), round(th, 2))


def test_a_goal_that_does_not_fit_is_not_driven_into_after_a_manoeuvre() -> None:
    """Campaign seeds 8200-8211, b8208.m07: a recovery docked the chair onto its route
    where it leaves a 2.0 x 2.0 m room for a 1.5 m corridor, at a route point whose
    footprint, facing along the route, reaches 3 cm into the corridor's wall. Docking
    planned a manoeuvre that ended 13 cm beside that pose, then sidestepped: backed up
    0.86 m and drove along the pose's line into it, unchecked once a manoeuvre was
    planned, until the safety checks held the chair 3.3 cm from the wall, where it stood
    until the recovery ran out. The points are the controller's scan; the gap is
    measured to the world (the room's and the corridor's walls, cells of 5 cm)."""
    points, start, goal = _scan_fixture("b8208_corridor_entry_scan")
    world = np.vstack(
        [
            _edge(13.95, 6.7, 13.95, 8.7),  # the room
            _edge(16.0, 6.7, 16.0, 8.7),
            _edge(13.95, 8.7, 14.2, 8.7),
            _edge(15.7, 8.7, 16.0, 8.7),
            _edge(13.95, 6.7, 14.05, 6.7),
            _edge(14.85, 6.7, 16.0, 6.7),
            _edge(14.2, 8.7, 14.2, 10.5),  # the corridor
            _edge(15.7, 8.7, 15.7, 10.5),
        ]
    )
    cmd, x, y, th, t, nearest = dock_with_guard(points, start, goal, truth=world)
    assert cmd.state == "arrived", (round(t, 1), round(x, 2), round(y, 2), round(th, 2))
    assert nearest >= 0.05, (round(nearest, 4), round(x, 3), round(y, 3), round(th, 3))


def _box(x0: float, y0: float, x1: float, y1: float) -> np.ndarray:
    """The four edges of a block standing in a room (a column, a cupboard)."""
    return np.vstack(
        [_edge(x0, y0, x1, y0), _edge(x1, y0, x1, y1), _edge(x1, y1, x0, y1), _edge(x0, y1, x0, y0)]
    )


def test_a_manoeuvre_planned_beside_a_face_it_could_not_see_is_planned_again() -> None:
    """Campaign seeds 8200-8211, b8200.m00: in a hall, held between two blocks (0.6 x 1.1
    m and 0.9 x 0.4 m), a recovery docked the chair onto its route, 1.7 m away round the
    first block's corner. From where it started, the block's far face was hidden behind
    it, so the manoeuvre planned a turn on the spot beside that face; there the scan showed
    it, the safety checks held the turn, and the chair stood until the recovery gave up
    (at 3489110 the turn went on, 4.8 cm from the block). Here the LiDAR sees from each
    pose only what is not hidden (the hall's walls and the two blocks, cells of 5 cm)."""
    world = np.vstack(
        [
            _box(7.2, 35.2, 7.8, 36.3),
            _box(7.75, 33.85, 8.65, 34.25),
            _edge(10.0, 32.0, 10.0, 36.1),
            _edge(4.5, 38.15, 10.0, 38.15),
        ]
    )
    start, goal = (8.51, 35.66, math.radians(-113)), (7.29, 34.52, math.radians(-144.8))
    cmd, x, y, th, t, nearest = dock_with_guard(world, start, goal, truth=world, seen=True)
    assert cmd.state == "arrived", (round(t, 1), round(x, 2), round(y, 2), round(th, 2))
    assert math.hypot(x - goal[0], y - goal[1]) <= DOCK.position_tolerance_m, (x, y)
    assert nearest >= 0.05, round(nearest, 4)


def test_a_turn_at_the_goal_that_neither_way_keeps_the_margin_is_not_left_to_the_checks() -> None:
    """Campaign seeds 8400-8411, b8405.m02: the chair came to a door's approach pose with
    its front in the doorway of another door beside it, 49 deg off the goal heading; the
    turn to it swept the front corner at that doorway's jamb either way. Docking saw it
    (marked cramped) and turned on, leaving it to the safety checks, whose hold on the
    jamb's corner (the scan's range noise, averaged per bearing) let go after 1 s: 4.6 cm
    from the jamb in the mission. Docking must not command a turn its own check says
    comes within its margin either way: here its commands run without the checks."""
    world = np.vstack(
        [
            _box(35.1, 43.0, 35.25, 44.45),  # the wall of the door ahead, and its jambs
            _box(35.1, 45.4, 35.25, 45.5),
            _box(34.0, 45.5, 35.6, 45.65),  # the wall of the doorway beside the pose
            _box(36.8, 45.5, 38.0, 45.65),
            _box(37.1, 43.8, 37.25, 45.5),
        ]
    )
    start, goal = (36.233, 44.902, math.radians(138.8)), (36.2, 44.9125, math.pi)
    cmd, x, y, th, t, nearest = dock_with_guard(world, start, goal, truth=world, checks=False)
    assert nearest >= 0.05, (round(nearest, 4), round(x, 3), round(y, 3), round(th, 3))
    assert cmd.state == "arrived", (round(t, 1), round(x, 2), round(y, 2), round(th, 2))


def test_the_last_drive_of_a_manoeuvre_is_driven_as_planned_not_aimed_at_the_goal() -> None:
    """Campaign seeds 8600-8611, b8611.m02: an 0.80 m door whose leaf stands open towards
    the chair beside a cupboard; the approach pose, 1.0 m before the door, is 6.5 cm from
    the leaf. Docking planned a manoeuvre whose last drive ran straight along the goal
    heading, 4.7 cm beside the goal's line (a cell: "on" it), and dropped that drive as
    the final stage's; but from the pose before it, 0.70 m away, docking steered straight
    at the goal, 4 deg off the heading, and swung the front corner to 3.7 cm from the
    leaf's tip. The points are the controller's scan; the gap is measured to the world:
    the leaf's faces, the cupboard, the jamb and the room's walls."""
    points, start, goal = _scan_fixture("b8611_leaf_and_cupboard_scan")
    world = np.vstack(
        [
            _edge(38.875, 12.7, 38.875, 13.4),  # the leaf, hinged at (38.9, 12.6)
            _edge(38.875, 13.4, 38.925, 13.4),
            _edge(38.925, 12.7, 38.925, 13.4),
            _box(38.9, 13.6, 39.6, 14.3),  # the cupboard
            _edge(38.1, 12.5, 38.1, 12.7),  # the other jamb
            _edge(36.6, 12.7, 38.1, 12.7),  # the room's walls
            _edge(38.925, 12.7, 39.6, 12.7),
            _edge(36.6, 12.7, 36.6, 16.2),
            _edge(39.6, 12.7, 39.6, 16.2),
            _edge(36.6, 16.2, 39.6, 16.2),
        ]
    )
    cmd, x, y, th, t, nearest = dock_with_guard(points, start, goal, truth=world)
    assert nearest >= 0.05, (round(nearest, 4), round(x, 3), round(y, 3), round(th, 3))
    assert cmd.state == "arrived", (round(t, 1), round(x, 2), round(y, 2), round(th, 2))


def test_a_manoeuvre_keeps_its_margin_to_points_beyond_the_window_it_was_planned_in() -> None:
    """Campaign seeds 8700-8711, b8706.m02: docking at a door's approach pose, 1.9 m
    before an 0.85 m door whose leaf stands open towards the chair, planned a manoeuvre
    in a window 1.5 m round the pose and the goal, from the scan points inside it. One of
    its poses lay 0.9 m nearer the door, inside the window, but the chair's front there
    reached out of it, past the window's edge, where the points had been left out: the
    front corner came to 3.5 cm from the door's jamb. The points are the controller's
    scan; the gap is measured to the world: the door's wall and jamb, the open leaf and
    the room's side wall."""
    points, start, goal = _scan_fixture("b8706_room_door_scan")
    world = np.vstack(
        [
            _edge(33.0, 19.3, 34.9, 19.3),  # the door's wall, to its jamb
            _edge(34.9, 19.1, 34.9, 19.3),
            _edge(35.7, 19.3, 35.7, 20.05),  # the open leaf, hinged at (35.75, 19.2)
            _edge(35.7, 20.05, 35.75, 20.05),
            _edge(35.85, 19.3, 35.85, 22.6),  # the room's side wall
        ]
    )
    cmd, x, y, th, t, nearest = dock_with_guard(points, start, goal, truth=world)
    assert nearest >= 0.05, (round(nearest, 4), round(x, 3), round(y, 3), round(th, 3))
    assert cmd.state == "arrived", (round(t, 1), round(x, 2), round(y, 2), round(th, 2))
