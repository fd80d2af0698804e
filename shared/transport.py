"""The one place outside node modules that talks to Zenoh: sessions and typed endpoints.

:func:`open_session` builds a session (client, peer or router) from a
:class:`~shared.config.TransportConfig`. :class:`Bus` wraps it with typed publish,
subscribe, query and liveliness helpers that encode/decode wheelnav messages. A
malformed payload never reaches a callback: the bus logs one line naming the key and
the fault, counts it in :attr:`Bus.bad_messages`, and carries on. An exception raised in
a callback is logged and counted the same way; the subscriber keeps running.
"""

from __future__ import annotations

import json
import logging
import threading
from collections import Counter
from collections.abc import Callable
from typing import Any, TypeVar

import zenoh

from shared.codec import DecodeError, decode, encode
from shared.config import TransportConfig
from shared.messages import Msg

T = TypeVar("T", bound=Msg)
R = TypeVar("R", bound=Msg)
log = logging.getLogger("wheelnav.transport")


def zenoh_config(transport: TransportConfig) -> zenoh.Config:
    """A Zenoh config for ``transport``: mode, endpoints, no multicast scouting (loopback-safe)."""
    conf = zenoh.Config()
    conf.insert_json5("mode", json.dumps(transport.mode))
    if transport.connect and transport.mode != "router":
        conf.insert_json5("connect/endpoints", json.dumps(transport.connect))
    if transport.listen or transport.mode == "router":
        conf.insert_json5("listen/endpoints", json.dumps(transport.listen))
    conf.insert_json5("scouting/multicast/enabled", "false")
    return conf


def open_session(transport: TransportConfig) -> zenoh.Session:
    """Open a Zenoh session; raises RuntimeError with one line if the router is unreachable."""
    try:
        return zenoh.open(zenoh_config(transport))
    except zenoh.ZError as exc:
        where = ", ".join(transport.connect or transport.listen) or "default endpoints"
        raise RuntimeError(
            f"cannot open a Zenoh {transport.mode} session ({where}): {exc}"
        ) from None


