"""The emergency stop as each service that obeys it holds it: latched, and asked for at start.

``wheelnav stop`` puts an :class:`~shared.messages.EmergencyStop` (active) on ``estop``,
``wheelnav stop --clear`` one that is not. The command exits, so the stop lives in the
services that obey it (:data:`HOLDERS`): each keeps the last one it received and answers
for it on ``estop/state/<service>``. A holder that (re)starts asks every other holder and
is stopped if any of them is: a stop is not lost while one holder lives, whichever of them
restarts. Until every answer is in (or ``ASK_TIMEOUT_S`` has passed) it counts as stopped,
so a restarted controller never commands motion before it knows. Holders that disagree
(one missed a clear) settle towards stopping; ``wheelnav stop --clear`` again clears them.
A stop message that arrives outranks the answers (it is the operator's latest word).

:class:`EstopLatch` is the pure state; :func:`hold_estop` wires one to the bus.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterable

from shared.messages import EmergencyStop, EmergencyStopQuery
from shared.topics import Keys
from shared.transport import Bus

HOLDERS = ("controller", "driver", "sim", "navigator")  # the services that obey the stop
ASK_TIMEOUT_S = 1.0  # wall time a (re)starting holder waits for another's answer
NEVER = EmergencyStop(0.0, False, "", "never set")  # what a holder holds before any stop


class EstopLatch:
    """One holder's emergency stop: the last message, and the start-up answers still due."""

    def __init__(self, name: str, asking: Iterable[str] = ()) -> None:
        self.name = name
        self.stop = NEVER
        self.waiting = set(asking)  # holders whose answer to the start-up question is due
        self.heard = False  # a stop message arrived: it outranks the start-up answers

    @property
    def active(self) -> bool:
        """Stopped: the last stop set it, or the start-up answers are not all in."""
        return self.stop.active or bool(self.waiting)

    def reason(self) -> str:
        """The stop in words ("" when not stopped)."""
        if self.stop.active:
            by = f" by {self.stop.source}" if self.stop.source else ""
            why = f": {self.stop.reason}" if self.stop.reason else ""
            return f"emergency stop{by}{why}"
        if self.waiting:
            return "emergency stop state not known yet (asking the other services)"
        return ""

    def on_message(self, msg: EmergencyStop) -> None:
        """A stop was set or cleared."""
        self.stop, self.heard = msg, True

    def on_answer(self, holder: str, held: EmergencyStop | None) -> bool:
        """``holder`` answered the start-up question with the stop it holds (None: no
        answer); True if that answer stopped this holder."""
        self.waiting.discard(holder)
        if held is None or not held.active or self.heard or self.stop.active:
            return False
        self.stop = held
        return True


def hold_estop(
    bus: Bus,
    keys: Keys,
    name: str,
    log: logging.Logger,
    on_change: Callable[[EstopLatch], None] | None = None,
) -> EstopLatch:
    """A latch for holder ``name``: subscribed to ``estop``, answering on its
    ``estop/state`` key, and asking the other holders once. ``on_change(latch)`` (from the
    bus's dispatcher) when a stop is set or cleared, by a message or taken up from an
    answer; the start-up wait ending with nothing held is no change (read
    ``latch.active``, which covers the wait, where it matters)."""
    others = [h for h in HOLDERS if h != name]
    latch = EstopLatch(name, others)

    def changed(was: bool) -> None:
        if latch.stop.active != was and on_change is not None:
            on_change(latch)

    def on_stop(msg: EmergencyStop) -> None:
        was, again = latch.stop.active, msg == latch.stop  # wheelnav stop sends it again
        latch.on_message(msg)
        if not again:
            word = "set" if msg.active else "cleared"
            why = f": {msg.reason}" if msg.reason else ""
            log.warning("emergency stop %s by %s%s", word, msg.source or "?", why)
        changed(was)

    def answered(holder: str) -> Callable[[EmergencyStop | None, str], None]:
        def done(held: EmergencyStop | None, _error: str) -> None:
            was = latch.stop.active
            if latch.on_answer(holder, held):
                log.warning("%s holds an emergency stop: taken up (%s)", holder, latch.reason())
            changed(was)

        return done

    stop_key = keys.estop
    state_key = keys.key("estop_state", service=name)
    log.info("subscribes %s", stop_key)
    bus.subscribe(stop_key, EmergencyStop, on_stop)
    log.info("serves %s", state_key)
    bus.serve(state_key, EmergencyStopQuery, lambda _query: latch.stop)
    for holder in others:
        bus.request(
            keys.key("estop_state", service=holder),
            EmergencyStopQuery(name),
            EmergencyStop,
            ASK_TIMEOUT_S,
            answered(holder),
        )
    return latch
