"""The layout's import rules hold for the project, and the checker catches every break."""

from __future__ import annotations

from pathlib import Path

from wheelnav.import_rules import check_tree

ROOT = Path(__file__).resolve().parents[1]
FIXTURE = Path(__file__).resolve().parent / "fixtures" / "layout_breaks"


def test_the_project_keeps_its_import_rules() -> None:
    assert [str(v) for v in check_tree(ROOT)] == []


def test_every_break_in_the_fixture_is_reported_and_nothing_else() -> None:
    found = {(v.path, v.imported, v.rule.split(" (")[0]) for v in check_tree(FIXTURE)}
    zenoh = "only node.py modules, shared/transport.py and tools import zenoh"
    assert found == {
        ("services/alpha/core.py", "zenoh", zenoh),
        ("services/alpha/core.py", "services.beta.planner", "no service imports another"),
        ("services/alpha/core.py", "wheelnav.cli.main", "a service never imports the tools"),
        ("services/beta/planner.py", "services.alpha.core", "no service imports another"),
        ("shared/messages.py", "sim.world.World", "shared/ imports nothing of ours but shared"),
        ("shared/config.py", "zenoh", zenoh),
        ("sim/world.py", "behaviours.fleet.Fleet", "sim/ imports only shared/"),
        ("behaviours/fleet.py", "services.alpha.core.planner", "behaviours/ imports only shared/"),
    }
    # every file marked BREAK is among them, once per marked line
    marked = sum(p.read_text().count("# BREAK") for p in FIXTURE.rglob("*.py"))
    assert len(found) == marked
