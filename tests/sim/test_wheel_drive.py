"""The chair moved by an emulated WHILL's wheels (the hardware path): where the wheels took
it, whatever the step rate; the ground's errors and the casters' kick; the chair's own
timeout seen as its watchdog. Pure: the model is stepped on its own clock."""

from __future__ import annotations

import math
import struct

import numpy as np
import pytest

from sim.robot import ChairState
from sim.wheel_drive import WheelDrive, Wheels, wheels_of
from sim.whill_emulator import ChairModel, ChairParams, Command

RADIUS, TRACK = 0.1325, 0.496


def velocity(v: float, w: float) -> bytes:
    """SetVelocity under serial control for forward speed ``v`` and turn rate ``w``."""
    front, side = round(v * 900), round(-w * TRACK * 900)
    return bytes([Command.SET_VELOCITY, 0]) + struct.pack(">hh", front, side)


def drive(chair: ChairModel, start: ChairState, **errors) -> WheelDrive:
    return WheelDrive(start, lambda: wheels_of(chair), RADIUS, TRACK, **errors)


def run(chair: ChairModel, wheels: WheelDrive, t0: float, t1: float, every: float) -> float:
    """Step the model every 10 ms from ``t0`` to ``t1``, the drive every ``every`` s."""
    t, next_step = t0, t0 + every
    while t < t1 - 1e-9:
        t = min(t1, t + 0.01)
        chair.due(t)
        if t >= next_step - 1e-9:
            wheels.step(every, t)
            next_step += every
    wheels.step(every, t)
    return t


def in_start_frame(chair: ChairModel, start: ChairState) -> tuple[float, float, float]:
    """The model's own pose (from where it started) seen from ``start``."""
    c, s = math.cos(start.theta), math.sin(start.theta)
    theta = math.atan2(math.sin(start.theta + chair.theta), math.cos(start.theta + chair.theta))
    return start.x + c * chair.x - s * chair.y, start.y + s * chair.x + c * chair.y, theta


def test_the_chair_goes_where_the_wheels_took_it() -> None:
    chair = ChairModel(ChairParams(track_m=TRACK, wheel_radius_m=RADIUS))
    start = ChairState(2.0, 3.0, 0.5)
    wheels = drive(chair, ChairState(start.x, start.y, start.theta))
    t = 0.0
    for v, w in [(0.5, 0.0), (0.4, 0.6), (0.0, -0.8), (-0.2, 0.3)]:
        chair.handle(velocity(v, w), t)
        t = run(chair, wheels, t, t + 0.9, every=0.02)
    x, y, theta = in_start_frame(chair, start)
    assert math.hypot(chair.x, chair.y) > 0.5  # it went somewhere
    # the model steps its pose by exact arcs between speed changes, the drive by the
    # wheels' chords: the same within the rounding of the ramps
    assert (wheels.state.x, wheels.state.y) == pytest.approx((x, y), abs=1e-4)
    assert wheels.state.theta == pytest.approx(theta, abs=1e-6)
    assert (wheels.state.v, wheels.state.w) == pytest.approx((chair.v, chair.w))


def test_a_late_step_moves_the_chair_further_never_elsewhere() -> None:
    """Steps every 20 ms or every 0.5 s (a simulator running late) end at the same pose."""
    ends = []
    for every in (0.02, 0.5):
        chair = ChairModel(ChairParams(track_m=TRACK, wheel_radius_m=RADIUS))
        wheels = drive(chair, ChairState(0.0, 0.0, 0.0))
        chair.handle(velocity(0.5, 0.5), 0.0)
        run(chair, wheels, 0.0, 3.0, every=every)
        ends.append((wheels.state.x, wheels.state.y, wheels.state.theta))
    # steady turning is exact in any step; only the ramps' curvature changes within one
    assert ends[0] == pytest.approx(ends[1], abs=0.01)


def test_the_ground_errs_from_the_wheels_as_the_simulated_odometry_does() -> None:
    still = Wheels(0.0, 0.0, 0.0)
    reading = [still]
    wheels = WheelDrive(
        ChairState(0.0, 0.0, 0.0),
        lambda: reading[0],
        RADIUS,
        TRACK,
        scale_error=0.01,
        turn_bias=0.005,
    )
    reading[0] = Wheels(10.0, 0.0, 0.0)  # ten seconds standing still: no bias
    wheels.step(0.02, 0.0)
    assert (wheels.state.x, wheels.state.theta) == (0.0, 0.0)
    turned = 10.0 / RADIUS  # both wheels roll 10 m in 20 s
    reading[0] = Wheels(30.0, turned, turned, v=0.5)
    wheels.step(0.02, 0.0)
    assert wheels.state.x == pytest.approx(10.0 / 1.01 * math.cos(-0.05), rel=1e-3)
    assert wheels.state.theta == pytest.approx(-0.005 * 20.0)
    assert wheels.state.v == pytest.approx(0.5 / 1.01)


def test_the_casters_kick_the_heading_when_the_chair_sets_off() -> None:
    headings = []
    for caster in (0.0, 0.2):
        chair = ChairModel(ChairParams(track_m=TRACK, wheel_radius_m=RADIUS))
        wheels = drive(
            chair, ChairState(0.0, 0.0, 0.0), caster=caster, rng=np.random.default_rng(3)
        )
        chair.handle(velocity(0.5, 0.0), 0.0)
        run(chair, wheels, 0.0, 4.0, every=0.02)
        headings.append(wheels.state.theta)
    assert headings[0] == 0.0  # straight on the wheels, no casters
    # both wheels ran alike, yet the kick (0.41 rad/s, fading over 0.5 s) turned the chair
    kick = np.random.default_rng(3).normal(0.0, 0.2)
    assert headings[1] == pytest.approx(kick * 0.5, rel=0.05)


def test_a_chair_whose_clock_has_not_started_yet_gives_no_time_to_err_over() -> None:
    chair = ChairModel(ChairParams(track_m=TRACK, wheel_radius_m=RADIUS))
    wheels = drive(chair, ChairState(0.0, 0.0, 0.0), turn_bias=0.005)  # read before any step
    assert wheels_of(chair).t is None
    chair.handle(velocity(0.5, 0.0), 5000.0)  # its clock starts at a monotonic 5000 s
    run(chair, wheels, 5000.0, 5000.5, every=0.02)
    assert abs(wheels.state.theta) < 0.005 * 0.6  # the bias over half a second, not 5000 s


def test_the_chairs_own_timeout_is_its_watchdog_until_the_next_command() -> None:
    chair = ChairModel(ChairParams(track_m=TRACK, wheel_radius_m=RADIUS))
    wheels = drive(chair, ChairState(0.0, 0.0, 0.0))
    chair.handle(velocity(0.3, 0.0), 0.0)
    run(chair, wheels, 0.0, 0.9, every=0.02)
    assert not wheels.watchdog_tripped
    run(chair, wheels, 0.9, 3.0, every=0.02)  # no command for over 1 s: it stops
    assert wheels.watchdog_tripped and chair.v == 0.0 and wheels.state.v == 0.0
    chair.handle(velocity(0.3, 0.0), 3.0)
    run(chair, wheels, 3.0, 3.2, every=0.02)
    assert not wheels.watchdog_tripped and wheels.state.v > 0.0
