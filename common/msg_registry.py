"""The message registry: ``register`` adds a frozen dataclass under a name and schema version;
``Arr`` declares a numpy array field's dtype and dimensions; ``msg_equal`` compares messages with
arrays. ``common.messages`` declares the types, ``common.codec`` encodes them."""

from __future__ import annotations

import dataclasses
import typing
from dataclasses import dataclass
from typing import Annotated, Any

import numpy as np


@dataclass(frozen=True)
class Arr:
    """Declares a numpy array field: dtype name and number of dimensions (``ndim``)."""

    dtype: str
    ndim: int


F32_1 = Annotated[np.ndarray, Arr("float32", 1)]
F32_2 = Annotated[np.ndarray, Arr("float32", 2)]
F64_2 = Annotated[np.ndarray, Arr("float64", 2)]
I8_2 = Annotated[np.ndarray, Arr("int8", 2)]
U8_2 = Annotated[np.ndarray, Arr("uint8", 2)]


class Schema(typing.NamedTuple):
    cls: type
    version: int
    fields: dict[str, Any]  # field name -> resolved annotation (with extras)


REGISTRY: dict[str, Schema] = {}


def register(name: str, version: int = 1):
    """Class decorator: add a dataclass to the codec registry under ``name`` (refuses duplicates)."""

    def deco(cls):
        if name in REGISTRY:
            raise ValueError(f"message type {name!r} registered twice")
        hints = typing.get_type_hints(cls, include_extras=True)
        REGISTRY[name] = Schema(cls, version, {f.name: hints[f.name] for f in dataclasses.fields(cls)})
        cls._msg_name = name
        cls._msg_version = version
        return cls

    return deco


def empty_f32() -> np.ndarray:
    return np.zeros(0, np.float32)


def msg_equal(a: Any, b: Any) -> bool:
    """Deep equality that understands numpy arrays (NaN equal to NaN)."""
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        if not (isinstance(a, np.ndarray) and isinstance(b, np.ndarray)):
            return False
        return a.dtype == b.dtype and a.shape == b.shape and np.array_equal(a, b, equal_nan=a.dtype.kind == "f")
    if dataclasses.is_dataclass(a) and not isinstance(a, type):
        return type(a) is type(b) and all(
            msg_equal(getattr(a, f.name), getattr(b, f.name)) for f in dataclasses.fields(a)
        )
    if isinstance(a, (tuple, list)):
        return isinstance(b, (tuple, list)) and len(a) == len(b) and all(map(msg_equal, a, b))
    if isinstance(a, float) and isinstance(b, float) and a != a and b != b:
        return True
    return a == b
