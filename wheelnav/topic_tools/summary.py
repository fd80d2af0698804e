"""Pure helpers of the topic tools: message summaries and rate statistics."""

from __future__ import annotations

import dataclasses
from collections import deque

import numpy as np

from shared.messages import Msg


def summarise(msg: Msg, indent: str = "  ") -> str:
    """A readable multi-line view of a message; arrays are shown by shape and a few rows."""
    lines = [f"{indent}type: {msg.TAG}"]
    for f in dataclasses.fields(msg):
        lines.append(f"{indent}{f.name}: {_show(getattr(msg, f.name), indent)}")
    return "\n".join(lines)


def _show(value: object, indent: str) -> str:
    if isinstance(value, np.ndarray):
        head = np.array2string(value[:3], precision=3, suppress_small=True).replace("\n", " ")
        more = " ..." if len(value) > 3 else ""
        return f"array {value.dtype} {value.shape} {head}{more}"
    if isinstance(value, list) and value and all(dataclasses.is_dataclass(v) for v in value):
        return f"{len(value)}" + "".join(f"\n{indent}  - {_show(v, indent)}" for v in value)
    if dataclasses.is_dataclass(value):
        inner = ", ".join(
            f"{f.name}={_fmt(getattr(value, f.name))}" for f in dataclasses.fields(value)
        )
        return f"{{{inner}}}"
    return _fmt(value)


def _fmt(value: object) -> str:
    return f"{value:.4f}" if isinstance(value, float) else repr(value)


class RateMeter:
    """Arrival rate over the last ``window`` messages."""

    def __init__(self, window: int = 100) -> None:
        self.times: deque[float] = deque(maxlen=window + 1)

    def tick(self, t: float) -> None:
        self.times.append(t)

    def rate(self) -> float:
        s = self.stats()
        return s["rate_hz"] if s else 0.0

    def stats(self) -> dict[str, float] | None:
        if len(self.times) < 2:
            return None
        gaps = np.diff(np.asarray(self.times))
        mean = float(gaps.mean())
        return {
            "rate_hz": 1.0 / mean if mean > 0 else float("inf"),
            "min_ms": 1e3 * gaps.min(),
            "max_ms": 1e3 * gaps.max(),
            "std_ms": 1e3 * gaps.std(),
            "n": len(gaps),
        }
