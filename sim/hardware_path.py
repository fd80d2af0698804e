"""The simulator's hardware path: the chair and its LiDAR behind the real drivers' links.

With ``sim.hardware_path`` the simulator stands in for the hardware, not for the drivers:
it hosts an emulated WHILL Model CR (sim/whill_emulator.py) on a pseudo terminal linked at
``whill.port``, where the WHILL driver opens it as it would the chair's serial port, and
moves the pybullet chair as that chair's wheels turn (sim/wheel_drive.py); and it sends
each scan of its VLP-16 as data packets over UDP to ``sim.vlp16_host`` at ``vlp16.port``,
where the VLP-16 driver listens (sim/scan_sender.py). The drivers then take ``cmd_vel``
and publish ``odom`` and ``scan``, so the whole path a real chair's data takes (serial
protocol, SDK, packets, decoder, the drivers' nodes and stamps) runs in simulation.

Both links live on wall time (the chair model steps on its thread's monotonic clock), so
the path runs on wall time only: :func:`check_hardware_path` says what else it needs.
"""

from __future__ import annotations

import contextlib
import logging
import os
from pathlib import Path

import numpy as np

from shared.config import ConfigError, FleetConfig
from sim.robot import ChairState
from sim.scan_sender import ScanSender
from sim.wheel_drive import WheelDrive, Wheels, wheels_of
from sim.whill_emulator import ChairModel, ChairParams, WhillEmulator


def check_hardware_path(cfg: FleetConfig) -> None:
    """ConfigError naming the key if ``cfg`` asks for the hardware path with a setting it
    cannot run with (the emulated chair and the packets run on wall time), or for a rider
    without it (the rider's joystick is the emulated WHILL's)."""
    for i, rider in enumerate(cfg.sim.riders):
        if (rider.front, rider.side) == (0, 0):
            raise ConfigError(f"sim.riders[{i}]: front or side must not be 0 (a joystick at rest)")
    if not cfg.sim.hardware_path:
        if cfg.sim.riders:
            raise ConfigError(
                "sim.riders: needs sim.hardware_path (the rider's joystick is the emulated"
                f" WHILL's), got {len(cfg.sim.riders)} rider(s)"
            )
        return
    needs = [
        ("clock", cfg.clock, "wall", "the drivers run on wall time"),
        ("sim.lockstep", cfg.sim.lockstep, False, "the drivers answer no lockstep"),
        (
            "sim.realtime_factor",
            cfg.sim.realtime_factor,
            1.0,
            "the emulated chair moves in real time",
        ),
        ("sim.lidar", cfg.sim.lidar, "vlp16", "its scans go out as VLP-16 packets"),
        (
            "sim.stamp_offset_s",
            cfg.sim.stamp_offset_s,
            0.0,
            "the drivers stamp odom and scan: whill.stamp_offset_s, vlp16.stamp_offset_s",
        ),
    ]
    for key, value, wanted, why in needs:
        if value != wanted:
            raise ConfigError(
                f"{key}: must be {wanted!r} with sim.hardware_path ({why}), got {value!r}"
            )


def link_port(target: str, link: str) -> None:
    """Make ``link`` a symbolic link to ``target`` (the pseudo terminal), replacing an old
    link there but never a file or a device: OSError if ``link`` is one."""
    path = Path(link)
    if path.is_symlink():
        path.unlink()
    elif path.exists():
        raise FileExistsError(f"{link} exists and is not a symbolic link: set whill.port elsewhere")
    path.parent.mkdir(parents=True, exist_ok=True)
    path.symlink_to(target)


def unlink_port(target: str, link: str) -> None:
    """Remove ``link`` if it still points at ``target`` (another run may have taken it)."""
    with contextlib.suppress(OSError):
        if os.readlink(link) == target:
            os.unlink(link)


def chair_params(cfg: FleetConfig) -> ChairParams:
    """The emulated chair's build (the driver's whill section) and accelerations (the
    robot's: the simulated chair's own); its 1 s timeout and joystick are a Model CR's."""
    return ChairParams(
        track_m=cfg.whill.track_m,
        wheel_radius_m=cfg.whill.wheel_radius_m,
        max_accel=cfg.robot.max_accel,
        max_turn_accel=cfg.robot.max_turn_accel,
    )


class HardwarePath:
    """The emulated WHILL behind its link and the LiDAR's packet sender, for one run.

    :meth:`drive` is the Simulation's ``drive``; :meth:`send_scan` takes each scan.
    Reach the emulated chair's model only under ``emulator.locked()``.
    """

    def __init__(self, cfg: FleetConfig, log: logging.Logger | None = None) -> None:
        check_hardware_path(cfg)
        self.cfg = cfg
        self.log = log or logging.getLogger("wheelnav.sim")
        self.link = cfg.whill.port
        self.emulator = WhillEmulator(ChairModel(chair_params(cfg)))
        try:
            link_port(self.emulator.port, self.link)
        except OSError:
            self.emulator.close()
            raise
        self.sender = ScanSender(cfg.sim.vlp16_host, cfg.vlp16.port)
        self.joystick = (0, 0)  # as the scripted riders (sim.riders) hold it now
        self.emulator.start()
        self.sender.start()
        self.log.info(
            "hardware path: WHILL emulator on %s (linked at %s), VLP-16 packets to udp %s:%d",
            self.emulator.port,
            self.link,
            cfg.sim.vlp16_host,
            cfg.vlp16.port,
        )

    def drive(self, start: ChairState) -> WheelDrive:
        """The chair's drive from ``start``: the emulated chair's wheels, with the ground's
        errors and the casters' kick as the simulator's own chair has them."""
        sim = self.cfg.sim
        return WheelDrive(
            start,
            self.wheels,
            self.cfg.whill.wheel_radius_m,
            self.cfg.whill.track_m,
            sim.odom_scale_error,
            sim.odom_turn_bias,
            sim.caster_disturbance,
            np.random.default_rng([sim.seed, 2]),
        )

    def wheels(self) -> Wheels:
        """The emulated chair's wheels now."""
        with self.emulator.locked() as chair:
            return wheels_of(chair)

    def streaming(self) -> bool:
        """Whether a driver has asked the emulated chair for its data (the link is up)."""
        with self.emulator.locked() as chair:
            return chair.stream_set is not None

    def ride(self, t_s: float) -> str:
        """Deflect the emulated chair's joystick as the scripted riders hold it at the
        simulator's time ``t_s`` (the first rider then riding; at rest when none is); what
        changed, in words ("" when nothing did)."""
        now = next(
            ((r.front, r.side) for r in self.cfg.sim.riders if r.at_s <= t_s < r.at_s + r.for_s),
            (0, 0),
        )
        if now == self.joystick:
            return ""
        self.joystick = now
        with self.emulator.locked() as chair:
            chair.rider_joystick(*now)
        if now == (0, 0):
            return "the rider lets go of the joystick"
        return f"the rider takes the joystick (front {now[0]}, side {now[1]})"

    def send_scan(self, points: np.ndarray, stamp_s: float) -> None:
        """Send one scan (sensor-frame points) as a revolution of packets."""
        self.sender.submit(points, stamp_s)

    def close(self) -> None:
        """Stop both links and remove the port's link."""
        self.sender.close()
        self.emulator.close()
        unlink_port(self.emulator.port, self.link)
        self.log.info(
            "hardware path: %d revolutions sent (%d packets), %d dropped; %d chair packets lost",
            self.sender.revolutions,
            self.sender.packets,
            self.sender.dropped,
            self.emulator.dropped,
        )
