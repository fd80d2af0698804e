"""Config: defaults, overrides, and one-line errors naming the bad key."""

from __future__ import annotations

from pathlib import Path

import pytest

from shared import config
from shared.config import ConfigError


def test_defaults_load() -> None:
    cfg = config.load()
    assert cfg.robot.footprint.width == 0.65
    assert cfg.sim.watchdog_s == 0.3


def test_overrides_apply_with_yaml_values() -> None:
    cfg = config.load(
        None, ["sim.seed=7", "controller.lookahead_m=0.8", "transport.connect=[tcp/h:1]"]
    )
    assert cfg.sim.seed == 7 and cfg.controller.lookahead_m == 0.8
    assert cfg.transport.connect == ["tcp/h:1"]


@pytest.mark.parametrize(
    ("override", "message"),
    [
        ("controller.lookahead_m=-0.2", "controller.lookahead_m: must be > 0, got -0.2"),
        ("controller.lookahed_m=1", "controller.lookahed_m: unknown key"),
        ("sim.seed=abc", "sim.seed: expected an integer"),
        ("transport.mode=mesh", "transport.mode: must be client, peer or router"),
        ("robot.footprint=3", "robot.footprint: expected a mapping"),
        ("sim.dt=.nan", "sim.dt: expected a finite number"),
        ("nonsense", "expected KEY=VALUE"),
    ],
)
def test_bad_values_name_the_key(override: str, message: str) -> None:
    with pytest.raises(ConfigError, match=message.replace(".", r"\.").replace("[", r"\[")) as info:
        config.load(None, [override])
    assert "\n" not in str(info.value)


def test_missing_and_malformed_files(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="no such file"):
        config.load(tmp_path / "nope.yaml")
    bad = tmp_path / "bad.yaml"
    bad.write_text("sim: [1, 2\n")
    with pytest.raises(ConfigError, match="not valid YAML"):
        config.load(bad)
    listy = tmp_path / "list.yaml"
    listy.write_text("- 1\n")
    with pytest.raises(ConfigError, match="mapping at the top level"):
        config.load(listy)


def test_configuration_doc_lists_every_key() -> None:
    from tests.conftest import ROOT

    doc = (ROOT / "docs" / "configuration.md").read_text()
    assert config.markdown_table() in doc, "regenerate the table in docs/configuration.md"
