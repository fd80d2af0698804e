"""A service's saved state: atomic, per service, nothing kept without a folder."""

from __future__ import annotations

from pathlib import Path

from shared.state_store import STATE_DIR_ENV, StateStore


def test_saves_and_loads_per_service(tmp_path: Path) -> None:
    a, b = StateStore(tmp_path, "localisation"), StateStore(tmp_path, "navigator")
    a.save({"stamp": 1.5, "pose": [1, 2, 3]})
    a.save({"stamp": 2.5, "pose": [1, 2, 4]})  # replaces
    assert a.load() == {"stamp": 2.5, "pose": [1, 2, 4]} and b.load() is None
    assert sorted(p.name for p in tmp_path.iterdir()) == ["localisation.json"]  # no temp left


def test_damaged_or_absent_state_is_none_with_a_reason(tmp_path: Path) -> None:
    store = StateStore(tmp_path, "localisation")
    (tmp_path / "localisation.json").write_text('{"stamp": 1.')  # killed mid-write elsewhere
    assert store.load() is None and "unreadable" in store.problem
    (tmp_path / "localisation.json").write_text("[1, 2]")
    assert store.load() is None and "not a mapping" in store.problem
    nowhere = StateStore.from_env("localisation", {})
    nowhere.save({"x": 1})  # no folder named: keeps nothing, says nothing
    assert nowhere.load() is None and nowhere.problem == ""
    named = StateStore.from_env("localisation", {STATE_DIR_ENV: str(tmp_path / "run")})
    named.save({"x": 1})
    assert named.load() == {"x": 1}