class Bus:
    """Typed wheelnav endpoints over one Zenoh session."""

    def __init__(
        self, session: zenoh.Session, name: str, lock: threading.RLock | None = None
    ) -> None:
        self.session = session
        self.name = name
        self.lock = lock or threading.RLock()
        self.bad_messages: Counter[str] = Counter()
        self._publishers: dict[str, zenoh.Publisher] = {}
        self._keep: list[Any] = []
        self._lock = threading.Lock()

    # -- publish / subscribe ------------------------------------------------------------

    def publish(self, key: str, msg: Msg) -> None:
        """Encode and put ``msg`` on ``key`` (the publisher is declared once, on first use)."""
        pub = self._publishers.get(key)
        if pub is None:
            pub = self.session.declare_publisher(key)
            self._publishers[key] = pub
        pub.put(encode(msg))

    def subscribe(self, key: str, msg_type: type[T] | None, callback: Callable[[T], None]) -> None:
        """Call ``callback(msg)`` per valid message on ``key`` (any type if ``msg_type`` None)."""

        def on_sample(sample: zenoh.Sample) -> None:
            if sample.kind != zenoh.SampleKind.PUT:
                return
            topic = str(sample.key_expr)
            try:
                msg = decode(sample.payload.to_bytes(), msg_type)
            except DecodeError as exc:
                self._count_bad(topic, str(exc))
                return
            try:
                with self.lock:
                    callback(msg)
            except Exception as exc:  # a bad message must not kill the subscriber
                self._count_bad(topic, f"handler failed: {type(exc).__name__}: {exc}")
                log.debug("handler traceback", exc_info=True)

        self._keep.append(self.session.declare_subscriber(key, on_sample))

    def subscribe_raw(self, key: str, callback: Callable[[str, bytes], None]) -> None:
        """Call ``callback(key, payload)`` for every sample (tools that show any topic)."""

        def on_sample(sample: zenoh.Sample) -> None:
            if sample.kind == zenoh.SampleKind.PUT:
                callback(str(sample.key_expr), sample.payload.to_bytes())

        self._keep.append(self.session.declare_subscriber(key, on_sample))

    def _count_bad(self, topic: str, why: str) -> None:
        with self._lock:
            self.bad_messages[topic] += 1
            n = self.bad_messages[topic]
        if n <= 10 or n % 100 == 0:
            log.warning("%s: dropped bad message on %s (%d so far): %s", self.name, topic, n, why)

    # -- request / response -------------------------------------------------------------

    def serve(self, key: str, req_type: type[T], handler: Callable[[T], Msg]) -> None:
        """Answer queries on ``key``: decode the request, reply with ``handler(request)``.

        A malformed request is answered with an error reply naming the fault.
        """

        def on_query(query: zenoh.Query) -> None:
            try:
                payload = query.payload.to_bytes() if query.payload is not None else b""
                request = decode(payload, req_type)
            except DecodeError as exc:
                self._count_bad(key, str(exc))
                query.reply_err(str(exc).encode())
                return
            try:
                with self.lock:
                    reply = handler(request)
            except Exception as exc:
                self._count_bad(key, f"handler failed: {type(exc).__name__}: {exc}")
                query.reply_err(f"{type(exc).__name__}: {exc}".encode())
                return
            query.reply(key, encode(reply))

        self._keep.append(self.session.declare_queryable(key, on_query, complete=True))

    def request(
        self,
        key: str,
        msg: Msg,
        reply_type: type[R],
        timeout_s: float,
        on_done: Callable[[R | None, str], None],
        locked: bool = True,
    ) -> None:
        """Send a query without blocking; ``on_done(reply, error)`` is called exactly once.

        ``error`` is empty on success; on timeout, no responder or a bad reply, ``reply`` is
        None and ``error`` says why. ``on_done`` runs under the bus lock unless ``locked``
        is False.
        """
        state = {"done": False}
        lock = threading.Lock()

        def finish(reply: R | None, error: str) -> None:
            with lock:
                if state["done"]:
                    return
                state["done"] = True
            if locked:
                with self.lock:
                    on_done(reply, error)
            else:
                on_done(reply, error)

        def on_reply(reply: zenoh.Reply) -> None:
            if reply.ok is not None:
                try:
                    answer = decode(reply.ok.payload.to_bytes(), reply_type)
                except DecodeError as exc:
                    finish(None, f"bad reply from {key}: {exc}")
                    return
                finish(answer, "")
            else:
                finish(None, f"{key} answered an error: {reply.err.payload.to_string()}")

        def on_end() -> None:
            finish(None, f"no answer from {key} within {timeout_s:.1f} s")

        handler = zenoh.handlers.Callback(on_reply, on_end)
        self.session.get(key, handler, payload=encode(msg), timeout=timeout_s)

    def call(self, key: str, msg: Msg, reply_type: type[R], timeout_s: float) -> R:
        """Blocking query; raises TimeoutError/RuntimeError with one line on failure."""
        done = threading.Event()
        result: dict[str, Any] = {}

        def on_done(reply: R | None, error: str) -> None:
            result.update(reply=reply, error=error)
            done.set()

        self.request(key, msg, reply_type, timeout_s, on_done, locked=False)
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

        def on_sample(sample: zenoh.Sample) -> None:
            with self.lock:
                callback(str(sample.key_expr), sample.kind == zenoh.SampleKind.PUT)

        self._keep.append(
            self.session.liveliness().declare_subscriber(pattern, on_sample, history=True)
        )

    def alive(self, pattern: str, timeout_s: float = 1.0) -> list[str]:
        """The keys of the liveliness tokens matching ``pattern`` now."""
        replies = self.session.liveliness().get(pattern, timeout=timeout_s)
        return sorted(str(r.ok.key_expr) for r in replies if r.ok is not None)

    def close(self) -> None:
        """Undeclare everything and close the session."""
        self._keep.clear()
        self._publishers.clear()
        self.session.close()
