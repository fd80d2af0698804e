"""An emulated WHILL Model CR on its serial protocol, behind a pseudo terminal.

Why: the WHILL driver (``services/whill_driver``) reaches the chair only through WHILL
Inc.'s SDK (``whill.ComWHILL`` over pyserial). Handing the SDK the slave end of a pseudo
terminal whose master end speaks the chair's protocol tests the driver as it runs on a
chair, framing and timing included, without one. The emulated chair integrates the motion
it is commanded, so odometry computed from its data stream can be checked against where
it really went.

Two parts: :class:`ChairModel` (state, commands, motion, the packets it sends; pure,
its clock passed in) and :class:`WhillEmulator` (the pseudo terminal and the thread
that feeds the model the bytes the SDK writes and writes back what the model sends).

The protocol, as the SDK frames it (Model CR reference)::

    packet   = 0xAF, length, payload..., checksum
    length   = len(payload) + 1               (the checksum counts)
    checksum = XOR of every byte before it    (so a good packet XORs to 0)

Commands, host to chair (payload = command id, arguments)::

    0x00 StartSendingData  data set (0/1), interval ms (u16), speed mode (data set 0 only)
    0x01 StopSendingData
    0x02 SetPower          0 off, 1 on (a power-on is answered with the payload 0x52)
    0x03 SetJoystick       user control, front, side (s8, -100..100; side > 0 turns right)
    0x04 SetSpeedProfile   speed mode, then 9 bytes: forward, reverse, turn (max, acc, dec)
    0x05 SetBatteryVoltaOut  0/1
    0x06 SetBatterySaving  low level %, buzzer
    0x08 SetVelocity       user control, front (s16, 0.004 km/h, -500..1500), side (s16,
                           0.004 km/h, -750..750; side > 0 turns right)

User control 0 puts the chair under serial control (the command drives it); 1 hands it
back to the rider's joystick (the command's values are ignored).

Data set 1, chair to host (after the set number 0x01, big endian)::

    12 bytes IMU (no longer filled: zeros), joystick front, side (s8), battery level
    (u8, %), battery current (s16, 2 mA), right and left motor angle (s16, 0.001 rad,
    -pi..pi), right and left motor speed (s16, 0.004 km/h at the tyre), power (u8),
    speed mode (u8), error code (u8), time stamp (u8, ms, counting 0..200 then again)

Data set 0 is the speed mode and its 9 profile bytes.

Where the reference leaves a choice, the emulator takes one and says so:

* ``side`` is the difference of the wheel speeds, left minus right: turn rate =
  -side / track (WHILL's ROS 2 driver converts ``cmd_vel`` so: side = -w * track * 900).
* The right motor counts backwards when the chair drives forwards: its angle and speed
  are sent negated (as WHILL's ROS 2 driver reads them for odometry).
* The chair's own timeout: under serial control and no SetVelocity or SetJoystick for
  ``timeout_s`` (1.0 s), the chair stops and goes back to its joystick.
* The rider: a deflected joystick is always reported in data set 1. With
  ``rider_overrides`` (the default) it drives the chair whatever serial control says;
  without it (the reference's reading) the chair follows it only once a command hands
  control back (SetJoystick with user control 1) or serial control times out.
* An error code other than 0 turns the motors off: the chair stops and ignores motion
  commands until the code is cleared.
* Powered off, the chair neither moves nor sends; powering on does not restart the data
  stream (the host asks again).
* Motion is held constant between two steps of the model; when data is streaming the
  model steps exactly at the packet times, so a packet's wheel speeds are the speeds of
  the interval it closes.
"""

from __future__ import annotations

import contextlib
import math
import os
import select
import threading
import time
import tty
from collections.abc import Iterator
from dataclasses import dataclass, field
from enum import IntEnum

