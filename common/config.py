"""Parameters: one frozen dataclass per component, loaded from YAML keyed by the ROS names.

Declare fields with ``param``::

    @dataclass(frozen=True)
    class InflationParams:
        inflation_radius: float = param(0.55, lo=0.0, hi=50.0, unit="m", doc="how far cost spreads")
        cost_scaling_factor: float = param(10.0, lo=0.0, doc="exponential decay rate")

``load_params(InflationParams, mapping, source="costmap.yaml", section="inflater")`` returns an
instance or raises ``ConfigError`` naming the file, the key and what is allowed.
"""

from __future__ import annotations

import dataclasses
import math
import typing
from pathlib import Path
from typing import Any

import yaml


class ConfigError(ValueError):
    """A configuration value that is unknown, of the wrong type or out of range."""

    def __init__(self, source: str, key: str, message: str):
        self.source, self.key = source, key
        super().__init__(f"{source}: {key}: {message}")


def param(default: Any = dataclasses.MISSING, *, lo: float | None = None, hi: float | None = None,
          choices: tuple | None = None, unit: str = "", doc: str = "", aliases: tuple[str, ...] = (),
          default_factory: Any = dataclasses.MISSING) -> Any:
    """A dataclass field with a declared range / choices, unit, description and accepted aliases."""
    meta = {"lo": lo, "hi": hi, "choices": choices, "unit": unit, "doc": doc, "aliases": tuple(aliases)}
    if default_factory is not dataclasses.MISSING:
        return dataclasses.field(default_factory=default_factory, metadata=meta)
    return dataclasses.field(default=default, metadata=meta)


def _allowed(f: dataclasses.Field) -> str:
    m = f.metadata
    if m.get("choices"):
        return f"one of {list(m['choices'])}"
    lo, hi = m.get("lo"), m.get("hi")
    unit = f" {m['unit']}" if m.get("unit") else ""
    if lo is not None and hi is not None:
        return f"in [{lo}, {hi}]{unit}"
    if lo is not None:
        return f">= {lo}{unit}"
    if hi is not None:
        return f"<= {hi}{unit}"
    return "any value"


def _coerce(ann: Any, value: Any, source: str, key: str) -> Any:
    origin = typing.get_origin(ann)
    if origin in (typing.Union, getattr(__import__("types"), "UnionType", None)):
        args = typing.get_args(ann)
        if value is None and type(None) in args:
            return None
        errors = []
        for a in args:
            if a is type(None):
                continue
            try:
                return _coerce(a, value, source, key)
            except ConfigError as e:
                errors.append(str(e))
        raise ConfigError(source, key, f"value {value!r} has the wrong type ({ann})")
    if ann is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ConfigError(source, key, f"expected a number, got {value!r}")
        return float(value)
    if ann is int:
        if isinstance(value, float) and value.is_integer():
            return int(value)
        if isinstance(value, bool) or not isinstance(value, int):
            raise ConfigError(source, key, f"expected an integer, got {value!r}")
        return value
    if ann is bool:
        if not isinstance(value, bool):
            raise ConfigError(source, key, f"expected true or false, got {value!r}")
        return value
    if ann is str:
        if not isinstance(value, (str, int, float)) or isinstance(value, bool):
            raise ConfigError(source, key, f"expected a string, got {value!r}")
        return str(value)
    if origin is tuple:
        if not isinstance(value, (list, tuple)):
            raise ConfigError(source, key, f"expected a list, got {value!r}")
        args = typing.get_args(ann)
        if len(args) == 2 and args[1] is Ellipsis:
            return tuple(_coerce(args[0], v, source, f"{key}[{i}]") for i, v in enumerate(value))
        if len(args) != len(value):
            raise ConfigError(source, key, f"expected {len(args)} items, got {len(value)}")
        return tuple(_coerce(a, v, source, f"{key}[{i}]") for i, (a, v) in enumerate(zip(args, value)))
    if ann is Any or ann is object:
        return value
    if origin is dict or ann is dict:
        if not isinstance(value, dict):
            raise ConfigError(source, key, f"expected a mapping, got {value!r}")
        return value
    return value


