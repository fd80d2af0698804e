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


def _to_wire(msg: Msg) -> dict[str, Any]:
    return {f.name: _field_to_wire(getattr(msg, f.name)) for f in dataclasses.fields(msg)}


def _field_to_wire(value: Any) -> Any:
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
        _validate(msg, cls.TAG)
    except DecodeError as exc:
        raise EncodeError(str(exc)) from None
    return msgpack.packb({"t": cls.TAG, "v": cls.VERSION, "d": wire}, default=_pack_ext)


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
# Schema checks (shared by encode and decode)
# --------------------------------------------------------------------------------------


@functools.cache
def _hints(cls: type) -> dict[str, Any]:
    return typing.get_type_hints(cls)


def _check_fields(cls: type, data: dict[str, Any], path: str) -> dict[str, Any]:
    fields = {f.name: f for f in dataclasses.fields(cls)}
    unknown = sorted(set(data) - fields.keys())
    if unknown:
        raise DecodeError(f"{path}: unknown field {unknown[0]!r}")
    values = {}
    hints = _hints(cls)
    for name, f in fields.items():
        if name not in data:
            has_default = (
                f.default is not dataclasses.MISSING or f.default_factory is not dataclasses.MISSING
            )
            if has_default:
                continue
            raise DecodeError(f"{path}.{name}: missing")
        values[name] = _check_value(hints[name], data[name], f"{path}.{name}", f.metadata)
    return values


def _check_value(hint: Any, value: Any, path: str, meta: Any) -> Any:
    origin = typing.get_origin(hint)
    if origin in (typing.Union, types.UnionType):
        options = typing.get_args(hint)
        if value is None and type(None) in options:
            return None
        inner = [o for o in options if o is not type(None)]
        return _check_value(inner[0], value, path, meta)
    if hint is float:
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise DecodeError(f"{path}: expected a number, got {type(value).__name__}")
        if not math.isfinite(value):
            raise DecodeError(f"{path}: not finite ({value})")
        return _in_range(float(value), path, meta, DEFAULT_LIMIT)
    if hint is bool:
        if not isinstance(value, bool):
            raise DecodeError(f"{path}: expected true/false, got {type(value).__name__}")
        return value
    if hint is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise DecodeError(f"{path}: expected an integer, got {type(value).__name__}")
        return _in_range(value, path, meta, INT_LIMIT)
    if hint is str:
        if not isinstance(value, str):
            raise DecodeError(f"{path}: expected text, got {type(value).__name__}")
        if len(value) > MAX_TEXT:
            raise DecodeError(f"{path}: text of {len(value)} characters (at most {MAX_TEXT})")
        return value
    if origin is list:
        if not isinstance(value, list):
            raise DecodeError(f"{path}: expected a list, got {type(value).__name__}")
        (item,) = typing.get_args(hint)
        return [_check_value(item, v, f"{path}[{i}]", meta) for i, v in enumerate(value)]
    if hint is np.ndarray:
        return _check_array(value, path, meta)
    if dataclasses.is_dataclass(hint):
        if not isinstance(value, dict):
            raise DecodeError(f"{path}: expected a {hint.TAG} map, got {type(value).__name__}")
        return _build(hint, value, path)
    raise DecodeError(f"{path}: unsupported field type {hint!r}")


def _in_range(value: float | int, path: str, meta: Any, limit: float) -> float | int:
    lo, hi = meta.get("range", (-limit, limit))
    if not lo <= value <= hi:
        raise DecodeError(f"{path}: {value!r} is outside [{lo:g}, {hi:g}]")
    return value


def _check_array(value: Any, path: str, meta: Any) -> np.ndarray:
    if not isinstance(value, np.ndarray):
        raise DecodeError(f"{path}: expected an array, got {type(value).__name__}")
    dtype, shape = meta.get("dtype"), meta.get("shape")
    if dtype is not None and value.dtype != dtype:
        raise DecodeError(f"{path}: expected dtype {dtype}, got {value.dtype}")
    if shape is not None:
        ok = len(shape) == value.ndim and all(
            want is None or want == got for want, got in zip(shape, value.shape, strict=True)
        )
        if not ok:
            raise DecodeError(f"{path}: expected shape {shape}, got {value.shape}")
    if value.dtype.kind in "fiu" and value.size:
        limit = meta.get("limit") or DEFAULT_LIMIT
        # one pass in the common case: NaN fails the comparison as well
        if not (np.abs(value) <= limit).all():
            if value.dtype.kind == "f" and not np.isfinite(value).all():
                raise DecodeError(f"{path}: contains non-finite values")
            worst = value.flat[int(np.argmax(np.abs(value)))].item()
            raise DecodeError(f"{path}: value {worst!r} is outside [{-limit:g}, {limit:g}]")
    return value


def _validate(msg: Msg, path: str) -> None:
    try:
        msg.validate()
    except Invalid as exc:
        raise DecodeError(f"{path}.{exc}") from None


def _build(cls: type, data: dict[str, Any], path: str) -> Any:
    msg = cls(**_check_fields(cls, data, path))
    _validate(msg, path)
    return msg
