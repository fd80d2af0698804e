"""A smooth pass through the simulator's door from random starts (the chair model, its
LiDAR and the doorway from the scan in closed loop; no fleet)."""

from __future__ import annotations

import math

import numpy as np

from services.controller.smooth_pass import FALLBACK, RUNNING, THROUGH, PassSettings, SmoothPass
from shared.config import RobotConfig
from tests.sim.test_simulation import make

MAPPED = PassSettings(door_width=1.0)  # the site's door_ab, as Path.door gives the width


def _pass(x: float, y: float, theta: float, mapped_off: float = 0.0) -> dict:
    sim = make(x=x, y=y, theta=theta)
    sim.set_door_openings(["door_ab"], [1.0])
    fp = RobotConfig().footprint
    ahead = (fp.front - fp.rear) / 2
    smooth = SmoothPass((6.2, 2.7 + mapped_off), 0.0, MAPPED)
    scan, state, prev, at = None, RUNNING, None, None
    max_w, side = 0.0, math.copysign(1.0, theta)  # the heading's side of the normal (0)
    overshoot = 0.0  # the most the heading went past the normal to the other side
    for _ in range(4000):
        s = sim.state
        v, w, state = smooth.step((s.x, s.y, s.theta), scan)
        if state != RUNNING:
            break
        max_w = max(max_w, abs(w))
        overshoot = max(overshoot, -side * math.degrees(s.theta))
        sim.command(v, w)
        result = sim.step()
        scan = result.scan if result.scan is not None else None
        cx, cy = s.x + ahead * math.cos(s.theta), s.y + ahead * math.sin(s.theta)
        if prev is not None and prev[0] < 6.2 <= cx and at is None:
            at = {"lateral": cy - 2.7, "heading": math.degrees(s.theta), "t": sim.time}
        prev = (cx, cy)
    seen = sim.door_clearance.get("door_ab")
    clearance = seen.clearance if seen else None
    return {
        "state": state,
        "at": at,
        "collisions": sim.collisions,
        "seen": smooth.seen,
        "clearance": clearance,
        "max_w": max_w,
        "overshoot_deg": overshoot,
    }


def test_through_a_1_m_door_from_random_starts_without_stopping() -> None:
    rng = np.random.default_rng(11)
    lateral, heading = [], []
    done = 0
    while done < 4:
        x, y = rng.uniform(2.0, 4.2), rng.uniform(1.0, 4.4)
        theta = math.atan2(2.7 - y, 6.2 - x) + rng.uniform(-0.6, 0.6)
        try:
            run = _pass(x, y, theta)
        except ValueError:  # a start in a wall
            continue
        done += 1
        assert run["state"] == THROUGH and run["collisions"] == 0, run
        assert run["clearance"] >= (1.0 - 0.65) / 2 - 0.03, run  # the opening's limit
        lateral.append(run["at"]["lateral"])
        heading.append(run["at"]["heading"])
    rms = math.sqrt(np.mean(np.square(lateral)))
    print(
        f"lateral rms {rms:.3f} m max {np.abs(lateral).max():.3f}, heading rms "
        f"{math.sqrt(np.mean(np.square(heading))):.2f} deg"
    )
    assert rms <= 0.03 and np.abs(lateral).max() <= 0.06


def test_the_scan_decides_when_the_mapped_door_is_10_cm_off() -> None:
    run = _pass(3.0, 3.6, -0.3, mapped_off=0.1)
    assert run["state"] == THROUGH and run["seen"] > 10 and abs(run["at"]["lateral"]) <= 0.03


def test_facing_away_it_asks_for_stop_turn_go() -> None:
    assert _pass(3.0, 2.7, math.pi)["state"] == FALLBACK


def test_a_tight_curve_keeps_to_the_turn_rate_and_does_not_swing_past_the_line() -> None:
    """Campaign b0.m00, door d1_010: handed over 1.05 m before the plane, facing 66 deg
    off, the pass asked for 3.5 rad/s (the chair turns at most 1.0) at 0.1 m/s, then for
    0.5 m/s as the heading came round; the chair's turn lagged, swung 16 deg past the
    line, and a corner came to 3.2 cm of the jamb. The speed is cut so that the turn the
    curve asks for, here and ahead, is one the chair can make and stop."""
    robot = RobotConfig()
    run = _pass(5.15, 2.85, math.radians(-66))
    print(f"max w {run['max_w']:.2f} rad/s, overshoot {run['overshoot_deg']:.1f} deg, {run}")
    assert run["state"] == THROUGH and run["collisions"] == 0, run
    assert run["max_w"] <= robot.max_turn_rate + 1e-9
    assert run["overshoot_deg"] <= 5.0
    assert run["clearance"] >= (1.0 - 0.65) / 2 - 0.03


def test_the_pass_runs_its_offset_left_of_the_doorway_s_middle() -> None:
    """Path.door's 7th value: the line beside a leaf standing open beyond the door (the
    free opening's middle) is that far left of the doorway's middle, facing through."""
    on_middle = SmoothPass((6.2, 2.7), 0.0)
    beside = SmoothPass((6.2, 2.7), 0.0, PassSettings(offset_m=0.02))
    pose = (4.0, 2.7, 0.0)
    assert on_middle.step(pose, None)[1] == 0.0
    assert beside.step(pose, None)[1] > 0.0  # turning left, onto y = 2.72
    assert beside.step((4.0, 2.72, 0.0), None)[1] == 0.0


