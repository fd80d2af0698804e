"""The WHILL Model CR emulator: framing, commands, motion, timeout, rider, data sets (pure,
on the model's own clock), and the real SDK reading it over the pseudo terminal."""

from __future__ import annotations

import math
import struct
import time

import pytest
from whill import ComWHILL

from sim.whill_emulator import (
    POWER_ON_ANSWER,
    ChairModel,
    ChairParams,
    Command,
    PacketReader,
    WhillEmulator,
    checksum,
    frame,
)

SET_1 = struct.Struct(">B12sbbBhhhhhBBBB")  # data set 1 payload, as the reference lays it out
SET_1_FIELDS = ("set", "imu", "front", "side", "battery", "current", "right_angle")
SET_1_FIELDS += ("left_angle", "right_speed", "left_speed", "power", "speed_mode", "error")
SET_1_FIELDS += ("stamp",)
INSTANT = ChairParams(max_accel=math.inf, max_turn_accel=math.inf)  # no ramps: exact checks


def velocity(front: int, side: int, user_control: int = 0) -> bytes:
    return bytes([Command.SET_VELOCITY, user_control]) + struct.pack(">hh", front, side)


def joystick(front: int, side: int, user_control: int = 0) -> bytes:
    return bytes([Command.SET_JOYSTICK, user_control, front & 0xFF, side & 0xFF])


def start(data_set: int = 1, interval_ms: int = 20, mode: int = 0) -> bytes:
    return bytes([Command.START_SENDING_DATA, data_set, interval_ms >> 8, interval_ms & 0xFF, mode])


def decode_set_1(packet: bytes) -> dict:
    assert packet[0] == 0xAF and packet[1] == len(packet) - 2 and checksum(packet) == 0
    fields = SET_1.unpack(packet[2:-1])
    return dict(zip(SET_1_FIELDS, fields, strict=True))


def run(chair: ChairModel, until: float, step: float = 0.01, t: float = 0.0) -> float:
    """Step the model from ``t`` to ``until`` as the emulator's thread does."""
    while t < until - 1e-9:
        t = min(until, t + step)
        chair.due(t)
    return t


# -- framing ------------------------------------------------------------------------------


def test_a_packet_is_sign_length_payload_and_an_xor_checksum() -> None:
    packet = frame(velocity(300, -100))
    assert packet == bytes([0xAF, 0x07, 0x08, 0x00, 0x01, 0x2C, 0xFF, 0x9C, 0xEE])
    assert checksum(packet) == 0


def test_the_reader_finds_packets_however_the_bytes_arrive() -> None:
    stream = b"\x00\x13" + frame(velocity(300, 0)) + frame(start()) + frame(joystick(-5, 7))
    whole = PacketReader().feed(stream)
    reader, pieces = PacketReader(), []
    for b in stream:
        pieces += reader.feed(bytes([b]))
    assert whole == pieces == [velocity(300, 0), start(), joystick(-5, 7)]


def test_the_reader_drops_bad_packets_and_finds_the_next_good_one() -> None:
    good = frame(velocity(100, 0))
    torn = bytearray(frame(velocity(900, 0)))
    torn[4] ^= 0x01  # a flipped bit: the checksum no longer matches
    unknown = frame(bytes([0x07, 0x00]))  # no command 7
    wrong_length = frame(bytes([Command.SET_POWER, 1, 0]))  # SetPower has one argument
    reader = PacketReader()
    assert reader.feed(bytes(torn) + unknown + wrong_length + good) == [velocity(100, 0)]
    assert reader.bad == 3


# -- commands and motion ------------------------------------------------------------------


def test_set_velocity_drives_straight_at_the_commanded_speed() -> None:
    chair = ChairModel(INSTANT)
    chair.handle(velocity(900, 0), 0.0)  # 900 x 0.004 km/h = 1 m/s
    run(chair, 0.5)
    assert chair.serial_control and chair.last_velocity == (900, 0)
    assert chair.v == pytest.approx(1.0) and chair.w == 0.0
    assert (chair.x, chair.y, chair.theta) == pytest.approx((0.5, 0.0, 0.0))


def test_side_is_the_wheel_speed_difference_and_positive_turns_right() -> None:
    chair = ChairModel(INSTANT)
    side = -round(0.25 * chair.params.track_m * 900)  # 0.25 rad/s to the left
    chair.handle(velocity(450, side), 0.0)
    run(chair, 0.8)
    assert chair.v == pytest.approx(0.5)
    assert chair.w == pytest.approx(0.25, abs=0.002)
    radius = chair.v / chair.w  # on the circle about (0, radius), 0.8 s along it
    turn = chair.w * 0.8
    expected = (radius * math.sin(turn), radius * (1 - math.cos(turn)), turn)
    assert (chair.x, chair.y, chair.theta) == pytest.approx(expected, abs=1e-9)


