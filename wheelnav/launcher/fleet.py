"""The fleet, defined once: which services exist, how each is started, in which profile.

``wheelnav up`` starts these as child processes; ``docker-compose.yml`` is generated
from the same table (``wheelnav compose``) and a test checks the committed file matches.
"""

from __future__ import annotations

from dataclasses import dataclass

ROUTER_PORT = 7447


@dataclass(frozen=True)
class ServiceSpec:
    """One service process: its module and the deployment profiles it belongs to."""

    name: str
    module: str
    profiles: tuple[str, ...]
    doc: str
    args: tuple[str, ...] = ()
    devices: tuple[str, ...] = ()  # host devices a container needs (the chair's serial port)
    udp_ports: tuple[int, ...] = ()  # UDP ports a container receives on (the LiDAR's data)

    def command(self, config: str, connect: str) -> list[str]:
        """The command line that starts it (the same locally and in a container)."""
        return ["python", "-m", self.module, "--config", config, "--connect", connect, *self.args]


SERVICES: tuple[ServiceSpec, ...] = (
    ServiceSpec(
        "sim",
        "services.sim.node",
        ("sim", "hardware_path"),
        "pybullet simulator: clock, odometry, LiDAR, collisions",
    ),
    ServiceSpec(
        "building",
        "services.building.node",
        ("sim", "hardware_path"),
        "building emulator: doors and lifts (Open-RMF protocol)",
    ),
    ServiceSpec(
        "localisation",
        "services.localisation.node",
        ("sim", "hardware", "hardware_path"),
        "pose on the floor map",
    ),
    ServiceSpec(
        "planner",
        "services.planner.node",
        ("sim", "hardware", "hardware_path"),
        "routes on the site maps",
    ),
    ServiceSpec(
        "controller",
        "services.controller.node",
        ("sim", "hardware", "hardware_path"),
        "path tracking: velocity commands",
    ),
    ServiceSpec(
        "navigator",
        "services.navigator.node",
        ("sim", "hardware", "hardware_path"),
        "mission behaviour tree",
    ),
    ServiceSpec(
        "driver",
        "services.whill_driver.node",
        ("hardware", "hardware_path"),
        "WHILL base driver: cmd_vel to the chair, odometry and status back",
        devices=("/dev/ttyUSB0",),
    ),
    ServiceSpec(
        "vlp16_driver",
        "services.vlp16_driver.node",
        ("hardware", "hardware_path"),
        "VLP-16 LiDAR driver: UDP packets to scan",
        udp_ports=(2368,),
    ),
    ServiceSpec(
        "rmf_bridge",
        "services.rmf_bridge.node",
        ("hardware",),
        "building bridge: the doors and lifts of an Open-RMF building (CDR over Zenoh)",
    ),
)
# hardware_path: the simulator (with sim.hardware_path) behind the drivers' serial and UDP
# links, on wall time on one host (a pseudo terminal joins sim and driver): docs/hardware.md
PROFILES = ("sim", "hardware", "hardware_path")
# what a profile cannot run without, set by ``wheelnav up --profile`` after the user's own
# ``--set`` (a driver on a real chair has no simulated clock; the emulated chair moves in
# real time): sim/hardware_path.py names the same keys
PROFILE_SETTINGS = {
    "hardware": ("clock=wall",),
    "hardware_path": (
        "clock=wall",
        "sim.lockstep=false",
        "sim.realtime_factor=1",
        "sim.hardware_path=true",
    ),
}


def viz_recorder(rrd_path: str) -> ServiceSpec:
    """The optional rerun recorder, added by ``wheelnav mission --rrd`` and ``up --rrd``."""
    return ServiceSpec("viz", "services.viz.node", (), "rerun recording", ("--save", rrd_path))


def services_for(profile: str) -> list[ServiceSpec]:
    """The services of ``profile``; ValueError naming the known profiles otherwise."""
    if profile not in PROFILES:
        raise ValueError(f"unknown profile {profile!r} (known: {', '.join(PROFILES)})")
    return [s for s in SERVICES if profile in s.profiles]


NO_SERVICES = "none"  # ``up --services none``: the router alone (a laptop's, for its clients)


def pick(specs: list[ServiceSpec], names: str) -> list[ServiceSpec]:
    """The services of ``specs`` named in ``names`` (comma-separated; "none": no service),
    in fleet order: what runs on one host of a fleet split across several. ValueError
    naming the names ``specs`` does not hold."""
    wanted = [n.strip() for n in names.split(",") if n.strip()]
    if wanted == [NO_SERVICES]:
        return []
    known = [s.name for s in specs]
    unknown = [n for n in wanted if n not in known]
    if unknown or not wanted:
        raise ValueError(
            f"--services {names!r}: {', '.join(unknown) or 'no name'} not in the profile "
            f"(it has {', '.join(known)}; or {NO_SERVICES}: the router alone)"
        )
    return [s for s in specs if s.name in wanted]
