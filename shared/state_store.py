"""What a service keeps so that, restarted by the launcher, it carries on where it stopped.

One small JSON file per service in the folder named by ``WHEELNAV_STATE_DIR`` (the launcher
sets it for its children: a fresh folder per fleet unless the user names one, as a compose
volume does). A write goes to a temporary file first and is then renamed over the old one,
so a service killed mid-write leaves the previous state whole. Without the variable the
store keeps nothing (a service started by hand starts fresh every time).
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

STATE_DIR_ENV = "WHEELNAV_STATE_DIR"


class StateStore:
    """The saved state of one service (``folder`` None: keeps nothing)."""

    def __init__(self, folder: str | Path | None, service: str) -> None:
        self.path = None if not folder else Path(folder) / f"{service}.json"
        self.problem = ""  # why the last load found nothing usable ("" if it did, or no file)

    @classmethod
    def from_env(cls, service: str, environ: dict[str, str] | None = None) -> StateStore:
        """The store in the folder the launcher named (none if it named none)."""
        return cls((os.environ if environ is None else environ).get(STATE_DIR_ENV), service)

    def save(self, state: dict[str, Any]) -> None:
        """Replace the saved state with ``state`` (JSON types only), atomically."""
        if self.path is None:
            return
        self.path.parent.mkdir(parents=True, exist_ok=True)
        tmp = self.path.with_suffix(f".{os.getpid()}.tmp")
        tmp.write_text(json.dumps(state))
        os.replace(tmp, self.path)

    def load(self) -> dict[str, Any] | None:
        """The saved state, or None (no store, no file, or a damaged one: see ``problem``)."""
        self.problem = ""
        if self.path is None or not self.path.exists():
            return None
        try:
            state = json.loads(self.path.read_text())
        except (OSError, ValueError) as exc:
            self.problem = f"{self.path}: unreadable ({exc})"
            return None
        if not isinstance(state, dict):
            self.problem = f"{self.path}: not a mapping"
            return None
        return state