PROTOCOL_SIGN = 0xAF
POWER_ON_ANSWER = 0x52  # the one-byte payload the chair sends when it powers on
KMH_UNIT = 0.004  # km/h per unit of SetVelocity and of the motor speeds
ANGLE_UNIT = 0.001  # rad per unit of the motor angles
CURRENT_UNIT_MA = 2.0  # mA per unit of the battery current
FRONT_RANGE = (-500, 1500)  # SetVelocity front, units
SIDE_RANGE = (-750, 750)  # SetVelocity side, units
STAMP_MODULO = 201  # the data set 1 time stamp counts 0..200 ms, then starts again
MIN_INTERVAL_MS = 10  # the shortest data interval the chair accepts
SPEED_MODES = 6  # 0-3 joystick modes, 4 serial (RS232), 5 smartphone app
IMU_BYTES = 12
TIME_EPS = 1e-9  # s: a packet due at ``now`` up to float rounding is due
RIGHT_SIGN = -1  # the right motor's angle and speed are sent negated (see above)
LEFT_SIGN = 1


class Command(IntEnum):
    """Command ids of the host-to-chair packets."""

    START_SENDING_DATA = 0x00
    STOP_SENDING_DATA = 0x01
    SET_POWER = 0x02
    SET_JOYSTICK = 0x03
    SET_SPEED_PROFILE = 0x04
    SET_BATTERY_VOLTAGE_OUT = 0x05
    SET_BATTERY_SAVING = 0x06
    SET_VELOCITY = 0x08


# payload length (command id included) of every command
PAYLOAD_LENGTH = {
    Command.START_SENDING_DATA: 5,
    Command.STOP_SENDING_DATA: 1,
    Command.SET_POWER: 2,
    Command.SET_JOYSTICK: 4,
    Command.SET_SPEED_PROFILE: 11,
    Command.SET_BATTERY_VOLTAGE_OUT: 2,
    Command.SET_BATTERY_SAVING: 3,
    Command.SET_VELOCITY: 6,
}
MAX_LENGTH = max(PAYLOAD_LENGTH.values()) + 1


def checksum(data: bytes) -> int:
    """XOR of ``data``'s bytes."""
    out = 0
    for b in data:
        out ^= b
    return out


def frame(payload: bytes) -> bytes:
    """A whole packet around ``payload``: sign, length, payload, checksum."""
    head = bytes([PROTOCOL_SIGN, len(payload) + 1]) + payload
    return head + bytes([checksum(head)])


def _s8(value: int) -> int:
    return value - 256 if value >= 128 else value


def _s16(hi: int, lo: int) -> int:
    return int.from_bytes(bytes([hi, lo]), "big", signed=True)


def _clamp(value: float, lo: float, hi: float) -> float:
    return max(lo, min(hi, value))


def _int16(value: float) -> bytes:
    return int(_clamp(round(value), -32768, 32767)).to_bytes(2, "big", signed=True)


def _wrap(angle: float) -> float:
    return math.atan2(math.sin(angle), math.cos(angle))


class PacketReader:
    """Cuts a byte stream into command payloads (checksum and length checked).

    A byte that does not start a good packet is dropped and the search goes on from the
    next one, so the reader finds its way back after noise or a torn packet; ``bad``
    counts the dropped starts.
    """

    def __init__(self) -> None:
        self._buf = bytearray()
        self.bad = 0

    def feed(self, data: bytes) -> list[bytes]:
        """The payloads of every whole packet in what has arrived so far."""
        self._buf += data
        out: list[bytes] = []
        while self._buf:
            if self._buf[0] != PROTOCOL_SIGN:
                self._drop()
                continue
            if len(self._buf) < 2:
                break
            length = self._buf[1]
            if not 2 <= length <= MAX_LENGTH:
                self._drop()
                continue
            if len(self._buf) < 2 + length:
                break
            packet = bytes(self._buf[: 2 + length])
            payload = packet[2:-1]
            expected = PAYLOAD_LENGTH.get(payload[0])
            if checksum(packet) != 0 or expected != len(payload):
                self._drop()
                continue
            del self._buf[: 2 + length]
            out.append(payload)
        return out

    def _drop(self) -> None:
        if self._buf[0] == PROTOCOL_SIGN:
            self.bad += 1
        del self._buf[0]


def default_profiles() -> list[list[int]]:
    """Speed profiles of the six modes (forward, reverse, turn: max, acceleration,
    deceleration), in the chair's units; values inside the SDK's documented ranges."""
    return [
        [15, 16, 64, 10, 16, 56, 10, 56, 72],
        [25, 16, 64, 10, 16, 56, 15, 56, 72],
        [35, 16, 64, 15, 16, 56, 20, 56, 72],
        [45, 16, 64, 20, 16, 56, 25, 56, 72],
        [60, 16, 64, 20, 16, 56, 25, 56, 72],
        [35, 16, 64, 15, 16, 56, 20, 56, 72],
    ]


