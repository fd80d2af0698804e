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
        ("launcher.router_connect=[chair:7447]", "launcher.router_connect: 'chair:7447' is not"),
        ("launcher.router_identity=a b", "launcher.router_identity: use letters"),
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


def test_mpc_tuning_has_one_home_with_the_fleets_values() -> None:
    mpc = config.load().controller.mpc
    assert (mpc.w_track, mpc.samples, mpc.steps, mpc.dt) == (10.0, 1000, 21, 0.2)
    assert (mpc.threads, mpc.safety_margin_m) == (0, 0.05)
    assert mpc == config.MPCConfig()  # the section's defaults are the class's, nothing else
    cfg = config.load(None, ["controller.mpc.w_track=4", "controller.mpc.guide_offsets_m=[0]"])
    assert cfg.controller.mpc.w_track == 4.0 and cfg.controller.mpc.guide_offsets_m == [0.0]


@pytest.mark.parametrize(
    ("override", "message"),
    [
        ("controller.mpc.temperature=0", "controller.mpc.temperature: must be > 0, got 0"),
        ("controller.mpc.samples=1", "controller.mpc.samples: must be >= 2, got 1"),
        ("controller.mpc.selection=best", "controller.mpc.selection: must be one of"),
        ("controller.mpc.noise_corr=1", "controller.mpc.noise_corr: must be in [0, 1)"),
        ("controller.mpc.w_tracks=1", "controller.mpc.w_tracks: unknown key"),
        ("controller.mpc_samples=1", "controller.mpc.samples: must be >= 2, got 1"),
    ],
)
def test_bad_mpc_values_name_the_dotted_key(override: str, message: str) -> None:
    escaped = message.replace(".", r"\.").replace("[", r"\[").replace(")", r"\)")
    with pytest.raises(ConfigError, match=escaped):
        config.load(None, [override])


@pytest.mark.parametrize(("old", "new"), sorted(config.DEPRECATED_KEYS.items()))
def test_a_deprecated_key_still_sets_its_new_key_with_a_warning(
    old: str, new: str, caplog: pytest.LogCaptureFixture
) -> None:
    value = 3 if new.endswith(("samples", "steps", "threads")) else 0.5
    with caplog.at_level("WARNING", logger="shared.config"):
        cfg = config.load(None, [f"{old}={value}"])
    section, key = new.rsplit(".", 1)
    assert section == "controller.mpc"
    assert getattr(cfg.controller.mpc, key) == value
    assert [
        r.getMessage() for r in caplog.records if old in r.getMessage() and new in r.getMessage()
    ]


def test_a_deprecated_key_in_a_file_works_and_giving_both_keys_is_an_error(
    tmp_path: Path,
) -> None:
    old = tmp_path / "old.yaml"
    old.write_text("controller:\n  mpc_track_weight: 7.5\n  mpc:\n    samples: 300\n")
    mpc = config.load(old).controller.mpc
    assert (mpc.w_track, mpc.samples) == (7.5, 300)
    both = ["controller.mpc_track_weight=3", "controller.mpc.w_track=4"]
    with pytest.raises(ConfigError, match=r"controller\.mpc_track_weight: deprecated") as info:
        config.load(None, both)
    assert "controller.mpc.w_track" in str(info.value) and "\n" not in str(info.value)
