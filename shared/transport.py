"""The one place outside node modules that talks to Zenoh: sessions and typed endpoints.

:func:`open_session` builds a session (client, peer or router) from a
:class:`~shared.config.TransportConfig`. :class:`Bus` wraps it with typed publish,
subscribe, query and liveliness helpers that encode/decode wheelnav messages. A
malformed payload never reaches a callback: the bus logs one line naming the key and
the fault, counts it in :attr:`Bus.bad_messages`, and carries on. An exception raised in
a callback is logged and counted the same way; the subscriber keeps running. Every sample
and query received is counted in :attr:`Bus.messages_in`; both counters are kept per key
expression as declared (a subscription to ``.../door/*/state`` counts every door's under
that pattern) and :meth:`Bus.counters` reads them at once (the service publishes them as
``Diagnostics``).

A session is secured (mutual TLS, user/password, the router's access control) when
``transport.security.dir`` names a credentials folder (shared/credentials.py,
docs/security.md); it joins as an identity: a service as its own name.

Ordering: zenoh-python runs each subscriber's callbacks on a thread of its own, which
loses the order in which samples of different keys arrived (a pose published before a
clock tick could be handled after it). The bus therefore only enqueues on Zenoh's
network thread and delivers everything (samples, queries, replies, liveliness changes)
from one :class:`Dispatcher` thread, in arrival order, holding :attr:`Bus.lock`. The
in-process fleet's buses share one dispatcher, so its deliveries keep one order too. Lockstep
determinism rests on this, and on publishing with congestion control BLOCK: with zenoh's
default (DROP) a router whose queue to a busy subscriber is full drops samples silently.
"""

from __future__ import annotations

import contextlib
import json
import logging
import queue
import threading
import time
from collections import Counter
from collections.abc import Callable, Iterator
from typing import Any, NamedTuple, TypeVar

import zenoh

from shared.codec import DecodeError, checked, clone, decode, encode
from shared.config import ConfigError, TransportConfig
from shared.credentials import read_settings, secure_endpoint
from shared.messages import Msg

Session = zenoh.Session  # for modules that pass a session on without importing zenoh
T = TypeVar("T", bound=Msg)
R = TypeVar("R", bound=Msg)
log = logging.getLogger("wheelnav.transport")


def zenoh_config(
    transport: TransportConfig, identity: str = "", access_control: dict | None = None
) -> zenoh.Config:
    """A Zenoh config for ``transport``: mode, endpoints, no multicast scouting (loopback-safe).

    A router connects too when ``transport.connect`` names other routers (another host's:
    Zenoh keeps the link up and makes it again after a cut). With
    ``transport.security.dir`` set, the session is secured as ``identity`` (mutual TLS,
    user/password; endpoints move to ``tls/``; a router that connects authenticates as
    ``identity`` too) and a router enforces ``access_control``. ConfigError with one line
    for missing credentials.
    """
    secured = bool(transport.security.dir)
    if secured and transport.mode == "peer":
        raise ConfigError("transport.security: a secured session is a client or the router")
    move = secure_endpoint if secured else str
    conf = zenoh.Config()
    conf.insert_json5("mode", json.dumps(transport.mode))
    if transport.connect:
        conf.insert_json5("connect/endpoints", json.dumps([move(e) for e in transport.connect]))
    if transport.listen or transport.mode == "router":
        conf.insert_json5("listen/endpoints", json.dumps([move(e) for e in transport.listen]))
    conf.insert_json5("scouting/multicast/enabled", "false")
    if secured:
        router = transport.mode == "router"
        links = router and bool(transport.connect)
        settings = read_settings(transport.security.dir, identity, router, links)
        for path, value in settings.items():
            conf.insert_json5(path, json.dumps(value))
    if access_control is not None:
        conf.insert_json5("access_control", json.dumps(access_control))
    return conf


def open_session(
    transport: TransportConfig, identity: str = "", access_control: dict | None = None
) -> zenoh.Session:
    """Open a Zenoh session; raises RuntimeError with one line if the router is unreachable
    or refuses it (a secured router refuses wrong credentials the same way)."""
    conf = zenoh_config(transport, identity, access_control)
    try:
        return zenoh.open(conf)
    except zenoh.ZError as exc:
        move = secure_endpoint if transport.security.dir else str
        where = ", ".join(map(move, transport.connect or transport.listen)) or "default endpoints"
        reason = str(exc).split("  at ")[0].strip()  # drop zenoh's source location
        if transport.security.dir and transport.mode != "router":
            reason += f" (as {identity!r}: unreachable, or refused for these credentials)"
        raise RuntimeError(
            f"cannot open a Zenoh {transport.mode} session ({where}): {reason}"
        ) from None


