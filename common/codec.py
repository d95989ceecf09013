"""msgpack codec for bus messages.

Wire format: a msgpack array ``["zenav", type_name, schema_version, body]`` where ``body`` is a
map of field name -> value. Nested messages are encoded as maps; numpy arrays as msgpack ext
type 1 holding ``dtype-str \\0 shape... \\0 raw bytes`` (no per-element Python loop).
Any decoding problem — wrong type, wrong version, truncated, hostile — raises ``DecodeError``.
"""

from __future__ import annotations

import dataclasses
import os
import struct
import sys
import types
import typing
from typing import Any

import msgpack
import numpy as np

from common.messages import REGISTRY, Arr

MAGIC = "zenav"
_EXT_NDARRAY = 1
_MAX_DIMS = 4
_ALLOWED_DTYPES = {"float32", "float64", "int8", "uint8", "int16", "uint16", "int32", "uint32", "int64"}


def _tune_malloc() -> None:
    """Keep large buffers on glibc's heap instead of fresh mmaps.

    Encoding a 640x480 float32 image makes a few ~1.2 MB buffers at once; above glibc's (dynamic)
    mmap threshold each is a new mapping whose ~300 pages fault in on first touch — measured 5.9 ms
    per encode on a KVM guest, 0.25 ms with this. Process-wide; ZENAV_MALLOC_TUNE=0 disables it.
    """
    if not sys.platform.startswith("linux") or os.environ.get("ZENAV_MALLOC_TUNE", "1") == "0":
        return
    try:
        import ctypes

        libc = ctypes.CDLL("libc.so.6")
        libc.mallopt(-3, 64 << 20)  # M_MMAP_THRESHOLD: mmap only above 64 MB
        libc.mallopt(-1, 128 << 20)  # M_TRIM_THRESHOLD: keep up to 128 MB of freed heap
    except (OSError, AttributeError):  # not glibc (musl, ...): nothing to tune
        pass


_tune_malloc()


class DecodeError(ValueError):
    """A payload that is not a valid zenav message of the expected type."""


class EncodeError(ValueError):
    """A message that cannot be encoded (wrong field type or array dtype)."""


def _pack_array(a: np.ndarray) -> msgpack.ExtType:
    a = np.ascontiguousarray(a)
    if a.ndim > _MAX_DIMS:
        raise EncodeError(f"array with {a.ndim} dims")
    if a.dtype.name not in _ALLOWED_DTYPES:  # e.g. object arrays would send raw pointers
        raise EncodeError(f"array dtype {a.dtype.name!r} not allowed")
    dt = a.dtype.newbyteorder("<") if a.dtype.byteorder == ">" else a.dtype
    head = struct.pack("<BB", len(dt.name), a.ndim) + dt.name.encode() + struct.pack(f"<{a.ndim}Q", *a.shape)
    return msgpack.ExtType(_EXT_NDARRAY, head + a.astype(dt, copy=False).tobytes())


def _unpack_array(code: int, data: bytes) -> Any:
    if code != _EXT_NDARRAY:
        raise DecodeError(f"unknown ext type {code}")
    if len(data) < 2:
        raise DecodeError("truncated array header")
    nlen, ndim = data[0], data[1]
    if ndim > _MAX_DIMS:
        raise DecodeError(f"array with {ndim} dims")
    off = 2 + nlen + 8 * ndim
    if len(data) < off:
        raise DecodeError("truncated array header")
    name = data[2 : 2 + nlen].decode("ascii", errors="replace")
    if name not in _ALLOWED_DTYPES:
        raise DecodeError(f"array dtype {name!r} not allowed")
    shape = struct.unpack(f"<{ndim}Q", data[2 + nlen : off])
    dt = np.dtype(name).newbyteorder("<")
    count = 1
    for s in shape:
        count *= s
    if count * dt.itemsize != len(data) - off:
        raise DecodeError(f"array body is {len(data) - off} bytes, shape {shape} needs {count * dt.itemsize}")
    return np.frombuffer(data, dtype=dt, offset=off, count=count).reshape(shape)


_ARRAY_FIELDS: dict[str, dict[str, Arr]] = {}  # message name -> {array field: Arr}, built lazily


def _array_fields(name: str | None) -> dict[str, Arr]:
    specs = _ARRAY_FIELDS.get(name)  # type: ignore[arg-type]
    if specs is None:
        schema = REGISTRY.get(name) if name is not None else None
        specs = {}
        for k, ann in (schema.fields.items() if schema is not None else ()):
            if typing.get_origin(ann) is typing.Annotated:
                spec = next((m for m in ann.__metadata__ if isinstance(m, Arr)), None)
                if spec is not None:
                    specs[k] = spec
        _ARRAY_FIELDS[name] = specs  # type: ignore[index]
    return specs


def _to_wire(v: Any) -> Any:
    if dataclasses.is_dataclass(v):
        name = getattr(type(v), "_msg_name", None)
        if name is None:
            raise EncodeError(f"{type(v).__name__} is not a registered message type")
        for k, spec in _array_fields(name).items():  # the receiver would reject it: fail here, loudly
            a = getattr(v, k)
            if not isinstance(a, np.ndarray) or a.dtype.name != spec.dtype or a.ndim != spec.ndim:
                got = f"{a.dtype.name}[{a.ndim}d]" if isinstance(a, np.ndarray) else type(a).__name__
                raise EncodeError(f"{name}.{k}: expected {spec.dtype}[{spec.ndim}d] array, got {got}")
        return {f.name: _to_wire(getattr(v, f.name)) for f in dataclasses.fields(v)}
    if isinstance(v, np.ndarray):
        return _pack_array(v)
    if isinstance(v, (tuple, list)):
        return [_to_wire(x) for x in v]
    if isinstance(v, np.generic):
        return v.item()
    return v


