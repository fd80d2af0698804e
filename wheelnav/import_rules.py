"""The layout's import rules, checked on the source (``python -m wheelnav.import_rules``).

The folders of the project and what each may import (docs/ARCHITECTURE.md draws it):

- ``services/<name>/``: one process each. A service never imports another service, nor
  the tools; it may import ``shared``, ``sim`` and ``behaviours``.
- Only a service's ``node.py`` (and ``shared/transport.py``, the bus) imports ``zenoh``;
  tools may too. Algorithms stay testable without a network.
- ``shared/`` imports nothing of ours but ``shared``.
- ``sim/`` and ``behaviours/`` import only ``shared`` (and themselves).
- ``wheelnav/`` (the tools: CLI, launcher, mission runner, benchmarks) may import anything.

Imports are read with :mod:`ast` (also those inside functions), never executed, so the
checker runs on any tree, including a fixture that breaks every rule on purpose.
"""

from __future__ import annotations

import argparse
import ast
import sys
from dataclasses import dataclass
from pathlib import Path

OURS = ("services", "shared", "sim", "behaviours", "wheelnav")
TRANSPORT = "shared/transport.py"


@dataclass(frozen=True)
class Violation:
    """One import that breaks a rule: where it stands, what it imports, which rule."""

    path: str
    line: int
    imported: str
    rule: str

    def __str__(self) -> str:
        return f"{self.path}:{self.line}: imports {self.imported}: {self.rule}"


def imports_of(source: str, module: str) -> list[tuple[int, str]]:
    """(line, dotted module) for every import in ``source``; ``module`` resolves relative ones."""
    out: list[tuple[int, str]] = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            out += [(node.lineno, alias.name) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parent = module.split(".")[: -node.level]
                base = ".".join([*parent, base] if base else parent)
            # ``from pkg import sub`` may name a submodule: count pkg.sub as imported too
            out += [(node.lineno, f"{base}.{alias.name}") for alias in node.names]
    return out


def _rule(path: str, imported: str) -> str | None:
    """The rule ``path`` (relative, with '/') breaks by importing ``imported``, or None."""
    parts = path.split("/")
    top, target = parts[0], imported.split(".")
    if target[0] == "zenoh":
        allowed = (
            top == "wheelnav" or path == TRANSPORT or (top == "services" and parts[-1] == "node.py")
        )
        return (
            None if allowed else "only node.py modules, shared/transport.py and tools import zenoh"
        )
    if target[0] not in OURS or top == "wheelnav":
        return None
    if top == "services":
        if target[0] == "wheelnav":
            return "a service never imports the tools (wheelnav/)"
        if target[0] == "services" and len(target) > 1 and len(parts) > 2 and target[1] != parts[1]:
            return f"no service imports another (services/{parts[1]} -> services/{target[1]})"
        return None
    if top == "shared" and target[0] != "shared":
        return "shared/ imports nothing of ours but shared"
    if top in ("sim", "behaviours") and target[0] not in ("shared", top):
        return f"{top}/ imports only shared/"
    return None


def check_tree(root: Path) -> list[Violation]:
    """Every import under ``root``'s project folders that breaks a rule."""
    found: list[Violation] = []
    for top in OURS:
        for file in sorted((root / top).rglob("*.py")):
            rel = file.relative_to(root).as_posix()
            module = rel.removesuffix(".py").replace("/", ".").removesuffix(".__init__")
            try:
                imported = imports_of(file.read_text(), module)
            except SyntaxError as exc:
                found.append(Violation(rel, exc.lineno or 0, "?", f"cannot parse: {exc.msg}"))
                continue
            for line, name in imported:
                rule = _rule(rel, name)
                if rule:
                    found.append(Violation(rel, line, name, rule))
    return found


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "root",
        nargs="?",
        default=Path(__file__).resolve().parents[1],
        type=Path,
        help="the project's root folder (default: this checkout)",
    )
    args = parser.parse_args(argv)
    violations = check_tree(args.root)
    for v in violations:
        print(v)
    print(f"{len(violations)} import rule violation(s)", file=sys.stderr)
    return 1 if violations else 0


if __name__ == "__main__":
    sys.exit(main())