def open_local_session() -> zenoh.Session:
    """A Zenoh session that neither listens nor connects: the in-process fleet's one
    session, which every service's :class:`Bus` shares (wheelnav/launcher/in_process.py).
    Zenoh routes within a session, so nothing leaves the process."""
    conf = zenoh.Config()
    conf.insert_json5("mode", json.dumps("peer"))
    conf.insert_json5("listen/endpoints", "[]")
    conf.insert_json5("connect/endpoints", "[]")
    conf.insert_json5("scouting/multicast/enabled", "false")
    return zenoh.open(conf)


class LocalExchange:
    """Typed messages between the buses of one process's fleet, handed over as objects.

    The in-process fleet (wheelnav/launcher/in_process.py) runs every service on one
    Zenoh session that neither listens nor connects: each message went from object to
    msgpack bytes and back once per subscriber, with its checks each way, for a receiver
    in the same process (the codec was about 0.55 ms of a 3.3 ms tick in ``wheelnav
    bench fleet``). Through an exchange a publish checks the message once, as
    :func:`~shared.codec.encode` would (a bad one raises EncodeError in the publisher,
    as before), and gives each matching subscription its own
    :func:`~shared.codec.clone` at once, in subscription order: what a subscriber gets
    equals what decoding the bytes would have given it, and nothing it holds is shared.
    Subscriptions match by Zenoh's key-expression rules. The buses still declare their
    Zenoh subscriptions, so a payload put on the session by anything else (a tool, a
    test) arrives as bytes, checked as before.
    """

    def __init__(self) -> None:
        self._subscriptions: list[tuple[zenoh.KeyExpr, LocalDelivery]] = []
        self._routes: dict[str, tuple[LocalDelivery, ...]] = {}  # published key -> takers
        self._lock = threading.Lock()

    def subscribe(self, key_expr: str, deliver: LocalDelivery) -> Callable[[], None]:
        """Hand every message published on a key matching ``key_expr`` to ``deliver``;
        the function returned ends the subscription."""
        entry = (zenoh.KeyExpr(key_expr), deliver)
        with self._lock:
            self._subscriptions.append(entry)
            self._routes.clear()

        def undeclare() -> None:
            with self._lock:
                if entry in self._subscriptions:
                    self._subscriptions.remove(entry)
                    self._routes.clear()

        return undeclare

    def publish(self, key: str, msg: Msg) -> None:
        """Check ``msg`` (EncodeError naming the bad field) and hand a copy of it to each
        subscription matching ``key``."""
        good = checked(msg)
        for deliver in self._route(key):
            deliver(key, clone(good))

    def _route(self, key: str) -> tuple[LocalDelivery, ...]:
        with self._lock:
            route = self._routes.get(key)
            if route is None:
                published = zenoh.KeyExpr(key)
                route = tuple(d for e, d in self._subscriptions if e.intersects(published))
                self._routes[key] = route
            return route


LocalDelivery = Callable[[str, Msg], None]
"""A subscription's hand-over: ``deliver(published key, its own copy of the message)``."""


FLEET_DISPATCHER = "fleet-deliveries"  # the name of the in-process fleet's one dispatcher
PUMP_POLL_S = 0.05  # how often a pump with nothing to deliver looks at its condition again


class _Park(NamedTuple):
    """The item that parks a dispatcher's thread while it is lent (see Dispatcher.lent)."""

    parked: threading.Event
    resume: threading.Event


