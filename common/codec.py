"""msgpack codec for bus messages.

Wire format: a msgpack array ``["zenav", type_name, schema_version, body]`` where ``body`` is a
map of field name -> value. Nested messages are encoded as maps; numpy arrays as msgpack ext
type 1 holding ``dtype-str \\0 shape... \\0 raw bytes`` (no per-element Python loop).
Any decoding problem — wrong type, wrong version, truncated, hostile — raises ``DecodeError``.
"""

from __future__ import annotations

import dataclasses
import struct
import types
import typing
from typing import Any, Callable

import msgpack
import numpy as np

from common import codec_gen, malloc_tune
from common.messages import REGISTRY

MAGIC = "zenav"
_EXT_NDARRAY = 1
_MAX_DIMS = 4
_ALLOWED_DTYPES = {"float32", "float64", "int8", "uint8", "int16", "uint16", "int32", "uint32", "int64"}

malloc_tune.apply()


class DecodeError(ValueError):
    """A payload that is not a valid zenav message of the expected type."""


class EncodeError(ValueError):
    """A message that cannot be encoded (wrong field type or array dtype)."""


def _pack_array(a: np.ndarray) -> msgpack.ExtType:
    if a.ndim > _MAX_DIMS:
        raise EncodeError(f"array with {a.ndim} dims")
    name = _DTYPE_NAMES.get(a.dtype)  # dtype.name is a slow Python property in numpy
    if name is None:  # e.g. object arrays would send raw pointers
        raise EncodeError(f"array dtype {a.dtype.name!r} not allowed")
    if a.dtype.byteorder == ">":
        a = a.astype(a.dtype.newbyteorder("<"))
    head = struct.pack(f"<BB{len(name)}s{a.ndim}Q", len(name), a.ndim, name.encode(), *a.shape)
    return msgpack.ExtType(_EXT_NDARRAY, head + a.tobytes())  # tobytes: C order, contiguous or not


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
    dt = _DTYPES.get(name)
    if dt is None:
        raise DecodeError(f"array dtype {name!r} not allowed")
    shape = struct.unpack(f"<{ndim}Q", data[2 + nlen : off])
    count = 1
    for s in shape:
        count *= s
    if count * dt.itemsize != len(data) - off:
        raise DecodeError(f"array body is {len(data) - off} bytes, shape {shape} needs {count * dt.itemsize}")
    return np.frombuffer(data, dtype=dt, offset=off, count=count).reshape(shape)


_DTYPES = {n: np.dtype(n).newbyteorder("<") for n in _ALLOWED_DTYPES}
_DTYPE_NAMES = {dt: n for n in _ALLOWED_DTYPES for dt in (np.dtype(n).newbyteorder("<"), np.dtype(n).newbyteorder(">"))}
_SCALARS = frozenset({float, int, str, bool, bytes, type(None)})  # sent as they are
# Encoders and decoders compiled once per message type / annotation: the generic walk over
# dataclasses.fields() and typing.get_origin() per field cost more than Zenoh itself per scan.
_ENCODERS: dict[type, Callable[[Any], dict]] = {}
_DECODERS: dict[Any, Callable[[Any], Any]] = {}


_array_spec = codec_gen.array_spec
_FAST: dict[type, Callable[[Any], Any]] = {}  # straight-line decoders (common.codec_gen)


def _make_encoder(cls: type) -> Callable[[Any], dict]:
    name = getattr(cls, "_msg_name", None)
    if name is None:
        raise EncodeError(f"{cls.__name__} is not a registered message type")
    schema = REGISTRY[name]
    arrays = [(k, s.dtype, s.ndim) for k, ann in schema.fields.items() if (s := _array_spec(ann)) is not None]

    def check_arrays(v: Any) -> None:  # the receiver would reject it: fail here, loudly
        for k, dtype, ndim in arrays:
            a = getattr(v, k)
            if not isinstance(a, np.ndarray) or _DTYPE_NAMES.get(a.dtype) != dtype or a.ndim != ndim:
                got = f"{a.dtype.name}[{a.ndim}d]" if isinstance(a, np.ndarray) else type(a).__name__
                raise EncodeError(f"{name}.{k}: expected {dtype}[{ndim}d] array, got {got}")

    names = tuple(f.name for f in dataclasses.fields(cls))
    return codec_gen.make_encoder(cls, schema.fields, names, _encoder_of, _to_wire, check_arrays)


def _encoder_of(cls: type) -> Callable[[Any], dict]:
    enc = _ENCODERS.get(cls)
    if enc is None:
        enc = _ENCODERS[cls] = _make_encoder(cls)
    return enc


def _to_wire(v: Any) -> Any:
    t = type(v)
    if t in _SCALARS:
        return v
    enc = _ENCODERS.get(t)
    if enc is not None:
        return enc(v)
    if t is np.ndarray:
        return _pack_array(v)
    if dataclasses.is_dataclass(v):
        return _encoder_of(t)(v)
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


# A decoder takes a wire value and returns the field value, or raises DecodeError whose text starts
# with the path below it (": expected float", ".header.stamp: expected float"); callers prefix theirs.
def _decoder(ann: Any) -> Callable[[Any], Any]:
    fn = _DECODERS.get(ann)
    if fn is None:
        fn = _DECODERS[ann] = _make_decoder(ann)
    return fn