def encode(msg: Any) -> bytes:
    """Encode a registered message to bytes."""
    name = getattr(type(msg), "_msg_name", None)
    if name is None:
        raise EncodeError(f"{type(msg).__name__} is not a registered message type")
    try:
        return msgpack.packb([MAGIC, name, type(msg)._msg_version, _to_wire(msg)], use_bin_type=True)
    except (TypeError, ValueError, OverflowError) as e:
        raise EncodeError(f"cannot encode {name}: {e}") from e


def _from_wire(ann: Any, v: Any, path: str) -> Any:
    """Build a field value of annotation ``ann`` from wire value ``v``, checking types."""
    origin = typing.get_origin(ann)
    if origin is typing.Annotated:
        spec = next((m for m in ann.__metadata__ if isinstance(m, Arr)), None)
        if spec is not None:
            if not isinstance(v, np.ndarray):
                raise DecodeError(f"{path}: expected array")
            if v.dtype.name != spec.dtype or v.ndim != spec.ndim:
                raise DecodeError(f"{path}: expected {spec.dtype}[{spec.ndim}d], got {v.dtype.name}[{v.ndim}d]")
            return v
        ann = typing.get_args(ann)[0]
        origin = typing.get_origin(ann)
    if origin is tuple:
        args = typing.get_args(ann)
        if not isinstance(v, list):
            raise DecodeError(f"{path}: expected list")
        if len(args) == 2 and args[1] is Ellipsis:
            return tuple(_from_wire(args[0], x, f"{path}[{i}]") for i, x in enumerate(v))
        if len(args) != len(v):
            raise DecodeError(f"{path}: expected {len(args)} items")
        return tuple(_from_wire(a, x, f"{path}[{i}]") for i, (a, x) in enumerate(zip(args, v)))
    if origin in (typing.Union, types.UnionType):
        for a in typing.get_args(ann):
            try:
                return _from_wire(a, v, path)
            except DecodeError:
                continue
        raise DecodeError(f"{path}: no union member matches")
    if ann is type(None):
        if v is not None:
            raise DecodeError(f"{path}: expected nil")
        return None
    if ann is float:
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise DecodeError(f"{path}: expected float")
        return float(v)
    if ann is bool:
        if not isinstance(v, bool):
            raise DecodeError(f"{path}: expected bool")
        return v
    if ann is int:
        if isinstance(v, bool) or not isinstance(v, int):
            raise DecodeError(f"{path}: expected int")
        return v
    if ann is str:
        if not isinstance(v, str):
            raise DecodeError(f"{path}: expected str")
        return v
    name = getattr(ann, "_msg_name", None)
    if name is not None:
        return _build(REGISTRY[name], v, path)
    raise DecodeError(f"{path}: unsupported field type {ann!r}")


def _build(schema, body: Any, path: str) -> Any:
    if not isinstance(body, dict):
        raise DecodeError(f"{path}: expected map")
    if set(body) != set(schema.fields):
        raise DecodeError(f"{path}: fields {sorted(map(str, body))} != {sorted(schema.fields)}")
    kwargs = {k: _from_wire(ann, body[k], f"{path}.{k}") for k, ann in schema.fields.items()}
    try:
        return schema.cls(**kwargs)
    except (TypeError, ValueError) as e:
        raise DecodeError(f"{path}: {e}") from e


def decode(data: bytes | bytearray | memoryview, expected: type | None = None) -> Any:
    """Decode bytes into a message; if ``expected`` is given the type must match. Raises DecodeError."""
    try:
        obj = msgpack.unpackb(
            bytes(data), raw=False, ext_hook=_unpack_array, strict_map_key=True,
            max_bin_len=1 << 30, max_str_len=1 << 20, max_array_len=1 << 24, max_map_len=1 << 16,
        )
    except DecodeError:
        raise
    except Exception as e:  # msgpack raises many types on hostile input
        raise DecodeError(f"not a msgpack payload: {type(e).__name__}: {e}") from e
    if not (isinstance(obj, list) and len(obj) == 4 and obj[0] == MAGIC):
        raise DecodeError("not a zenav payload (missing magic)")
    _, name, version, body = obj
    schema = REGISTRY.get(name) if isinstance(name, str) else None
    if schema is None:
        raise DecodeError(f"unknown message type {name!r}")
    if expected is not None and schema.cls is not expected:
        raise DecodeError(f"expected {getattr(expected, '_msg_name', expected)}, got {name}")
    if version != schema.version:
        raise DecodeError(f"{name}: schema version {version!r}, this build speaks {schema.version}")
    try:
        return _build(schema, body, name)
    except DecodeError:
        raise
    except (RecursionError, MemoryError, TypeError, ValueError, KeyError) as e:
        raise DecodeError(f"{name}: {type(e).__name__}: {e}") from e
