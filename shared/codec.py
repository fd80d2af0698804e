"""msgpack codec for wheelnav messages, with numpy arrays carried as raw bytes.

Wire format: a msgpack map ``{"t": tag, "v": schema version, "d": {field: value}}``.
Nested messages are maps of their fields; numpy arrays are msgpack extension type 1
holding ``[dtype string, shape, raw C-order bytes]`` (never Python lists).

Every failure to decode (not msgpack, truncated, unknown tag, a schema version that is
not an integer from 1 to this build's, missing or unknown field, wrong type or shape,
non-finite number, a number outside its range, fields that disagree with each other)
raises :class:`DecodeError` with a one-line message naming the field, so a subscriber can
log, count and go on. Encoding runs the same checks (:class:`EncodeError`).

The checks per field come from the type hints and field metadata of
:mod:`shared.messages` (``range`` for numbers, ``dtype``/``shape``/``limit`` for arrays);
the checks across fields are each class's :meth:`~shared.messages.Msg.validate`, run on
every message built, nested ones included.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import types
import typing
from collections.abc import Callable
from typing import Any, TypeVar

import msgpack
import numpy as np

from shared.messages import DEFAULT_LIMIT, INT_LIMIT, MAX_TEXT, REGISTRY, Invalid, Msg

_EXT_NDARRAY = 1
T = TypeVar("T", bound=Msg)


class DecodeError(ValueError):
    """A payload that is not a valid message of the expected type."""


class EncodeError(ValueError):
    """A message that cannot be sent as it is (wrong type, shape or a non-finite number)."""


# --------------------------------------------------------------------------------------
# Encoding
# --------------------------------------------------------------------------------------


def _pack_ext(obj: Any) -> msgpack.ExtType:
    if isinstance(obj, np.ndarray):
        arr = np.ascontiguousarray(obj)
        header = msgpack.packb([arr.dtype.str, list(arr.shape)])
        return msgpack.ExtType(_EXT_NDARRAY, header + arr.tobytes())
    if isinstance(obj, np.generic):
        return obj.item()
    raise TypeError(f"cannot encode {type(obj).__name__}")


@functools.cache
def _field_names(cls: type) -> tuple[str, ...]:
    return tuple(f.name for f in dataclasses.fields(cls))


def _to_wire(msg: Any) -> dict[str, Any]:
    cls = msg if isinstance(msg, type) else type(msg)
    return {name: _field_to_wire(getattr(msg, name)) for name in _field_names(cls)}


_PLAIN = frozenset({float, int, str, bool, type(None), np.ndarray})  # sent as they are


def _field_to_wire(value: Any) -> Any:
    if type(value) in _PLAIN:
        return value
    if dataclasses.is_dataclass(value):
        return _to_wire(value)
    if isinstance(value, list):
        return [_field_to_wire(v) for v in value]
    return value


def encode(msg: Msg) -> bytes:
    """Check ``msg`` against its schema and pack it; raises EncodeError naming the bad field."""
    cls = type(msg)
    if getattr(cls, "TAG", None) not in REGISTRY:
        raise EncodeError(f"{cls.__name__} is not a registered message type")
    wire = _to_wire(msg)
    try:
        _check_fields(cls, wire, cls.TAG)
        if _plan(cls).validates:
            _validate(msg, cls.TAG)
    except DecodeError as exc:
        raise EncodeError(str(exc)) from None
    return msgpack.packb({"t": cls.TAG, "v": cls.VERSION, "d": wire}, default=_pack_ext)


def checked(msg: Msg) -> Msg:
    """``msg`` checked as :func:`encode` checks it (EncodeError naming the bad field) and
    rebuilt as :func:`decode` builds it: numbers as the wire gives them back, nested
    messages and lists new. Its arrays are ``msg``'s own: :func:`clone` it for a receiver.

    The in-process fleet's buses hand messages over so (shared.transport.LocalExchange):
    the bytes between the two cost more than the checks.
    """
    cls = type(msg)
    if getattr(cls, "TAG", None) not in REGISTRY:
        raise EncodeError(f"{cls.__name__} is not a registered message type")
    try:
        return _checked(cls, msg, cls.TAG)
    except DecodeError as exc:
        raise EncodeError(str(exc)) from None


def _checked(cls: type, msg: Any, path: str) -> Any:
    """``_build(cls, _to_wire(msg), path)`` without the wire form: each field checked as
    it is held (a plain value's wire form is itself), a nested message or a list of them
    checked as objects. A field whose value is of another type takes the wire way, and a
    list whose items fail is checked again that way for the failing item's path. A
    navigator's tree snapshot (a list of nodes) took 1.9 ms the wire way."""
    plan = _plan(cls)
    values = {}
    held = msg.__dict__
    for (name, check, _default, fast, kind, lo, hi, optional), nested in zip(
        plan.fields, plan.nested, strict=True
    ):
        value = held[name]
        if fast and type(value) is kind:  # _check_fields' fast test, inline: the hot path
            if fast == _NUMBER:
                if lo <= value <= hi:  # NaN and infinities fail it
                    values[name] = value
                    continue
            elif fast == _BOOL or len(value) <= MAX_TEXT:
                values[name] = value
                continue
        elif optional and value is None:
            values[name] = None
            continue
        if nested is not None:
            item_cls, many = nested
            if not many and type(value) is item_cls:
                values[name] = _checked(item_cls, value, f"{path}.{name}")
                continue
            if many and type(value) is list and all(type(v) is item_cls for v in value):
                try:
                    values[name] = [_checked(item_cls, v, path) for v in value]
                    continue
                except DecodeError:
                    pass  # the wire way below names the failing item
        values[name] = check(_field_to_wire(value), f"{path}.{name}")
    out = cls.__new__(cls)  # every field is in values: what __init__ would set (no hooks)
    out.__dict__.update(values)
    if plan.validates:
        _validate(out, path)
    return out


def clone(msg: Msg) -> Msg:
    """A copy of a :func:`checked` or decoded message that shares nothing with it that a
    receiver could change (arrays copied, writable, as decode gives them; nested messages
    and lists copied), without checking it again."""
    cls = type(msg)
    copy = cls.__new__(cls)
    fields = dict(msg.__dict__)
    for name in _deep_fields(cls):
        fields[name] = _cloned(fields[name])
    copy.__dict__.update(fields)
    return copy


@functools.cache
def _deep_fields(cls: type) -> tuple[str, ...]:
    """The fields of ``cls`` that may hold something mutable (an array, list, message):
    those without a fast test in its :class:`_Plan` (numbers, text, bools are immutable)."""
    return tuple(name for name, _check, _default, fast, *_ in _plan(cls).fields if not fast)


def _cloned(value: Any) -> Any:
    if isinstance(value, np.ndarray):
        return value.copy()
    if isinstance(value, list):
        return [_cloned(v) for v in value]
    if dataclasses.is_dataclass(value):
        return clone(value)
    return value


# --------------------------------------------------------------------------------------
# Decoding
# --------------------------------------------------------------------------------------


_HEADER_PEEK = 256  # bytes read for an array's header (dtype and shape) before its body


def _unpack_ext(code: int, data: bytes) -> Any:
    if code != _EXT_NDARRAY:
        raise DecodeError(f"unknown msgpack extension type {code}")
    unpacker = msgpack.Unpacker(raw=False)
    # the header is a few bytes: read it from the front instead of copying a whole scan in
    unpacker.feed(data[:_HEADER_PEEK])
    try:
        try:
            header = unpacker.unpack()
        except msgpack.OutOfData:  # a long shape: read the header from the whole buffer
            unpacker = msgpack.Unpacker(raw=False)
            unpacker.feed(data)
            header = unpacker.unpack()
        dtype_str, shape = header
        offset = unpacker.tell()
        dtype = np.dtype(dtype_str)
    except Exception as exc:
        raise DecodeError(f"bad array header: {exc}") from None
    if dtype.hasobject:
        raise DecodeError("object arrays are not allowed")
    if not isinstance(shape, list) or not all(type(n) is int and n >= 0 for n in shape):
        raise DecodeError(f"bad array shape {shape!r}")
    count = math.prod(shape) if shape else 1
    size = len(data) - offset
    if size != count * dtype.itemsize:
        raise DecodeError(
            f"array of shape {shape} {dtype} needs {count * dtype.itemsize} bytes, got {size}"
        )
    return np.frombuffer(data, dtype=dtype, count=count, offset=offset).reshape(shape).copy()


def peek_tag(payload: bytes) -> str:
    """The message tag of a payload, without checking the rest (for tools that show any topic)."""
    return _unpack(payload)["t"]


def _unpack(payload: bytes) -> dict[str, Any]:
    try:
        obj = msgpack.unpackb(bytes(payload), ext_hook=_unpack_ext, raw=False, strict_map_key=True)
    except DecodeError:
        raise
    except Exception as exc:
        raise DecodeError(f"not a msgpack message ({type(exc).__name__}: {exc})") from None
    if not isinstance(obj, dict) or not {"t", "v", "d"} <= obj.keys():
        raise DecodeError("not a wheelnav message (expected a map with t, v, d)")
    if not isinstance(obj["t"], str) or not isinstance(obj["d"], dict):
        raise DecodeError("not a wheelnav message (bad t or d)")
    return obj


def decode(payload: bytes, expected: type[T] | None = None) -> T:
    """Unpack and check a payload; ``expected`` pins the type. Raises DecodeError on any fault."""
    obj = _unpack(payload)
    tag, version = obj["t"], obj["v"]
    cls = REGISTRY.get(tag)
    if cls is None:
        raise DecodeError(f"unknown message tag {tag!r}")
    if expected is not None and cls is not expected:
        raise DecodeError(f"expected {expected.TAG}, got {tag}")
    if isinstance(version, bool) or not isinstance(version, int) or version < 1:
        raise DecodeError(f"{tag} schema version {version!r}: expected an integer >= 1")
    if version > cls.VERSION:
        raise DecodeError(
            f"{tag} schema version {version!r} is newer than this build's {cls.VERSION}"
        )
    return _build(cls, obj["d"], tag)


def to_plain(msg: Msg) -> dict[str, Any]:
    """A JSON-friendly dict of a message (arrays as nested lists), for tools and reports."""

    def plain(value: Any) -> Any:
        if dataclasses.is_dataclass(value):
            return {f.name: plain(getattr(value, f.name)) for f in dataclasses.fields(value)}
        if isinstance(value, np.ndarray):
            return value.tolist()
        if isinstance(value, list):
            return [plain(v) for v in value]
        return value

    return {"type": msg.TAG, **plain(msg)}


# --------------------------------------------------------------------------------------
# Schema checks (shared by encode and decode), compiled once per message type
# --------------------------------------------------------------------------------------

Check = Callable[[Any, str], Any]
"""One field's check: the value as the message holds it, or DecodeError naming ``path``."""


# How a field's usual value is recognised without calling its check (``_Plan.fields``)
_OTHER, _NUMBER, _TEXT, _BOOL = range(4)


@dataclasses.dataclass(frozen=True)
class _Plan:
    """A message type's fields as the codec checks them.

    Each field: name, check, whether it has a default, and how its usual value passes
    without a call (``fast``: a float or int of exactly ``kind`` within [lo, hi], text
    of exactly str within ``MAX_TEXT``, exactly a bool; ``optional``: None passes too).
    A field's path (``odometry.pose.x``) is built only for a value that fails the fast
    test: building one per field cost more than the checks (``wheelnav bench codec``).
    """

    names: frozenset[str]
    fields: tuple[tuple[str, Check, bool, int, type, Any, Any, bool], ...]
    validates: bool  # the class has checks across its fields (Msg.validate overridden)
    # per field: (message type, a list of them?) for a nested message or a list of them
    nested: tuple[tuple[type, bool] | None, ...] = ()


@functools.cache
def _plan(cls: type) -> _Plan:
    """The checks of ``cls``'s fields, built once from its type hints and field metadata:
    reading hints and metadata for every message cost more than the checks themselves
    (``wheelnav bench codec``)."""
    hints = typing.get_type_hints(cls)
    fields = dataclasses.fields(cls)
    return _Plan(
        frozenset(f.name for f in fields),
        tuple(
            (
                f.name,
                _check_for(hints[f.name], f.metadata),
                f.default is not dataclasses.MISSING
                or f.default_factory is not dataclasses.MISSING,
                *_fast_test(hints[f.name], f.metadata),
            )
            for f in fields
        ),
        cls.validate is not Msg.validate,
        tuple(_nested_type(hints[f.name]) for f in fields),
    )


def _nested_type(hint: Any) -> tuple[type, bool] | None:
    """(message type, whether a list of them) of a field that holds messages, else None."""
    if typing.get_origin(hint) is list:
        (item,) = typing.get_args(hint)
        return (item, True) if dataclasses.is_dataclass(item) else None
    return (hint, False) if dataclasses.is_dataclass(hint) else None


def _fast_test(hint: Any, meta: Any) -> tuple[int, type, Any, Any, bool]:
    """``(fast, kind, lo, hi, optional)`` of a field (see :class:`_Plan`): the test its
    check starts with, so a value that passes it is the value the check would return."""
    optional = False
    if typing.get_origin(hint) in (typing.Union, types.UnionType):
        options = [o for o in typing.get_args(hint) if o is not type(None)]
        optional = len(options) < len(typing.get_args(hint))
        hint = options[0]
    if hint is float:
        return _NUMBER, float, *meta.get("range", (-DEFAULT_LIMIT, DEFAULT_LIMIT)), optional
    if hint is int:
        return _NUMBER, int, *meta.get("range", (-INT_LIMIT, INT_LIMIT)), optional
    if hint is str:
        return _TEXT, str, None, None, optional
    if hint is bool:
        return _BOOL, bool, None, None, optional
    return _OTHER, object, None, None, optional


_ABSENT = object()


def _check_fields(cls: type, data: dict[str, Any], path: str) -> dict[str, Any]:
    plan = _plan(cls)
    if not plan.names.issuperset(data):
        unknown = sorted(set(data) - plan.names)
        raise DecodeError(f"{path}: unknown field {unknown[0]!r}")
    values = {}
    for name, check, has_default, fast, kind, lo, hi, optional in plan.fields:
        value = data.get(name, _ABSENT)
        if value is _ABSENT:
            if not has_default:
                raise DecodeError(f"{path}.{name}: missing")
            continue
        if fast and type(value) is kind:
            if fast == _NUMBER:
                if lo <= value <= hi:  # NaN and infinities fail it
                    values[name] = value
                    continue
            elif fast == _BOOL or len(value) <= MAX_TEXT:
                values[name] = value
                continue
        elif optional and value is None:
            values[name] = None
            continue
        values[name] = check(value, f"{path}.{name}")
    return values


def _check_for(hint: Any, meta: Any) -> Check:
    """The check of a field with type ``hint`` and metadata ``meta`` (ranges, dtype...)."""
    origin = typing.get_origin(hint)
    if origin in (typing.Union, types.UnionType):
        options = typing.get_args(hint)
        inner = _check_for([o for o in options if o is not type(None)][0], meta)
        if type(None) not in options:
            return inner
        return lambda value, path: None if value is None else inner(value, path)
    if hint is float:
        return _number_check(*meta.get("range", (-DEFAULT_LIMIT, DEFAULT_LIMIT)))
    if hint is bool:
        return _check_bool
    if hint is int:
        return _int_check(*meta.get("range", (-INT_LIMIT, INT_LIMIT)))
    if hint is str:
        return _check_str
    if origin is list:
        (item,) = typing.get_args(hint)
        return _list_check(_check_for(item, meta))
    if hint is np.ndarray:
        return _array_check(meta.get("dtype"), meta.get("shape"), meta.get("limit"))
    if dataclasses.is_dataclass(hint):
        return _nested_check(hint)

    def unsupported(value: Any, path: str) -> Any:
        raise DecodeError(f"{path}: unsupported field type {hint!r}")

    return unsupported


def _outside(value: float | int, path: str, lo: float, hi: float) -> DecodeError:
    return DecodeError(f"{path}: {value!r} is outside [{lo:g}, {hi:g}]")


def _number_check(lo: float, hi: float) -> Check:
    def number(value: Any, path: str) -> float:
        if type(value) is float and lo <= value <= hi:
            return value  # the common case; NaN and infinities fail the comparison
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise DecodeError(f"{path}: expected a number, got {type(value).__name__}")
        if not math.isfinite(value):
            raise DecodeError(f"{path}: not finite ({value})")
        value = float(value)
        if not lo <= value <= hi:
            raise _outside(value, path, lo, hi)
        return value

    return number


def _int_check(lo: int, hi: int) -> Check:
    def integer(value: Any, path: str) -> int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise DecodeError(f"{path}: expected an integer, got {type(value).__name__}")
        if not lo <= value <= hi:
            raise _outside(value, path, lo, hi)
        return value if type(value) is int else int(value)  # an IntEnum as its number

    return integer


def _check_bool(value: Any, path: str) -> bool:
    if not isinstance(value, bool):
        raise DecodeError(f"{path}: expected true/false, got {type(value).__name__}")
    return value


def _check_str(value: Any, path: str) -> str:
    if not isinstance(value, str):
        raise DecodeError(f"{path}: expected text, got {type(value).__name__}")
    if len(value) > MAX_TEXT:
        raise DecodeError(f"{path}: text of {len(value)} characters (at most {MAX_TEXT})")
    return value if type(value) is str else str.__str__(value)  # a StrEnum as its text


def _list_check(item: Check) -> Check:
    def items(value: Any, path: str) -> list[Any]:
        if not isinstance(value, list):
            raise DecodeError(f"{path}: expected a list, got {type(value).__name__}")
        return [item(v, f"{path}[{i}]") for i, v in enumerate(value)]

    return items


def _nested_check(cls: type) -> Check:
    def nested(value: Any, path: str) -> Any:
        if not isinstance(value, dict):
            raise DecodeError(f"{path}: expected a {cls.TAG} map, got {type(value).__name__}")
        return _build(cls, value, path)

    return nested


def _array_check(dtype: np.dtype | None, shape: tuple | None, limit: float | None) -> Check:
    limit = limit or DEFAULT_LIMIT

    def array(value: Any, path: str) -> np.ndarray:
        if not isinstance(value, np.ndarray):
            raise DecodeError(f"{path}: expected an array, got {type(value).__name__}")
        if dtype is not None and value.dtype != dtype:
            raise DecodeError(f"{path}: expected dtype {dtype}, got {value.dtype}")
        if shape is not None:
            ok = len(shape) == value.ndim and all(
                want is None or want == got for want, got in zip(shape, value.shape, strict=True)
            )
            if not ok:
                raise DecodeError(f"{path}: expected shape {shape}, got {value.shape}")
        kind = value.dtype.kind
        if kind in "fiu" and value.size:
            # floats: two reductions and no temporary array (NaN fails them as well);
            # integers through abs as before (the smallest int64 has no positive twin)
            if kind == "f":
                fine = value.min() >= -limit and value.max() <= limit
            else:
                fine = (np.abs(value) <= limit).all()
            if not fine:
                if kind == "f" and not np.isfinite(value).all():
                    raise DecodeError(f"{path}: contains non-finite values")
                worst = value.flat[int(np.argmax(np.abs(value)))].item()
                raise DecodeError(f"{path}: value {worst!r} is outside [{-limit:g}, {limit:g}]")
        return value

    return array


def _validate(msg: Msg, path: str) -> None:
    try:
        msg.validate()
    except Invalid as exc:
        raise DecodeError(f"{path}.{exc}") from None


def _build(cls: type, data: dict[str, Any], path: str) -> Any:
    msg = cls(**_check_fields(cls, data, path))
    if _plan(cls).validates:
        _validate(msg, path)
    return msg