def test_acceleration_is_limited() -> None:
    chair = ChairModel(ChairParams(max_accel=1.0))
    chair.handle(velocity(900, 0), 0.0)
    run(chair, 0.3)
    assert chair.v == pytest.approx(0.3)


def test_the_chairs_own_timeout_stops_it_after_one_second_without_commands() -> None:
    chair = ChairModel(INSTANT)
    chair.handle(velocity(450, 0), 0.0)
    t = run(chair, 0.95)
    assert chair.v == pytest.approx(0.5) and chair.timeouts == 0
    run(chair, 1.2, t=t)
    assert chair.v == 0.0 and chair.timeouts == 1 and not chair.serial_control
    assert chair.timeout_at == pytest.approx(1.0, abs=0.011)  # at the first step from 1 s


def test_commands_within_the_timeout_keep_it_going() -> None:
    chair = ChairModel(INSTANT)
    t = 0.0
    for k in range(6):
        chair.handle(velocity(450, 0), k * 0.5)
        t = run(chair, (k + 1) * 0.5, t=t)
    assert chair.v == pytest.approx(0.5) and chair.timeouts == 0
    assert chair.x == pytest.approx(1.5)


def test_set_joystick_drives_like_the_joystick_and_release_hands_the_chair_back() -> None:
    chair = ChairModel(INSTANT)
    chair.handle(joystick(50, -20), 0.0)  # half ahead, a fifth to the left
    run(chair, 0.1)
    assert chair.serial_control
    assert (chair.v, chair.w) == pytest.approx((0.5, 0.2))
    chair.handle(joystick(0, 0, user_control=1), 0.1)
    run(chair, 0.2, t=0.1)
    assert not chair.serial_control and (chair.v, chair.w) == (0.0, 0.0)


def test_the_rider_overrides_serial_commands_by_default() -> None:
    chair = ChairModel(INSTANT)
    chair.handle(velocity(270, 0), 0.0)
    chair.rider_joystick(-50, 0)
    run(chair, 0.1)
    assert chair.v == pytest.approx(-0.5)


def test_without_override_the_joystick_waits_for_the_host_to_hand_over() -> None:
    chair = ChairModel(ChairParams(max_accel=math.inf, rider_overrides=False))
    chair.handle(velocity(270, 0), 0.0)
    chair.rider_joystick(-50, 0)
    t = run(chair, 0.1)
    assert chair.v == pytest.approx(0.3)  # serial control holds: the joystick is only read
    chair.handle(joystick(0, 0, user_control=1), t)
    run(chair, 0.2, t=t)
    assert chair.v == pytest.approx(-0.5)


def test_an_error_stops_the_chair_until_it_is_cleared() -> None:
    chair = ChairModel(INSTANT)
    chair.handle(velocity(450, 0), 0.0)
    t = run(chair, 0.1)
    chair.error_code = 7
    t = run(chair, 0.2, t=t)
    chair.handle(velocity(450, 0), t)
    t = run(chair, 0.3, t=t)
    assert chair.v == 0.0
    chair.error_code = 0
    chair.handle(velocity(450, 0), t)
    run(chair, 0.4, t=t)
    assert chair.v == pytest.approx(0.5)


def test_a_chair_that_is_off_hears_only_power_on_and_answers_it() -> None:
    chair = ChairModel(INSTANT, powered=False)
    assert chair.handle(start(), 0.0) == [] and chair.handle(velocity(450, 0), 0.0) == []
    run(chair, 0.5)
    assert chair.due(0.5) == [] and chair.v == 0.0
    assert chair.handle(bytes([Command.SET_POWER, 1]), 0.5) == [frame(bytes([POWER_ON_ANSWER]))]
    assert chair.handle(bytes([Command.SET_POWER, 1]), 0.7) == []  # already on
    chair.handle(velocity(450, 0), 0.7)
    run(chair, 0.8, t=0.7)
    assert chair.v == pytest.approx(0.5)


# -- data sets ----------------------------------------------------------------------------


def test_data_set_1_carries_joystick_battery_wheels_power_mode_error_and_stamp() -> None:
    chair = ChairModel(INSTANT, battery_level=63, battery_current_ma=-1500.0, speed_mode=4)
    chair.error_code = 2
    chair.handle(start(interval_ms=20), 0.0)
    chair.rider_joystick(-40, 25)
    packets = chair.due(0.1)
    assert len(packets) == 5
    sets = [decode_set_1(p) for p in packets]
    assert [s["stamp"] for s in sets] == [20, 40, 60, 80, 100]
    last = sets[-1]
    assert last["set"] == 1 and last["imu"] == bytes(12)
    assert (last["front"], last["side"], last["battery"]) == (-40, 25, 63)
    assert last["current"] == -750  # units of 2 mA
    assert (last["power"], last["speed_mode"], last["error"]) == (1, 4, 2)


