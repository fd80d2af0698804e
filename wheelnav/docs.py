"""Regenerate the tables in docs/ that are derived from code (``make docs``).

docs/ARCHITECTURE.md holds the topic table (shared/topics.py) and docs/configuration.md
the config key table (shared/config.py); tests fail when either is stale.
"""

from __future__ import annotations

from pathlib import Path

from shared import config, topics

ROOT = Path(__file__).resolve().parents[1]
TABLES = {
    "ARCHITECTURE.md": ("| name | key | message |", topics.markdown_table),
    "configuration.md": ("| key | type | default |", config.markdown_table),
}


def replace_table(text: str, header: str, table: str) -> str:
    """``text`` with the markdown table that starts with ``header`` replaced by ``table``."""
    start = text.index(header)
    end = start
    lines = text[start:].splitlines(keepends=True)
    for line in lines:
        if not line.startswith("|"):
            break
        end += len(line)
    return text[:start] + table + "\n" + text[end:]


def main() -> None:
    for name, (header, make) in TABLES.items():
        path = ROOT / "docs" / name
        path.write_text(replace_table(path.read_text(), header, make()))
        print(f"updated {path.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