@dataclass
class ChairParams:
    """The emulated chair's build and behaviour (defaults: a Model CR, WHILL's figures)."""

    track_m: float = 0.496  # between the drive wheels
    wheel_radius_m: float = 0.1325
    max_accel: float = 1.0  # m/s^2, speeding up and slowing down (inf: at once)
    max_turn_accel: float = 2.0  # rad/s^2
    timeout_s: float = 1.0  # the chair's own command timeout under serial control
    joystick_speed: float = 1.0  # m/s at full forward deflection
    joystick_turn_rate: float = 1.0  # rad/s at full side deflection
    rider_overrides: bool = True  # a deflected joystick drives the chair whatever serial says


@dataclass
class ChairModel:
    """The chair's state: power, control, motion, battery, error, data stream.

    Pure: every method that needs the time takes it (seconds on any monotonic clock).
    :meth:`handle` applies a command payload, :meth:`due` steps the motion to ``now`` and
    returns the data packets due by then. The rider and the chair's condition are plain
    attributes and :meth:`rider_joystick`.
    """

    params: ChairParams = field(default_factory=ChairParams)
    powered: bool = True
    battery_level: int = 80  # %
    battery_current_ma: float = 0.0
    error_code: int = 0
    speed_mode: int = 0  # the mode the speed mode indicator shows
    # where the chair is (its own frame: where it started) and how it moves
    x: float = 0.0
    y: float = 0.0
    theta: float = 0.0
    v: float = 0.0
    w: float = 0.0
    right_angle: float = 0.0  # rad, unwrapped, forward positive
    left_angle: float = 0.0
    # who drives it
    serial_control: bool = False
    joystick: tuple[int, int] = (0, 0)  # the rider's (front, side)
    command_v: float = 0.0  # what the last serial command asked for
    command_w: float = 0.0
    last_command_at: float | None = None
    last_velocity: tuple[int, int] | None = None  # the last SetVelocity's (front, side)
    # bookkeeping for tests and logs
    commands: int = 0  # motion commands received (SetVelocity, SetJoystick)
    timeouts: int = 0  # times the chair's own timeout stopped it
    timeout_at: float | None = None  # when it last did
    profiles: list[list[int]] = field(default_factory=default_profiles)
    battery_voltage_out: bool = False
    battery_saving: tuple[int, bool] = (19, True)
    # the data stream
    stream_set: int | None = None
    stream_interval_s: float = 0.0
    stream_mode: int = 0
    next_due: float = 0.0
    t: float | None = None  # the time the motion was stepped to
    started: float | None = None  # the chair's clock origin (its time stamps count from it)
    catch_up_s: float = 5.0  # fell further behind than this: skip the missed packets

    # -- commands --------------------------------------------------------------------------

    def handle(self, payload: bytes, now: float) -> list[bytes]:
        """Apply one command payload received at ``now``; the packets the chair answers."""
        self._clock(now)
        cmd = payload[0]
        if cmd == Command.SET_POWER:
            return self._set_power(payload[1] == 1, now)
        if not self.powered:
            return []  # a sleeping chair hears only SetPower
        if cmd == Command.START_SENDING_DATA:
            interval_ms = max(MIN_INTERVAL_MS, (payload[2] << 8) | payload[3])
            self.stream_set = payload[1] if payload[1] in (0, 1) else None
            self.stream_interval_s = interval_ms / 1000.0
            self.stream_mode = min(payload[4], SPEED_MODES - 1)
            self.next_due = now + self.stream_interval_s
        elif cmd == Command.STOP_SENDING_DATA:
            self.stream_set = None
        elif cmd == Command.SET_JOYSTICK:
            front, side = _s8(payload[2]), _s8(payload[3])
            self._motion_command(payload[1], now)
            self.command_v = _clamp(front, -100, 100) / 100 * self.params.joystick_speed
            self.command_w = -_clamp(side, -100, 100) / 100 * self.params.joystick_turn_rate
        elif cmd == Command.SET_VELOCITY:
            front = int(_clamp(_s16(payload[2], payload[3]), *FRONT_RANGE))
            side = int(_clamp(_s16(payload[4], payload[5]), *SIDE_RANGE))
            self._motion_command(payload[1], now)
            self.last_velocity = (front, side)
            self.command_v = front * KMH_UNIT / 3.6
            self.command_w = -side * KMH_UNIT / 3.6 / self.params.track_m
        elif cmd == Command.SET_SPEED_PROFILE and payload[1] < SPEED_MODES:
            self.profiles[payload[1]] = list(payload[2:11])
        elif cmd == Command.SET_BATTERY_VOLTAGE_OUT:
            self.battery_voltage_out = payload[1] == 1
        elif cmd == Command.SET_BATTERY_SAVING:
            self.battery_saving = (payload[1], bool(payload[2]))
        return []

    def _set_power(self, on: bool, now: float) -> list[bytes]:
        if on == self.powered:
            return []
        self.powered = on
        self.stream_set = None
        self.serial_control = False
        if not on:
            self.v = self.w = 0.0
            return []
        return [frame(bytes([POWER_ON_ANSWER]))]

    def _motion_command(self, user_control: int, now: float) -> None:
        self.commands += 1
        self.last_command_at = now
        self.serial_control = user_control == 0

    def rider_joystick(self, front: int, side: int) -> None:
        """The rider deflects the joystick (``(0, 0)``: lets go); -100..100, side > 0 right."""
        self.joystick = (int(_clamp(front, -100, 100)), int(_clamp(side, -100, 100)))

    # -- time and motion -------------------------------------------------------------------

    def _clock(self, now: float) -> None:
        if self.started is None:
            self.started = now
        if self.t is None:
            self.t = now

    def due(self, now: float) -> list[bytes]:
        """Step the motion to ``now`` and return the data packets due by then, each made at
        its own time (the model steps exactly at the packet times while streaming)."""
        self._clock(now)
        out: list[bytes] = []
        if self.stream_set is None or not self.powered:
            self.advance(now)
            return out
        if now - self.next_due > self.catch_up_s:  # stalled for long: skip, as a lost line
            self.next_due = now
        while self.next_due <= now + TIME_EPS:
            self.advance(self.next_due)
            out.append(self.data_packet())
            self.next_due += self.stream_interval_s
        return out

    def advance(self, t: float) -> None:
        """Step the motion from the last step to ``t`` at one velocity (held constant)."""
        self._clock(t)
        dt = t - self.t
        if dt <= 0:
            return
        self.t = t
        target_v, target_w = self._target(t)
        p = self.params
        self.v = _approach(self.v, target_v, p.max_accel * dt)
        self.w = _approach(self.w, target_w, p.max_turn_accel * dt)
        if abs(self.w) < 1e-9:
            self.x += self.v * dt * math.cos(self.theta)
            self.y += self.v * dt * math.sin(self.theta)
        else:  # the exact arc
            turn = self.w * dt
            radius = self.v / self.w
            self.x += radius * (math.sin(self.theta + turn) - math.sin(self.theta))
            self.y -= radius * (math.cos(self.theta + turn) - math.cos(self.theta))
        self.theta = _wrap(self.theta + self.w * dt)
        right, left = self.wheel_speeds()
        self.right_angle += right * dt / p.wheel_radius_m
        self.left_angle += left * dt / p.wheel_radius_m

    def _target(self, t: float) -> tuple[float, float]:
        """The velocity the chair is asked for at ``t`` (and the timeout, if it falls due)."""
        if not self.powered or self.error_code:
            self.serial_control = False
            return 0.0, 0.0
        if (
            self.serial_control
            and self.last_command_at is not None
            and t - self.last_command_at >= self.params.timeout_s
        ):
            self.serial_control = False
            self.timeouts += 1
            self.timeout_at = t
        rider = self.joystick != (0, 0)
        if self.serial_control and not (rider and self.params.rider_overrides):
            return self.command_v, self.command_w
        front, side = self.joystick
        return front / 100 * self.params.joystick_speed, -side / 100 * (
            self.params.joystick_turn_rate
        )

    def wheel_speeds(self) -> tuple[float, float]:
        """(right, left) tyre speeds, m/s, forward positive."""
        half = self.w * self.params.track_m / 2
        return self.v + half, self.v - half

    # -- what the chair sends --------------------------------------------------------------

    def stamp_ms(self) -> int:
        """The data set 1 time stamp now: the chair's milliseconds, counting 0..200."""
        return int(round((self.t - self.started) * 1000)) % STAMP_MODULO

    def data_packet(self) -> bytes:
        """The packet of the data set being streamed (set 1 unless set 0 was asked for)."""
        return frame(self.data_set_0() if self.stream_set == 0 else self.data_set_1())

    def data_set_0(self) -> bytes:
        """Data set 0 payload: the streamed speed mode and its profile."""
        return bytes([0x00, self.stream_mode, *self.profiles[self.stream_mode]])

    def data_set_1(self) -> bytes:
        """Data set 1 payload: joystick, battery, wheels, power, speed mode, error, stamp."""
        right, left = self.wheel_speeds()
        front, side = self.joystick
        return b"".join(
            [
                bytes([0x01]),
                bytes(IMU_BYTES),
                bytes([front & 0xFF, side & 0xFF, int(_clamp(self.battery_level, 0, 100))]),
                _int16(self.battery_current_ma / CURRENT_UNIT_MA),
                _int16(_wrap(RIGHT_SIGN * self.right_angle) / ANGLE_UNIT),
                _int16(_wrap(LEFT_SIGN * self.left_angle) / ANGLE_UNIT),
                _int16(RIGHT_SIGN * right * 3.6 / KMH_UNIT),
                _int16(LEFT_SIGN * left * 3.6 / KMH_UNIT),
                bytes(
                    [
                        int(self.powered),
                        self.speed_mode & 0xFF,
                        self.error_code & 0xFF,
                        self.stamp_ms(),
                    ]
                ),
            ]
        )