def test_wheel_data_forwards_the_right_motor_counts_backwards() -> None:
    chair = ChairModel(INSTANT)
    chair.handle(start(interval_ms=20), 0.0)
    chair.handle(velocity(450, 0), 0.0)  # 0.5 m/s = 1.8 km/h = 450 units at each tyre
    s = decode_set_1(chair.due(0.2)[-1])
    assert (s["left_speed"], s["right_speed"]) == (450, -450)
    turned = 0.5 * 0.2 / chair.params.wheel_radius_m
    assert s["left_angle"] == round(turned * 1000) and s["right_angle"] == -s["left_angle"]


def test_turning_left_speeds_up_the_right_wheel() -> None:
    chair = ChairModel(INSTANT)
    chair.handle(start(interval_ms=20), 0.0)
    chair.handle(velocity(0, -446), 0.0)  # on the spot, counter-clockwise
    s = decode_set_1(chair.due(0.04)[-1])
    assert s["left_speed"] == -223 and s["right_speed"] == -223  # right counts backwards


def test_wheel_angles_wrap_at_pi() -> None:
    chair = ChairModel(INSTANT)
    chair.handle(start(interval_ms=20), 0.0)
    t = 0.0
    for _ in range(4):  # 1 m/s for 0.5 s: the wheels turn 3.77 rad
        chair.handle(velocity(900, 0), t)
        packets = chair.due(t + 0.125)
        t += 0.125
    s = decode_set_1(packets[-1])
    turned = 0.5 / chair.params.wheel_radius_m
    assert s["left_angle"] == round((turned - 2 * math.pi) * 1000)


def test_the_stamp_counts_milliseconds_from_0_to_200() -> None:
    chair = ChairModel(INSTANT)
    chair.handle(start(interval_ms=30), 0.0)
    stamps = [decode_set_1(p)["stamp"] for p in chair.due(0.3)]
    assert stamps == [30, 60, 90, 120, 150, 180, 9, 39, 69, 99]


def test_a_late_call_still_makes_every_packet_at_its_own_time() -> None:
    prompt, late = ChairModel(INSTANT), ChairModel(INSTANT)
    for chair in (prompt, late):
        chair.handle(start(interval_ms=20), 0.0)
        chair.handle(velocity(450, -100), 0.0)
    packets = []
    for k in range(1, 11):
        packets += prompt.due(k * 0.02)
    assert packets == late.due(0.2)  # the same ten packets, made all at once


def test_data_set_0_is_the_speed_profile_of_the_asked_mode() -> None:
    chair = ChairModel(INSTANT)
    profile = [40, 20, 70, 15, 20, 60, 20, 50, 80]
    chair.handle(bytes([Command.SET_SPEED_PROFILE, 2, *profile]), 0.0)
    chair.handle(start(data_set=0, interval_ms=50, mode=2), 0.0)
    assert chair.due(0.1) == [frame(bytes([0, 2, *profile]))] * 2
    chair.handle(bytes([Command.STOP_SENDING_DATA]), 0.1)
    assert chair.due(0.5) == []


# -- the real SDK on the pseudo terminal --------------------------------------------------


def wait_until(predicate, com: ComWHILL | None = None, timeout_s: float = 20.0) -> bool:
    """Poll ``predicate`` (refreshing the SDK if given) until true or ``timeout_s``."""
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        if com is not None:
            com.refresh()
        if predicate():
            return True
        time.sleep(0.01)
    return False


def test_the_sdk_reads_the_emulators_data_set_1() -> None:
    with WhillEmulator(ChairModel(battery_level=57, speed_mode=3)) as emu:
        com = ComWHILL(port=emu.port, timeout=0.1)
        try:
            with emu.locked() as chair:
                chair.rider_joystick(30, -12)
                chair.error_code = 9
            com.start_data_stream(20, 1)
            assert wait_until(lambda: com.seq_data_set_1 >= 5, com), "no data set 1"
            assert (com.joy["front"], com.joy["side"]) == (30, -12)
            assert com.battery["level"] == 57
            assert (com.speed_mode_indicator, com.error_code, com.power_status) == (3, 9, 1)
            assert com.time_diff_ms == 20
        finally:
            com.com.close()


def test_the_sdk_powers_the_chair_on_and_drives_it() -> None:
    with WhillEmulator(ChairModel(powered=False)) as emu:
        com = ComWHILL(port=emu.port, timeout=0.1)
        answered = []
        com.register_callback("power_on", lambda: answered.append(True))
        try:
            com.send_power_on()
            assert wait_until(lambda: answered, com), "no power-on answer"
            com.send_velocity(270, 0)
            assert wait_until(lambda: emu.chair.x > 0.05), "the chair did not move"
            with emu.locked() as chair:
                assert chair.powered and chair.last_velocity == (270, 0)
            assert emu.reader.bad == 0
        finally:
            com.com.close()
