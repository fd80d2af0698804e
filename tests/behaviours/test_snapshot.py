"""Tree snapshots: parents first, statuses and feedback, changes without feedback noise."""

from __future__ import annotations

import py_trees

from behaviours.snapshot import signature, snapshot
from shared.codec import decode, encode
from shared.messages import TreeSnapshot
from shared.tree_text import render_tree


def tree() -> py_trees.behaviour.Behaviour:
    drive = py_trees.composites.Sequence(
        "Drive",
        memory=True,
        children=[py_trees.behaviours.Success("Leg 0"), py_trees.behaviours.Running("Door d1")],
    )
    return py_trees.composites.Selector(
        "Route", memory=True, children=[drive, py_trees.behaviours.Failure("SafeStop")]
    )


def test_snapshot_order_statuses_and_wire_round_trip() -> None:
    root = tree()
    root.tick_once()
    snap = decode(encode(snapshot(root, 3.0, "g1")), TreeSnapshot)
    assert [n.name for n in snap.nodes] == ["Route", "Drive", "Leg 0", "Door d1", "SafeStop"]
    assert [n.parent for n in snap.nodes] == [-1, 0, 1, 1, 0]
    assert [n.status for n in snap.nodes] == ["RUNNING", "RUNNING", "SUCCESS", "RUNNING", "INVALID"]
    text = render_tree(snap)
    assert "* Route [Selector]" in text and "    ✓ Leg 0 [Success]" in text


def test_feedback_alone_is_not_a_change() -> None:
    root = tree()
    root.tick_once()
    a = snapshot(root, 1.0, "g1")
    root.children[0].children[1].feedback_message = "42 % done"
    b = snapshot(root, 1.1, "g1")
    assert signature(a) == signature(b)
    root.tick_once()
    assert signature(snapshot(root, 1.2, "g1")) == signature(a)  # same statuses again