class Dispatcher:
    """One thread that delivers the items of one or more buses in arrival order, each
    under its bus's :attr:`Bus.lock`.

    A bus of its own process has its own. The in-process fleet's buses share one
    (:class:`~shared.service.Hosting`): with a thread per bus, every message woke another
    thread that then fought the others for the interpreter lock (about 60 thread
    switches a tick in the demo); one thread takes them in turn. Its handlers must
    never block waiting for another bus's delivery (none does: requests are
    asynchronous, :meth:`Bus.call` is not for handlers).
    """

    def __init__(self, name: str) -> None:
        self._inbox: queue.SimpleQueue = queue.SimpleQueue()
        self._held: list[tuple] | None = None
        self._held_lock = threading.Lock()
        self._lent_to: threading.Thread | None = None  # the thread that delivers meanwhile
        self._closed = False  # close() was asked for while lent: end once taken back
        self.thread = threading.Thread(target=self._run, name=name, daemon=True)
        self.thread.start()

    def put(self, bus: Bus, fn: Callable[..., None], args: tuple) -> None:
        """Queue ``fn(*args)`` for delivery under ``bus``'s lock."""
        with self._held_lock:
            if self._held is not None:
                self._held.append((bus, fn, args))
                return
        self._inbox.put((bus, fn, args))

    @contextlib.contextmanager
    def deferred(self) -> Iterator[None]:
        """Hand over what arrives meanwhile at the end, in order, with one wake-up.

        For a burst of publishing (the simulator's tick): each message would wake the
        dispatcher, which then took the interpreter lock from the publisher between two
        puts, a thread switch each way per message.
        """
        with self._held_lock:
            outer = self._held is not None
            if not outer:
                self._held = []
        if outer:  # already deferred (nested, or another thread): that one hands over
            yield
            return
        try:
            yield
        finally:
            with self._held_lock:
                held, self._held = self._held, None
                for job in held:
                    self._inbox.put(job)

    @contextlib.contextmanager
    def lent(self) -> Iterator[None]:
        """Deliver on the calling thread, in :meth:`pump`, until the block ends.

        For the lockstep simulator, which only waits between its steps: with the
        dispatcher's own thread delivering, every stage cost two hand-overs of the
        interpreter lock (the announcement woke the dispatcher, the last answer woke the
        simulator), about a tenth of a tick in the in-process demo. The dispatcher's
        thread first delivers what is queued before, then parks until the block ends;
        the order of deliveries is the queue's, as before. Meanwhile nothing is delivered
        outside :meth:`pump`.
        """
        if threading.current_thread() is self.thread or self._lent_to is not None:
            raise RuntimeError("a dispatcher is lent to one thread at a time, never its own")
        parked, resume = threading.Event(), threading.Event()
        self._inbox.put(_Park(parked, resume))
        while not parked.wait(0.1):
            if not self.thread.is_alive():
                raise RuntimeError("the dispatcher's thread has ended")
        self._lent_to = threading.current_thread()
        try:
            yield
        finally:
            self._lent_to = None
            resume.set()

    def pump(self, done: Callable[[], bool], timeout_s: float) -> bool:
        """Deliver queued items on this thread (inside :meth:`lent`) until ``done()``;
        False if ``timeout_s`` passes first."""
        if self._lent_to is not threading.current_thread():
            raise RuntimeError("pump only inside lent(), on the thread it was lent to")
        deadline = time.monotonic() + timeout_s
        while not done():
            left = deadline - time.monotonic()
            if left <= 0:
                return False
            if self._closed:  # closing: nothing more is delivered
                time.sleep(min(left, PUMP_POLL_S))
                continue
            try:
                job = self._inbox.get_nowait()  # most often one is queued: no timed wait
            except queue.Empty:
                try:
                    job = self._inbox.get(timeout=min(left, PUMP_POLL_S))
                except queue.Empty:
                    continue
            if job is None:
                self._closed = True
                continue
            self._deliver(job)
        return True

    def _run(self) -> None:
        while True:
            job = self._inbox.get()
            if job is None:
                return
            if isinstance(job, _Park):
                job.parked.set()
                job.resume.wait()
                if self._closed:
                    return
                continue
            self._deliver(job)

    @staticmethod
    def _deliver(job: tuple) -> None:
        bus, fn, args = job
        if bus._closing:
            return  # shutting down: what is still queued is not delivered
        try:
            with bus.lock:
                fn(*args)
        except Exception as exc:  # a handler bug must not stop delivery
            bus._count_bad(bus.name, f"handler failed: {type(exc).__name__}: {exc}")
            log.debug("handler traceback", exc_info=True)

    def close(self) -> None:
        """Stop the thread once what is queued before is delivered (or skipped)."""
        self._inbox.put(None)
        if threading.current_thread() is not self.thread and self._lent_to is None:
            self.thread.join(timeout=2.0)  # lent: its thread ends once taken back