def load_params(cls: type, data: dict | None, source: str = "<config>", section: str = "",
                ignore: tuple[str, ...] = ()) -> Any:
    """Build ``cls`` from ``data``; unknown keys (not in ``ignore``) and bad values raise ConfigError."""
    data = dict(data or {})
    hints = typing.get_type_hints(cls)
    by_name: dict[str, dataclasses.Field] = {}
    for f in dataclasses.fields(cls):
        by_name[f.name] = f
        for a in f.metadata.get("aliases", ()):
            by_name[a] = f
    kwargs: dict[str, Any] = {}
    prefix = f"{section}." if section else ""
    for key, value in data.items():
        k = str(key)
        if k in ignore:
            continue
        f = by_name.get(k)
        if f is None:
            known = sorted(x for x in by_name if not x.startswith("_"))
            raise ConfigError(source, prefix + k, f"unknown key (known keys: {', '.join(known)})")
        v = _coerce(hints[f.name], value, source, prefix + k)
        m = f.metadata
        if m.get("choices") and v not in m["choices"]:
            raise ConfigError(source, prefix + k, f"{v!r} is not allowed; must be {_allowed(f)}")
        if isinstance(v, (int, float)) and not isinstance(v, bool):
            if isinstance(v, float) and math.isnan(v):
                raise ConfigError(source, prefix + k, "NaN is not allowed")
            lo, hi = m.get("lo"), m.get("hi")
            if (lo is not None and v < lo) or (hi is not None and v > hi):
                raise ConfigError(source, prefix + k, f"{v} is out of range; must be {_allowed(f)}")
        kwargs[f.name] = v
    try:
        obj = cls(**kwargs)
    except (TypeError, ValueError) as e:
        raise ConfigError(source, section or cls.__name__, str(e)) from e
    check = getattr(obj, "validate", None)
    if check is not None:
        try:
            check()
        except ValueError as e:
            raise ConfigError(source, section or cls.__name__, str(e)) from e
    return obj


def read_yaml(path: str | Path) -> dict:
    """Read a YAML mapping; an empty file is ``{}``; a non-mapping or a syntax error raises ConfigError."""
    p = Path(path)
    try:
        text = p.read_text()
    except OSError as e:
        raise ConfigError(str(p), "<file>", f"cannot read: {e.strerror}") from e
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as e:
        raise ConfigError(str(p), "<file>", f"invalid YAML: {e}") from e
    if data is None:
        return {}
    if not isinstance(data, dict):
        raise ConfigError(str(p), "<file>", "top level must be a mapping")
    return data


def strip_frame(name: str) -> str:
    """ROS tf2 frame ids carry no leading slash: '/map' -> 'map'."""
    return name.lstrip("/")


def describe(cls: type) -> str:
    """A table of the parameters of ``cls`` (name, default, allowed, doc) for --help output."""
    rows = []
    for f in dataclasses.fields(cls):
        d = f.default if f.default is not dataclasses.MISSING else "(computed)"
        rows.append(f"  {f.name:<28} {d!s:<12} {_allowed(f):<22} {f.metadata.get('doc', '')}")
    return "\n".join(rows)


def include(value: Any, source: str, key: str) -> tuple[dict, str]:
    """A config entry that is either an inline mapping or a path to a YAML file (relative to the
    file ``source``). Returns (mapping, file it came from)."""
    if value is None:
        return {}, source
    if isinstance(value, dict):
        return value, source
    if isinstance(value, str):
        p = Path(value).expanduser()
        if not p.is_absolute():
            p = Path(source).parent / p
        if not p.exists():
            raise ConfigError(source, key, f"file not found: {p}")
        return read_yaml(p), str(p)
    raise ConfigError(source, key, f"expected a mapping or a file path, got {value!r}")


def merge_included(cfg: dict, key: str, source: str) -> tuple[dict, str]:
    """``cfg`` with ``key: FILE`` (or an inline mapping) as its base and the other keys overriding it,
    plus the source to name in errors. Without ``key``, ``cfg`` and ``source`` unchanged."""
    if key not in cfg:
        return cfg, source
    base, src = include(cfg[key], source, key)
    return {**base, **{k: v for k, v in cfg.items() if k != key}}, f"{src} (+ overrides in {source})"
