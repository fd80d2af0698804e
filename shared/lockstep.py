"""Lockstep simulation time: the barrier the simulator waits on, and the participant side.

After every step the simulator announces the tick stage by stage. Stage ``k``'s
participants (``sim.lockstep_stages[k]``) do their work for the tick and answer with an
:class:`~shared.messages.Ack` naming the next tick they will answer; only then is stage
``k + 1`` announced, and only after the last stage does the simulator step again. The
stages order the fleet's data flow inside one tick (pose, then control, then mission
logic), so results do not depend on machine load and runs go faster than real time
when the machine allows. Each wait is bounded by a wall-clock timeout. A participant
whose liveliness token goes away (a crashed process) is not waited for; the
simulator's command watchdog then stops the chair.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence

from shared.messages import Ack, Clock, LockstepProfile


class Barrier:
    """Which participants the simulator still waits for at a tick and stage (bookkeeping)."""

    def __init__(self, stages: Sequence[Sequence[str]]) -> None:
        self.stage_of = {name: i for i, names in enumerate(stages) for name in names}
        self.n_stages = max(1, len(stages))
        self.alive: set[str] = set()
        self.next_tick: dict[str, int] = {}

    def set_alive(self, name: str, alive: bool) -> None:
        """Record a participant's liveliness; a newly seen one is due at once."""
        if name not in self.stage_of:
            return
        if alive:
            self.alive.add(name)
        else:
            self.alive.discard(name)
            self.next_tick.pop(name, None)

    def ack(self, msg: Ack) -> None:
        """Record an answer: ``msg.participant`` is next due at ``msg.next_tick``."""
        if msg.participant in self.stage_of:
            self.next_tick[msg.participant] = max(
                msg.next_tick, self.next_tick.get(msg.participant, 0)
            )

    def answered(self, tick: int, stage: int) -> bool:
        """Every live participant of ``stage`` has answered ``tick`` (``waiting_on`` is
        empty; asked after every delivery while the simulator waits, so no list)."""
        stage_of, next_tick = self.stage_of, self.next_tick
        return not any(stage_of[p] == stage and next_tick.get(p, 0) <= tick for p in self.alive)

    def waiting_on(self, tick: int, stage: int) -> list[str]:
        """Live participants of ``stage`` that have not yet answered ``tick``."""
        return sorted(
            p for p in self.alive if self.stage_of[p] == stage and self.next_tick.get(p, 0) <= tick
        )


class Participant:
    """The participant side: calls ``step(clock)`` at ``rate_hz`` of fleet time and acks.

    ``publish_ack`` sends an Ack (the node wires it to the bus). While :meth:`hold` is in
    force (an outstanding request whose answer must land in this tick), the ack is
    withheld until :meth:`release`; the simulator's timeout still bounds the wait.
    """

    def __init__(
        self,
        name: str,
        stage: int,
        rate_hz: float,
        step: Callable[[Clock], None],
        publish_ack: Callable[[Ack], None],
    ) -> None:
        self.name = name
        self.stage = stage
        self.rate_hz = rate_hz
        self._step = step
        self._publish_ack = publish_ack
        self._next_tick = 0
        self._holds = 0
        self._pending: Ack | None = None

    def on_clock(self, clock: Clock) -> None:
        """Handle one announcement: step if it is this stage's and due, then answer."""
        if clock.stage != self.stage:
            return
        period = max(1, math.floor(1.0 / (self.rate_hz * clock.dt) + 1e-9))
        not_due = self._next_tick - period <= clock.tick < self._next_tick
        if not_due:
            return
        started = time.perf_counter()
        self._step(clock)
        compute_s = time.perf_counter() - started
        self._next_tick = clock.tick + period
        ack = Ack(self.name, clock.tick, self._next_tick, compute_s)
        if self._holds:
            self._pending = ack
        else:
            self._publish_ack(ack)

    def hold(self) -> None:
        """Withhold acks until a matching :meth:`release` (e.g. while a route is computed)."""
        self._holds += 1

    def release(self) -> None:
        """End one hold; send the withheld ack when no hold remains."""
        self._holds = max(0, self._holds - 1)
        if not self._holds and self._pending is not None:
            ack, self._pending = self._pending, None
            self._publish_ack(ack)


class TickProfile:
    """Where the simulator's wall time goes, summed since the clock started.

    The simulator adds each part of a tick as it runs it; acks add their participant's
    compute time. :meth:`message` is the :class:`LockstepProfile` that ``wheelnav bench
    fleet`` prints.
    """

    def __init__(self, n_stages: int, dt: float) -> None:
        self.dt = dt
        self.ticks = 0
        self.physics_s = self.publish_s = self.pacing_s = 0.0
        self.stage_wait_s = [0.0] * n_stages
        self.compute_s: dict[str, float] = {}
        self.steps: dict[str, int] = {}
        self._started = time.perf_counter()

    def start(self) -> None:
        """The clock starts now (waiting for the fleet is not a tick's time)."""
        self._started = time.perf_counter()

    def ack(self, msg: Ack) -> None:
        """Count one answered step of ``msg.participant``."""
        self.compute_s[msg.participant] = self.compute_s.get(msg.participant, 0.0) + msg.compute_s
        self.steps[msg.participant] = self.steps.get(msg.participant, 0) + 1

    def message(self, stamp: float) -> LockstepProfile:
        names = sorted(self.compute_s)
        return LockstepProfile(
            stamp,
            self.dt,
            self.ticks,
            time.perf_counter() - self._started,
            self.physics_s,
            self.publish_s,
            self.pacing_s,
            list(self.stage_wait_s),
            names,
            [self.compute_s[n] for n in names],
            [self.steps[n] for n in names],
        )