class Bus:
    """Typed wheelnav endpoints over one Zenoh session, delivered in arrival order.

    ``owns_session``: :meth:`close` closes the session too. A bus on a session others
    share (the in-process fleet's) undeclares only its own endpoints. ``dispatcher``: the
    thread that delivers (shared by the in-process fleet's buses); by default its own.
    ``exchange``: the in-process fleet's buses publish to each other through it, as
    checked objects instead of bytes (:class:`LocalExchange`); nothing they publish
    then leaves through Zenoh, whose session there reaches no other process anyway.
    """

    def __init__(
        self,
        session: zenoh.Session,
        name: str,
        owns_session: bool = True,
        dispatcher: Dispatcher | None = None,
        exchange: LocalExchange | None = None,
    ) -> None:
        self.session = session
        self.name = name
        self.owns_session = owns_session
        self.lock = threading.RLock()
        self.bad_messages: Counter[str] = Counter()  # per declared key (see counters)
        self.messages_in: Counter[str] = Counter()
        self._publishers: dict[str, zenoh.Publisher] = {}
        self._keep: list[Any] = []
        self.exchange = exchange  # public: the in-process fleet's services share their host's
        self._local: list[Callable[[], None]] = []  # the exchange's subscriptions, to end
        self._count_lock = threading.Lock()
        self._closing = False
        self._owns_dispatcher = dispatcher is None
        # public: the in-process fleet's services deliver on their host's bus's dispatcher
        self.dispatcher = dispatcher or Dispatcher(f"{name}-bus")

    # -- delivery -------------------------------------------------------------------------

    def _handler(
        self, deliver: Callable[[Any], None], on_drop: Callable[[], None] | None = None
    ) -> zenoh.handlers.Callback:
        """A Zenoh callback that only queues the item (on the network thread, in order)."""
        put = self.dispatcher.put
        drop = (lambda: put(self, on_drop, ())) if on_drop else None
        return zenoh.handlers.Callback(
            lambda item: put(self, deliver, (item,)), drop, indirect=False
        )

    def _latest(self, call: Callable[[Any], None]) -> Callable[[Any], None]:
        """``arrive(msg)`` for each good message as it arrives: queued in arrival order,
        as :meth:`_handler` does, but ``call`` takes one only if no newer one has arrived
        by then: a subscriber that falls behind takes up the newest, in its place in the
        order, never a backlog (see :meth:`subscribe`)."""
        lock = threading.Lock()
        newest = [0]  # the number of the latest good arrival

        def take(number: int, msg: Any) -> None:
            with lock:
                superseded = number != newest[0]
            if not superseded:
                call(msg)

        def arrive(msg: Any) -> None:
            with lock:
                newest[0] += 1
                number = newest[0]
            self.dispatcher.put(self, take, (number, msg))

        return arrive

    # -- publish / subscribe ------------------------------------------------------------

    def publish(self, key: str, msg: Msg) -> None:
        """Encode and put ``msg`` on ``key`` (the publisher is declared once, on first use);
        with an exchange, hand it to the exchange's subscribers instead."""
        if self.exchange is not None:
            self.exchange.publish(key, msg)
            return
        pub = self._publishers.get(key)
        if pub is None:
            # BLOCK, not zenoh's default DROP: a put that meets a full queue (a router
            # forwarding 300 kB scans to a busy subscriber) waits instead of vanishing.
            # A dropped scan or pose made lockstep runs differ under load.
            pub = self.session.declare_publisher(
                key, congestion_control=zenoh.CongestionControl.BLOCK
            )
            self._publishers[key] = pub
        pub.put(encode(msg))

    def subscribe(
        self,
        key: str,
        msg_type: type[T] | None,
        callback: Callable[[T], None],
        latest: bool = False,
    ) -> None:
        """Call ``callback(msg)`` per valid message on ``key`` (any type if ``msg_type`` None).

        With ``latest`` a message is skipped when a newer valid one has arrived before it
        is delivered (one key per subscription: a wildcard would mix keys); what is
        delivered keeps its place in the arrival order. For the tick announcements: in lockstep the
        simulator waits for a participant's answer to a tick it is due at, so only ticks
        it would ignore are skipped; free running, a participant the machine cannot keep
        up with steps on the newest tick instead of working through a backlog whose stamps
        fall ever further behind (under a loaded CI run the navigator judged the
        controller silent for 60 s and failed the demo)."""

        def valid(sample: zenoh.Sample) -> Any | None:
            """The sample's message, or None (counted as bad when it does not decode)."""
            if sample.kind != zenoh.SampleKind.PUT:
                return None
            self._count_in(key)
            try:
                return decode(sample.payload.to_bytes(), msg_type)
            except DecodeError as exc:
                self._count_bad(key, str(exc), str(sample.key_expr))
                return None

        def call(msg: Any) -> None:
            try:
                callback(msg)
            except Exception as exc:  # a bad message must not kill the subscriber
                self._count_bad(key, f"handler failed: {type(exc).__name__}: {exc}")
                log.debug("handler traceback", exc_info=True)

        def deliver(sample: zenoh.Sample) -> None:
            msg = valid(sample)
            if msg is not None:
                call(msg)

        def from_exchange(published: str, msg: Msg) -> Msg | None:
            """A message from the exchange (checked by its publisher), or None if it is
            not of ``msg_type`` (counted as decoding its bytes would have counted it)."""
            self._count_in(key)
            if msg_type is not None and type(msg) is not msg_type:
                self._count_bad(key, f"expected {msg_type.TAG}, got {msg.TAG}", published)
                return None
            return msg

        if latest:  # checked as it arrives, so a bad message never skips a good one
            arrive = self._latest(call)

            def arrive_sample(sample: zenoh.Sample) -> None:
                msg = valid(sample)
                if msg is not None:
                    arrive(msg)

            def arrive_local(published: str, msg: Msg) -> None:
                good = from_exchange(published, msg)
                if good is not None:
                    arrive(good)

            handler = zenoh.handlers.Callback(arrive_sample, None, indirect=False)
            local = arrive_local
        else:

            def deliver_local(published: str, msg: Msg) -> None:
                good = from_exchange(published, msg)
                if good is not None:
                    call(good)

            handler = self._handler(deliver)

            def local(published: str, msg: Msg) -> None:
                self.dispatcher.put(self, deliver_local, (published, msg))

        self._keep.append(self.session.declare_subscriber(key, handler))
        if self.exchange is not None:
            self._local.append(self.exchange.subscribe(key, local))

    def subscribe_raw(self, key: str, callback: Callable[[str, bytes], None]) -> None:
        """Call ``callback(key, payload)`` for every sample (tools that show any topic)."""

        def deliver(sample: zenoh.Sample) -> None:
            if sample.kind == zenoh.SampleKind.PUT:
                callback(str(sample.key_expr), sample.payload.to_bytes())

        def local(published: str, msg: Msg) -> None:  # as the bytes it would have been
            self.dispatcher.put(self, callback, (published, encode(msg)))

        self._keep.append(self.session.declare_subscriber(key, self._handler(deliver)))
        if self.exchange is not None:
            self._local.append(self.exchange.subscribe(key, local))

    def _count_in(self, key: str) -> None:
        with self._count_lock:
            self.messages_in[key] += 1

    def _count_bad(self, key: str, why: str, topic: str | None = None) -> None:
        """Count a bad message under the declared ``key``; the log names the ``topic`` it
        came on (the first 10 per key, then every 100th)."""
        with self._count_lock:
            self.bad_messages[key] += 1
            n = self.bad_messages[key]
        if n <= 10 or n % 100 == 0:
            log.warning(
                "%s: dropped bad message on %s (%d so far): %s", self.name, topic or key, n, why
            )

    def counters(self) -> dict[str, tuple[int, int]]:
        """``{key: (messages in, bad messages)}`` for every key that has received anything
        (taken at once, so the totals agree)."""
        with self._count_lock:
            keys = sorted(set(self.messages_in) | set(self.bad_messages))
            return {k: (self.messages_in[k], self.bad_messages[k]) for k in keys}

    # -- request / response -------------------------------------------------------------

    def serve(self, key: str, req_type: type[T], handler: Callable[[T], Msg]) -> None:
        """Answer queries on ``key``: decode the request, reply with ``handler(request)``.

        A malformed request is answered with an error reply naming the fault. Queries are
        answered on Zenoh's own callback thread (a query cannot be answered once the
        network thread's callback has returned), holding :attr:`lock`.
        """

        def answer(query: zenoh.Query) -> None:
            with self.lock:
                deliver(query)

        def deliver(query: zenoh.Query) -> None:
            self._count_in(key)
            try:
                payload = query.payload.to_bytes() if query.payload is not None else b""
                request = decode(payload, req_type)
            except DecodeError as exc:
                self._count_bad(key, str(exc))
                query.reply_err(str(exc).encode())
                return
            try:
                reply = handler(request)
            except Exception as exc:
                self._count_bad(key, f"handler failed: {type(exc).__name__}: {exc}")
                query.reply_err(f"{type(exc).__name__}: {exc}".encode())
                return
            query.reply(key, encode(reply))

        self._keep.append(self.session.declare_queryable(key, answer, complete=True))

    def request(
        self,
        key: str,
        msg: Msg,
        reply_type: type[R],
        timeout_s: float,
        on_done: Callable[[R | None, str], None],
    ) -> None:
        """Send a query without blocking; ``on_done(reply, error)`` is called exactly once,
        from the dispatcher (so in order with the samples around it).

        ``error`` is empty on success; on timeout, no responder or a bad reply, ``reply`` is
        None and ``error`` says why.
        """
        state = {"done": False}

        def finish(reply: R | None, error: str) -> None:
            if not state["done"]:
                state["done"] = True
                on_done(reply, error)

        def on_reply(reply: zenoh.Reply) -> None:
            if reply.ok is None:
                finish(None, f"{key} answered an error: {reply.err.payload.to_string()}")
                return
            try:
                answer = decode(reply.ok.payload.to_bytes(), reply_type)
            except DecodeError as exc:
                finish(None, f"bad reply from {key}: {exc}")
                return
            finish(answer, "")

        def on_end() -> None:
            finish(None, f"no answer from {key} within {timeout_s:.1f} s")

        self.session.get(
            key, self._handler(on_reply, on_end), payload=encode(msg), timeout=timeout_s
        )

    def call(self, key: str, msg: Msg, reply_type: type[R], timeout_s: float) -> R:
        """Blocking query; raises TimeoutError with one line on failure.

        Never call it from a bus callback: the answer is delivered by the same dispatcher.
        """
        done = threading.Event()
        result: dict[str, Any] = {}

        def on_done(reply: R | None, error: str) -> None:
            result.update(reply=reply, error=error)
            done.set()

        self.request(key, msg, reply_type, timeout_s, on_done)
        if not done.wait(timeout_s + 1.0) or result["reply"] is None:
            raise TimeoutError(result.get("error") or f"no answer from {key}")
        return result["reply"]

    # -- liveliness ---------------------------------------------------------------------

    def declare_alive(self, key: str) -> None:
        """Hold a liveliness token on ``key`` for as long as the session lives."""
        self._keep.append(self.session.liveliness().declare_token(key))

    def watch_alive(self, pattern: str, callback: Callable[[str, bool], None]) -> None:
        """Call ``callback(key, alive)`` when a token on ``pattern`` appears or goes (and for
        the tokens already there)."""

        def deliver(sample: zenoh.Sample) -> None:
            callback(str(sample.key_expr), sample.kind == zenoh.SampleKind.PUT)

        self._keep.append(
            self.session.liveliness().declare_subscriber(
                pattern, self._handler(deliver), history=True
            )
        )

    def alive(self, pattern: str, timeout_s: float = 1.0) -> list[str]:
        """The keys of the liveliness tokens matching ``pattern`` now."""
        replies = self.session.liveliness().get(pattern, timeout=timeout_s)
        return sorted(str(r.ok.key_expr) for r in replies if r.ok is not None)

    def close(self) -> None:
        """Undeclare everything, close the session and stop the dispatcher."""
        self._closing = True
        with self.lock:  # let a callback that is running finish first
            pass
        for undeclare in self._local:
            undeclare()
        self._local.clear()
        if not self.owns_session:
            for endpoint in [*self._keep, *self._publishers.values()]:
                endpoint.undeclare()
        self._keep.clear()
        self._publishers.clear()
        if self.owns_session:
            self.session.close()
        if self._owns_dispatcher:
            self.dispatcher.close()
