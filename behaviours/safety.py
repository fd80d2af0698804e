"""The safety branch: while the chair is unsafe, nothing below it runs.

The controller already zeroes its command when its pose is stale or lost, no scan has
arrived, something stands in the stop zone, or every trajectory collides; it says so in
its FollowStatus. A controller that has gone silent is unsafe too (the base's watchdog
stops the chair, but nothing should be asked of it). The gate turns that into mission
logic: it stops ticking the mission (pre-empting every phase, without resetting its
progress, so the chair carries on where it was when the cause clears), reports when a
stop starts and ends, and fails the mission if one lasts longer than its timeout. A hold
that moving might clear (an obstacle, boxed in) hands over to the navigator's recoveries
after ``recover_after_s`` instead (behaviours/recovery.py), or sooner to a step that has
a way round of its own (``quits_when_held``: a smooth door pass hands the door to
stop-turn-go). Phase
limits count the time under a hold: one that runs out while the gate holds ends its
phase there and then, as it would have with the chair moving.

The :class:`PauseGate` above a whole mission tree is the other kind of hold: the
operator's emergency stop or the rider taking the joystick. It lasts until it is cleared
(no timeout, no recovery: nothing the mission could do would end it), and its time does
not count against any limit.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator

import py_trees
from py_trees.common import Status

from behaviours.timeouts import Timeout

# "estop": the controller holds an emergency stop (the navigator's own PauseGate holds
# the mission above this gate while it knows of one)
UNSAFE = ("stale_pose", "stale_scan", "obstacle", "blocked", "stale", "estop")
RECOVERABLE = ("obstacle", "blocked")  # moving may clear these; stale inputs it cannot


class SafetyGate(py_trees.decorators.Decorator):
    """Ticks its child only while the chair is safe; holds (RUNNING) while it is not.

    FAILURE, with ``on_timeout(reason)`` called, when one unsafe spell lasts longer than
    ``timeout_s`` of fleet time (a spell ends after ``clear_s`` without a cause, so a
    person walking out of the stop zone makes one spell, not several). Needs
    ``setup(fleet=...)`` (a :class:`behaviours.fleet.Fleet`); ``silent_s`` is how old the
    controller's last status may be.
    """

    def __init__(
        self,
        name: str,
        child: py_trees.behaviour.Behaviour,
        clock: Callable[[], float],
        timeout_s: float,
        on_timeout: Callable[[str], None],
        silent_s: float = 1.0,
        clear_s: float = 0.5,
        recover_after_s: float | None = None,
        on_recover: Callable[[str], None] | None = None,
    ) -> None:
        super().__init__(name=name, child=child)
        self.recover_after_s = recover_after_s
        self.on_recover = on_recover
        self.clock = clock
        self.timeout_s = timeout_s
        self.on_timeout = on_timeout
        self.silent_s = silent_s
        self.clear_s = clear_s
        self.fleet = None
        self.since: float | None = None
        self.clear_since: float | None = None
        self.cause = ""

    def setup(self, **kwargs) -> None:
        self.fleet = kwargs["fleet"]

    def discount_hold(self, held_s: float) -> None:
        """The whole mission was held ``held_s`` seconds (a :class:`PauseGate`): a spell
        under way does not count that time."""
        if self.since is not None:
            self.since += held_s
        if self.clear_since is not None:
            self.clear_since += held_s

    def unsafe(self) -> str:
        """Why the chair is unsafe now, or "" if it is not."""
        status = self.fleet.follow_status()
        if status is None:
            return ""  # nothing sent yet: the first path will tell
        if status.state in UNSAFE:
            return status.state
        if self.clock() - status.stamp > self.silent_s:
            return "controller_silent"
        return ""

    def tick(self) -> Iterator[py_trees.behaviour.Behaviour]:
        cause = self.unsafe()
        now = self.clock()
        if not cause:
            if self.since is not None:  # one spell ends once it has stayed clear a while
                self.clear_since = now if self.clear_since is None else self.clear_since
                if now - self.clear_since >= self.clear_s:
                    held = self.clear_since - self.since
                    self.fleet.event("safety_clear", f"{self.cause} cleared after {held:.1f} s")
                    self.since, self.clear_since, self.cause = None, None, ""
            yield from super().tick()
            return
        self.clear_since = None
        if self.since is None:
            self.since, self.cause = now, cause
            self.fleet.event("safety_stop", cause)
        expired = self.expired_limit(now)
        if expired is not None:  # a phase limit ran out under the hold: it ends its phase
            self.fleet.event("safety_stop", f"{cause}: {expired.name} limit reached while held")
            yield from super().tick()
            return
        quitter = self.quitting(cause, now - self.since)
        if quitter is not None:  # a step with a way round the hold of its own takes it
            self.fleet.event("safety_stop", f"{cause}: {quitter.name} gives up while held")
            self.since, self.clear_since, self.cause = None, None, ""
            yield from super().tick()
            return
        if self.status != Status.RUNNING:
            self.initialise()
        held = now - self.since
        recover = (
            self.recover_after_s is not None
            and self.on_recover is not None
            and cause in RECOVERABLE
            and held >= self.recover_after_s
        )
        if recover:  # hand over to the navigator's recoveries
            self.feedback_message = f"held: {cause} for {held:.1f} s, recovering"
            self.fleet.stop()
            self.on_recover(cause)
            self.since, self.clear_since, self.cause = None, None, ""
            self.stop(Status.FAILURE)
            self.status = Status.FAILURE
        elif held > self.timeout_s:
            reason = f"safety stop ({cause}) for more than {self.timeout_s:g} s"
            self.feedback_message = reason
            self.fleet.stop()
            self.on_timeout(reason)
            self.stop(Status.FAILURE)
            self.status = Status.FAILURE
        else:
            self.feedback_message = f"holding: {cause} for {held:.1f} s"
            self.status = Status.RUNNING
        yield self

    def quitting(self, cause: str, held_s: float) -> py_trees.behaviour.Behaviour | None:
        """A running step below the gate that gives up under this hold (it has a
        ``quits_when_held(cause, held_s)`` saying so): it is ticked to fail, so the
        fallback beside it takes over instead of the navigator's recoveries."""
        for b in self.decorated.iterate():
            quits = getattr(b, "quits_when_held", None)
            if b.status == Status.RUNNING and quits is not None and quits(cause, held_s):
                return b
        return None

    def expired_limit(self, now: float) -> Timeout | None:
        """A running phase limit below the gate whose time is up (hold time counts)."""
        for b in self.decorated.iterate():
            if isinstance(b, Timeout) and b.status == Status.RUNNING and b.expired(now):
                return b
        return None

    def update(self) -> Status:
        self.feedback_message = ""
        return self.decorated.status


