"""The launcher and docker-compose.yml describe the same fleet, with the same commands."""

from __future__ import annotations

import pytest
import yaml

from shared.config import LauncherConfig
from shared.state_store import STATE_DIR_ENV
from tests.conftest import ROOT
from wheelnav.launcher.backoff import Backoff
from wheelnav.launcher.compose import render_compose
from wheelnav.launcher.fleet import SERVICES, pick, services_for
from wheelnav.launcher.supervisor import Supervisor


def compose() -> dict:
    return yaml.safe_load((ROOT / "docker-compose.yml").read_text())


def test_committed_compose_file_is_generated_from_the_fleet() -> None:
    assert (ROOT / "docker-compose.yml").read_text() == render_compose(), (
        "run `wheelnav compose > docker-compose.yml`"
    )


def test_same_services_and_commands_as_the_launcher() -> None:
    services = compose()["services"]
    assert set(services) == {"router"} | {s.name for s in SERVICES}
    assert services["router"]["image"].startswith("eclipse/zenoh")
    for profile in ("sim", "hardware"):
        in_compose = {n for n, s in services.items() if profile in s["profiles"]} - {"router"}
        assert in_compose == {s.name for s in services_for(profile)}
    sup = Supervisor(list(SERVICES), "tcp/router:7447", LauncherConfig(), "/config/fleet.yaml")
    for spec in SERVICES:
        local = sup._command(spec)
        container = services[spec.name]["command"]
        assert local[1:] == container[1:], spec.name  # same module, config and endpoint flags
        # a restarted container resumes from the state its service saved, as under the
        # launcher (which names a fresh folder per fleet)
        folder = services[spec.name]["environment"][STATE_DIR_ENV]
        assert f"state:{folder}" in services[spec.name]["volumes"], spec.name
        assert (ROOT / "services" / spec.module.split(".")[1] / "node.py").is_file()
    assert "state" in compose()["volumes"]


def test_dockerfile_installs_every_package_the_fleet_runs() -> None:
    dockerfile = (ROOT / "deploy" / "Dockerfile").read_text()
    for pkg in ("services", "behaviours", "sim", "shared", "sites"):
        assert f"COPY {pkg} ./{pkg}" in dockerfile
    for profile in ("sim", "hardware"):
        assert (ROOT / "deploy" / f"fleet.{profile}.yaml").is_file()


def test_backoff_grows_and_resets() -> None:
    b = Backoff(base_s=0.5, max_s=4.0, reset_after_s=30.0)
    assert [b.on_exit(1.0) for _ in range(5)] == [0.5, 1.0, 2.0, 4.0, 4.0]
    assert b.on_exit(60.0) == 0.5


def test_a_host_of_a_split_fleet_runs_the_services_it_names_or_none() -> None:
    sim = services_for("sim")
    chair = pick(sim, "navigator,sim, controller,localisation,planner")
    assert [s.name for s in chair] == ["sim", "localisation", "planner", "controller", "navigator"]
    assert [s.name for s in pick(sim, "building")] == ["building"]
    assert pick(sim, "none") == []  # the router alone: a laptop's, for its clients
    with pytest.raises(ValueError, match="driver not in the profile"):
        pick(sim, "building,driver")
    with pytest.raises(ValueError, match="no name not in the profile"):
        pick(sim, ",")


def test_up_names_a_service_its_profile_lacks_in_one_line(capsys) -> None:
    from wheelnav.cli import main

    assert main(["up", "--services", "driver"]) == 2  # the sim profile has no driver
    err = capsys.readouterr().err
    assert "driver not in the profile" in err and err.count("\n") == 1


def test_up_gives_the_hardware_path_the_settings_it_cannot_run_without() -> None:
    # `wheelnav up --profile hardware_path` needed four --set flags, or the simulator
    # refused to start; the profile now brings them, and they are the ones it checks
    from shared import config as config_mod
    from sim.hardware_path import check_hardware_path
    from wheelnav.launcher.fleet import PROFILE_SETTINGS

    with pytest.raises(config_mod.ConfigError, match="clock: must be 'wall'"):
        check_hardware_path(config_mod.load(None, ["sim.hardware_path=true"]))
    settings = list(PROFILE_SETTINGS["hardware_path"])
    check_hardware_path(config_mod.load(None, settings))  # runs as it is
    assert "clock=wall" in PROFILE_SETTINGS["hardware"]
