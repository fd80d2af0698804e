"""Topic keys: one table, robot namespaces, and the docs generated from it."""

from __future__ import annotations

import pytest

from shared.topics import TOPICS, Keys, markdown_table
from tests.conftest import ROOT


def test_keys_are_namespaced_per_robot() -> None:
    k = Keys("chair2")
    assert k.odom == "wheelnav/chair2/odom"
    assert k.key("alive", service="planner") == "wheelnav/chair2/alive/planner"
    assert k.key("alive") == "wheelnav/chair2/alive/*"
    assert k.key("door_state", door="d1") == "wheelnav/building/door/d1/state"


def test_bad_names_are_refused() -> None:
    with pytest.raises(ValueError, match="robot name 'a/b'"):
        Keys("a/b")
    with pytest.raises(KeyError, match="unknown topic 'odometry'"):
        Keys("c").key("odometry")


def test_names_are_unique() -> None:
    names = [t.name for t in TOPICS]
    assert len(names) == len(set(names))


def test_architecture_doc_has_the_current_table() -> None:
    doc = (ROOT / "docs" / "ARCHITECTURE.md").read_text()
    assert markdown_table() in doc


def test_no_topic_literals_outside_topics_module() -> None:
    offenders = []
    for folder in ("services", "behaviours", "sim", "shared"):
        for path in (ROOT / folder).rglob("*.py"):
            if path.name == "topics.py":
                continue
            if '"wheelnav/' in path.read_text():
                offenders.append(str(path.relative_to(ROOT)))
    assert offenders == []


def test_zenoh_only_in_nodes_and_transport() -> None:
    allowed = {"shared/transport.py"}
    offenders = []
    for folder in ("services", "behaviours", "sim", "shared"):
        for path in (ROOT / folder).rglob("*.py"):
            rel = str(path.relative_to(ROOT))
            if path.name == "node.py" or rel in allowed:
                continue
            if "import zenoh" in path.read_text():
                offenders.append(rel)
    assert offenders == []


def test_no_navigation_service_listens_to_ground_truth() -> None:
    """Ground truth is for evaluation (sim, building emulator, mission report, viz) only."""
    navigation = ("localisation", "planner", "controller", "navigator")
    for name in navigation:
        source = (ROOT / "services" / name / "node.py").read_text()
        assert "ground_truth" not in source and "sim_status" not in source, name
    for path in (ROOT / "behaviours").rglob("*.py"):
        assert "ground_truth" not in path.read_text(), path.name
