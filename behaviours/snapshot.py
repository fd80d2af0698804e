"""Tree snapshots: the statuses and feedback of every behaviour, for streaming and display.

Built after a tick by walking the tree (as py_trees' SnapshotVisitor does); ``signature``
leaves out feedback so a countdown or a progress figure does not make every tick a change.
"""

from __future__ import annotations

import py_trees

from shared.messages import TreeNode, TreeSnapshot


def _preorder(b: py_trees.behaviour.Behaviour):
    yield b
    for child in b.children:
        yield from _preorder(child)


def snapshot(root: py_trees.behaviour.Behaviour, stamp: float, goal_id: str) -> TreeSnapshot:
    """The whole tree under ``root``, parents before children (display order)."""
    order = list(_preorder(root))
    ids = {b.id: i for i, b in enumerate(order)}
    nodes = [
        TreeNode(
            ids[b.id],
            ids[b.parent.id] if b is not root and b.parent is not None else -1,
            b.name,
            type(b).__name__,
            b.status.value,
            b.feedback_message or "",
        )
        for b in order
    ]
    return TreeSnapshot(stamp, goal_id, root.name, nodes)


def signature(snap: TreeSnapshot) -> tuple:
    """What counts as a change of the tree: its shape and statuses (not feedback)."""
    return (snap.goal_id, snap.tree, tuple((n.id, n.status) for n in snap.nodes))
