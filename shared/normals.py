"""Standard normals of one generator, drawn a block ahead on a helper thread.

The MPC's exploration noise (1000 samples x 21 steps x 2 a cycle: 0.46 ms to draw) and
the VLP-16's range noise (about 25,000 returns a scan: 0.22 ms) are big float32 draws
each cycle. numpy's generator fills a block without the interpreter lock, so the next
block is drawn on a helper thread while the rest of the cycle (and of the fleet) runs.

The values are the generator's own, in order: consecutive draws of one dtype from a
numpy ``Generator`` continue one stream, so taking ``n`` values here gives what drawing
``n`` at that moment would have given, however the blocks fall (tests/shared/
test_normals.py). A stream must own its generator: nothing else may draw from it.
"""

from __future__ import annotations

import queue
import threading
from collections.abc import Callable
from concurrent.futures import Future

import numpy as np

_helpers: dict[str, queue.SimpleQueue] = {}
_helpers_lock = threading.Lock()


def _serve(jobs: queue.SimpleQueue) -> None:
    while True:
        fill, done = jobs.get()
        try:
            done.set_result(fill())
        except BaseException as exc:  # handed to the stream, raised there
            done.set_exception(exc)


def _submit(thread_name: str, fill: Callable[[], np.ndarray]) -> Future:
    """Run ``fill`` on the process's helper thread named ``thread_name`` (started on first
    use; ``wheelnav bench fleet`` charges a thread named "NAME-noise" to service NAME)."""
    with _helpers_lock:
        jobs = _helpers.get(thread_name)
        if jobs is None:
            jobs = _helpers[thread_name] = queue.SimpleQueue()
            threading.Thread(target=_serve, args=(jobs,), name=thread_name, daemon=True).start()
    done: Future = Future()
    jobs.put((fill, done))
    return done


class NormalStream:
    """float32 standard normals of ``rng``, served in order by :meth:`take`, drawn in
    blocks of ``block`` values one block ahead on the helper thread ``thread_name``."""

    def __init__(self, rng: np.random.Generator, block: int, thread_name: str) -> None:
        if block < 1:
            raise ValueError(f"block must be >= 1, got {block}")
        self._rng = rng
        self._block = block
        self._thread = thread_name
        self._current = np.empty(0, dtype=np.float32)
        self._used = 0
        self._pending: Future | None = None
        self.ahead()

    def take(self, n: int) -> np.ndarray:
        """The next ``n`` values (waits for the helper if it is still drawing them): a
        view of a block no one else sees, or a new array where ``n`` spans blocks. A block
        used up here is replaced by the one drawn ahead; the one after is not started
        until :meth:`ahead` (or the next take that needs it)."""
        parts = []
        while n > 0:
            if self._used == len(self._current):
                self.ahead()
                self._current, self._used, self._pending = self._pending.result(), 0, None
            part = self._current[self._used : self._used + n]
            self._used += len(part)
            n -= len(part)
            parts.append(part)
        if len(parts) == 1:
            return parts[0]
        return np.concatenate(parts) if parts else np.empty(0, dtype=np.float32)

    def ahead(self) -> None:
        """Start drawing the next block (no-op if started): call it once the values taken
        are in use, so that it is drawn meanwhile (the MPC calls it once its kernel,
        which may run on both cores, is done)."""
        if self._pending is None:
            rng, size = self._rng, self._block
            self._pending = _submit(
                self._thread, lambda: rng.standard_normal(size, dtype=np.float32)
            )