class PauseGate(py_trees.decorators.Decorator):
    """Holds a whole mission tree (RUNNING, its child not ticked) while ``reason()`` says
    why: the emergency stop, the rider's pause (services/navigator/holds.py).

    When a hold starts it stops the chair (the controller drops its path) and reports it
    (event ``hold``); its feedback is the reason. When it ends, the time held is taken
    off every phase limit and safety spell under way below (``discount_hold``), and every
    behaviour that was running starts again (its ``initialise`` sends its path again, from
    where the chair now stands), so the mission goes on where it was (event ``hold_over``).
    Needs ``setup(fleet=...)``.
    """

    def __init__(
        self,
        name: str,
        child: py_trees.behaviour.Behaviour,
        reason: Callable[[], str],
        clock: Callable[[], float],
    ) -> None:
        super().__init__(name=name, child=child)
        self.reason = reason
        self.clock = clock
        self.fleet = None
        self.since: float | None = None
        self.why = ""

    def setup(self, **kwargs) -> None:
        self.fleet = kwargs["fleet"]

    @property
    def holding(self) -> bool:
        return self.since is not None

    def tick(self) -> Iterator[py_trees.behaviour.Behaviour]:
        why = self.reason()
        now = self.clock()
        if not why:
            if self.since is not None:
                self._resume(now)
            yield from super().tick()
            return
        if self.since is None:
            self.since = now
            self.fleet.stop()
            self.fleet.event("hold", why)
        self.why = why
        if self.status != Status.RUNNING:
            self.initialise()
        self.feedback_message = why
        self.status = Status.RUNNING
        yield self

    def _resume(self, now: float) -> None:
        held = now - self.since
        self.since = None
        below = list(self.decorated.iterate())
        for b in below:
            discount = getattr(b, "discount_hold", None)
            if discount is not None and b.status == Status.RUNNING:
                discount(held)
        again = [b for b in below if b.status == Status.RUNNING and not b.children]
        for b in again:
            b.stop(Status.INVALID)  # the next tick initialises it afresh
        steps = ", ".join(b.name for b in again) or "nothing was running"
        self.fleet.event("hold_over", f"after {held:.1f} s ({self.why}): {steps} again")
        self.why = ""

    def update(self) -> Status:
        self.feedback_message = ""
        return self.decorated.status