def test_a_late_side_approach_asks_for_stop_turn_go_before_the_doorway() -> None:
    """Campaign b8908.m01, door d2_013 (0.80 m): the leg handed over 1 m before the plane,
    0.7 m beside the door's line and facing along the wall. There is no room to come onto
    the line before the front reaches the door: the curve ran the chair into the doorway
    still turning, 5.6 deg off, a corner 3.4 cm from the jamb (the guard held it; here, with
    no guard, it hits the wall). A pass that, followed from where the chair is, would bring
    a point of the footprint more than ``smooth_corner_excess_m`` off the line in the jamb
    is not driven: stop-turn-go instead, before anything of the chair is in the doorway."""
    for x, y in ((5.2, 3.4), (5.4, 3.5)):
        run = _pass(x, y, -math.pi / 2)
        assert run["state"] == FALLBACK and run["collisions"] == 0, run
        assert run["at"] is None, run  # its middle never reached the door plane


def test_a_door_not_seen_open_is_never_entered_without_the_navigator() -> None:
    """The navigator hands the pass over before it has verified the door, and stops the
    chair if it is not seen open by then; were it to die in between, the controller would
    drive the pass on into a closed door (the guard holds the chair at the leaf, a few
    cm off). The pass itself stops the front ``smooth_open_by_m`` before the plane until
    its own scans show the doorway open."""
    sim = make(x=3.0, y=2.7, theta=0.0)
    sim.set_door_openings(["door_ab"], [0.0])
    fp = RobotConfig().footprint
    smooth = SmoothPass((6.2, 2.7), 0.0)
    scan, front = None, -math.inf
    for _ in range(1500):  # 15 s
        s = sim.state
        v, w, state = smooth.step((s.x, s.y, s.theta), scan)
        assert state == RUNNING
        sim.command(v, w)
        result = sim.step()
        scan = result.scan
        front = max(front, s.x + fp.front * math.cos(s.theta))
    print(f"front at most {front:.3f} m, {sim.collisions} collisions")
    assert sim.collisions == 0
    # stopped 0.3 m before the plane, or before the face while the reveal is not seen
    assert 6.2 - 0.1 - 0.3 - 0.05 <= front <= 6.2 - 0.3 + 0.01


def test_late_handovers_fall_back_or_keep_to_the_door_s_limits() -> None:
    """Random handovers 0.8-1.8 m before the plane, up to 0.8 m beside the line, facing up
    to 97 deg off (the footprint still before the jamb): each either asks for stop-turn-go
    before the doorway or passes within the rule's limits in the jamb (the wall is 0.2 m):
    no corner more than 3 cm beyond the half width off the line while the footprint's
    centre is in it, none nearer than 5 cm to a jamb while only the outline is, each with
    1 cm for the chair model's lag, which the ideal prediction lacks. 60 such starts (this
    seed): 25 passed (at worst 1.1 cm off centred, 6.9 cm from a jamb with only the
    outline in), 35 fell back, 0 collisions."""
    fp = RobotConfig().footprint
    half, mid, gap = fp.width / 2, (fp.front - fp.rear) / 2, (1.0 - fp.width) / 2
    rng = np.random.default_rng(2)
    outcomes, n = {THROUGH: 0, FALLBACK: 0}, 0
    while n < 12:
        before, lateral = rng.uniform(0.8, 1.8), rng.uniform(-0.8, 0.8)
        pose = (6.2 - before, 2.7 + lateral, rng.uniform(-1.7, 1.7))
        if not SmoothPass((6.2, 2.7), 0.0, MAPPED)._before_jamb(pose):
            continue
        try:
            sim = make(x=pose[0], y=pose[1], theta=pose[2])
        except ValueError:  # a start in a wall
            continue
        if sim.in_collision:
            continue
        n += 1
        sim.set_door_openings(["door_ab"], [1.0])
        smooth = SmoothPass((6.2, 2.7), 0.0, MAPPED)
        scan, state, centred, outline = None, RUNNING, 0.0, 0.0
        for _ in range(3000):
            s = sim.state
            v, w, state = smooth.step((s.x, s.y, s.theta), scan)
            if state != RUNNING:
                break
            sim.command(v, w)
            scan = sim.step().scan
            c, sn = math.cos(s.theta), math.sin(s.theta)
            centre_in = abs(s.x + mid * c - 6.2) <= 0.1
            for fx in np.linspace(-fp.rear, fp.front, 12):
                for fy in (half, -half):
                    if abs(s.x + fx * c - fy * sn - 6.2) <= 0.1:
                        excess = abs(s.y + fx * sn + fy * c - 2.7) - half
                        if centre_in:
                            centred = max(centred, excess)
                        else:
                            outline = max(outline, excess)
        assert sim.collisions == 0 and state in outcomes, (pose, state)
        outcomes[state] += 1
        if state == THROUGH:
            assert centred <= 0.03 + 0.01 and outline <= gap - 0.05 + 0.01, (pose, centred, outline)
    print(outcomes)
    assert outcomes[THROUGH] > 0 and outcomes[FALLBACK] > 0  # both ways were taken