def _fail(text: str) -> Callable[[Any], Any]:
    def dec(v: Any) -> Any:
        raise DecodeError(text)
    return dec


def _make_decoder(ann: Any) -> Callable[[Any], Any]:  # noqa: C901 - one branch per kind of field
    origin = typing.get_origin(ann)
    if origin is typing.Annotated:
        spec = _array_spec(ann)
        if spec is None:
            return _decoder(typing.get_args(ann)[0])
        dtype, ndim, want = spec.dtype, spec.ndim, _DTYPES.get(spec.dtype)

        def arr(v: Any) -> Any:  # arrays on the wire are always little-endian (_unpack_array)
            if type(v) is not np.ndarray:
                raise DecodeError(": expected array")
            if v.dtype != want or v.ndim != ndim:
                raise DecodeError(f": expected {dtype}[{ndim}d], got {v.dtype.name}[{v.ndim}d]")
            return v
        return arr
    if origin is tuple:
        args = typing.get_args(ann)
        variadic = len(args) == 2 and args[1] is Ellipsis
        items = [_decoder(a) for a in (args[:1] if variadic else args)]

        def tup(v: Any) -> tuple:
            if type(v) is not list:
                raise DecodeError(": expected list")
            if not variadic and len(v) != len(items):
                raise DecodeError(f": expected {len(items)} items")
            out = []
            for i, x in enumerate(v):
                try:
                    out.append((items[0] if variadic else items[i])(x))
                except DecodeError as e:
                    raise DecodeError(f"[{i}]{e}") from None
            return tuple(out)
        return tup
    if origin in (typing.Union, types.UnionType):
        members = [_decoder(a) for a in typing.get_args(ann)]

        def union(v: Any) -> Any:
            for m in members:
                try:
                    return m(v)
                except DecodeError:
                    continue
            raise DecodeError(": no union member matches")
        return union
    if ann is float:
        return lambda v: v if type(v) is float else float(v) if type(v) is int else _raise(": expected float")
    if ann in (bool, int, str, type(None)):
        expected = "nil" if ann is type(None) else ann.__name__
        return lambda v: v if type(v) is ann else _raise(f": expected {expected}")
    name = getattr(ann, "_msg_name", None)
    if name is not None:
        return _make_builder(REGISTRY[name])
    return _fail(f": unsupported field type {ann!r}")


def _raise(text: str) -> Any:
    raise DecodeError(text)


def _plain(cls: type) -> bool:
    """A plain dataclass (generated __init__, no __post_init__, no slots): fill its __dict__ directly, 10x
    cheaper than __init__'s object.__setattr__ per field of a frozen class; every field is given."""
    init = getattr(getattr(cls, "__init__", None), "__code__", None)
    return (init is not None and init.co_filename == "<string>" and not hasattr(cls, "__post_init__")
            and "__slots__" not in cls.__dict__ and all(f.init for f in dataclasses.fields(cls)))


def _make_builder(schema) -> Callable[[Any], Any]:
    keys = frozenset(schema.fields)
    fields = [(k, _decoder(ann)) for k, ann in schema.fields.items()]
    cls = schema.cls
    new = object.__new__
    plain = _plain(cls)

    def build(body: Any) -> Any:
        if type(body) is not dict:
            raise DecodeError(": expected map")
        if body.keys() != keys:
            raise DecodeError(f": fields {sorted(map(str, body))} != {sorted(keys)}")
        kwargs = {}
        for k, dec in fields:
            try:
                kwargs[k] = dec(body[k])
            except DecodeError as e:
                raise DecodeError(f".{k}{e}") from None
        if plain:
            obj = new(cls)
            obj.__dict__.update(kwargs)
            return obj
        try:
            return cls(**kwargs)
        except (TypeError, ValueError) as e:
            raise DecodeError(f": {e}") from e
    return build


def _fast_of(cls: Any) -> Callable[[Any], Any]:
    fn = _FAST.get(cls)
    if fn is None:
        schema = REGISTRY[cls._msg_name]
        fn = _FAST[cls] = codec_gen.make_decoder(cls, schema.fields, _plain(cls), _decoder, _fast_of, _DTYPES)
    return fn


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
        return _fast_of(schema.cls)(body)
    except Exception:  # noqa: BLE001 - off the common case (or bad): the generic walk decides and explains
        pass
    try:
        return _decoder(schema.cls)(body)
    except DecodeError as e:
        raise DecodeError(f"{name}{e}") from None
    except (RecursionError, MemoryError, TypeError, ValueError, KeyError) as e:
        raise DecodeError(f"{name}: {type(e).__name__}: {e}") from e


def peek_type(data: bytes) -> str:
    """The message type name of a payload without decoding its body ('?' if not a zenav payload;
    for listing topics without paying for a decode)."""
    try:
        u = msgpack.Unpacker(raw=False, max_buffer_size=max(len(data), 1))
        u.feed(data)
        if u.read_array_header() != 4 or u.unpack() != MAGIC:
            return "?"
        name = u.unpack()
        return name if isinstance(name, str) else "?"
    except Exception:  # noqa: BLE001 - anything odd is simply not a zenav payload
        return "?"
