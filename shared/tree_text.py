"""A behaviour-tree snapshot (TreeSnapshot) as indented text, for terminals and viewers."""

from __future__ import annotations

from shared.messages import TreeSnapshot

MARKS = {"SUCCESS": "✓", "FAILURE": "✗", "RUNNING": "*", "INVALID": "-"}


def render_tree(snap: TreeSnapshot) -> str:
    """A TreeSnapshot as an indented text tree with status marks and feedback."""
    children: dict[int, list] = {}
    for node in snap.nodes:
        children.setdefault(node.parent, []).append(node)
    lines = [f"goal {snap.goal_id}  t={snap.stamp:.1f} s  tree {snap.tree}"]

    def walk(node, depth: int) -> None:
        mark = MARKS.get(node.status, "?")
        fb = f"  -- {node.feedback}" if node.feedback and node.status != "INVALID" else ""
        lines.append(f"{'    ' * depth}{mark} {node.name} [{node.kind}]{fb}")
        for child in children.get(node.id, []):
            walk(child, depth + 1)

    for root in children.get(-1, []):
        walk(root, 0)
    return "\n".join(lines)