def _approach(current: float, target: float, max_step: float) -> float:
    return current + max(-max_step, min(max_step, target - current))


class WhillEmulator:
    """A :class:`ChairModel` behind a pseudo terminal: open :attr:`port` with the SDK.

    One thread reads what the host writes, hands each command to the model, steps the
    model at the data stream's times and writes its packets. Reach the model only under
    :meth:`locked` (``with emu.locked() as chair: chair.rider_joystick(60, 0)``).

    Bytes the host does not read are lost, as on a serial line: when the slave's buffer
    is full (no host, or one that stopped reading) the packet is dropped, never queued.
    """

    POLL_S = 0.01  # the longest the thread sleeps (steps the motion when not streaming)

    def __init__(self, chair: ChairModel | None = None) -> None:
        self.chair = chair or ChairModel()
        self._lock = threading.Lock()
        self._master, self._slave = os.openpty()
        tty.setraw(self._slave)  # no echo, no line editing before the SDK configures it
        os.set_blocking(self._master, False)
        self.port = os.ttyname(self._slave)
        self.reader = PacketReader()
        self.dropped = 0  # packets the host did not take
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="whill-emulator", daemon=True)

    def start(self) -> WhillEmulator:
        """Start answering on :attr:`port`."""
        self._thread.start()
        return self

    def close(self) -> None:
        """Stop the thread and close both ends of the pseudo terminal."""
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(timeout=2.0)
        for fd in (self._master, self._slave):
            with contextlib.suppress(OSError):
                os.close(fd)

    def __enter__(self) -> WhillEmulator:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.close()

    @contextlib.contextmanager
    def locked(self) -> Iterator[ChairModel]:
        """The model, held still against the I/O thread."""
        with self._lock:
            yield self.chair

    def _run(self) -> None:
        while not self._stop.is_set():
            now = time.monotonic()
            with self._lock:
                chair = self.chair
                wait = self.POLL_S
                if chair.stream_set is not None and chair.powered:
                    wait = _clamp(chair.next_due - now, 0.0, self.POLL_S)
            ready, _, _ = select.select([self._master], [], [], wait)
            data = self._read() if ready else b""
            now = time.monotonic()
            with self._lock:
                out = self.chair.due(now)  # packets due before what just arrived
                for payload in self.reader.feed(data):
                    out += self.chair.handle(payload, now)
            for packet in out:
                self._write(packet)

    def _read(self) -> bytes:
        try:
            return os.read(self._master, 4096)
        except (BlockingIOError, OSError):
            return b""

    def _write(self, packet: bytes) -> None:
        try:
            written = os.write(self._master, packet)
        except (BlockingIOError, OSError):
            written = 0
        if written != len(packet):
            self.dropped += 1
