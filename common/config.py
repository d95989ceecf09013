"""Parameters: one frozen dataclass per component, loaded from YAML keyed by the ROS names.

Declare fields with ``param``::

    @dataclass(frozen=True)
    class InflationParams:
        inflation_radius: float = param(0.55, lo=0.0, hi=50.0, unit="m", doc="how far cost spreads")
        cost_scaling_factor: float = param(10.0, lo=0.0, doc="exponential decay rate")

``load_params(InflationParams, mapping, source="costmap.yaml", section="inflater")`` returns an
instance or raises ONE ``ConfigError`` listing every problem of the mapping (unknown keys with a
did-you-mean, wrong types, out-of-range values), one ``file: key: why`` per line. Keys that ROS knows
but that have no effect in zenav are passed as ``no_effect={key: why}`` and reported as notes
(``Note``) instead of failing (``master_side.ros_params`` builds that mapping from the ROS catalogue).
``Problems`` collects the errors of several loads so that a loader reports them all at once.
"""

from __future__ import annotations

import dataclasses
import math
import os
import typing
from pathlib import Path
from typing import Any, Iterable, Mapping

import yaml

from common.config_errors import ConfigError, Note, Problem, Problems, suggest, unknown_key_message

__all__ = ["ConfigError", "Note", "Problem", "Problems", "suggest", "unknown_key_message", "param",
           "load_params", "read_yaml", "strip_frame", "describe", "include", "include_chain",
           "merge_included", "overlay"]


def param(default: Any = dataclasses.MISSING, *, lo: float | None = None, hi: float | None = None,
          choices: tuple | None = None, unit: str = "", doc: str = "", aliases: tuple[str, ...] = (),
          no_effect: bool = False, default_factory: Any = dataclasses.MISSING) -> Any:
    """A dataclass field with a declared range / choices, unit, description and accepted aliases.
    ``no_effect=True``: a ROS parameter accepted (and checked) but not used by zenav; load_params
    reports it in ``notes`` when a file sets it (the ``doc`` says why)."""
    meta = {"lo": lo, "hi": hi, "choices": choices, "unit": unit, "doc": doc, "aliases": tuple(aliases),
            "no_effect": no_effect}
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
                ignore: Iterable[str] = (), *, no_effect: Mapping[str, str] | None = None,
                notes: list[str] | None = None) -> Any:
    """Build ``cls`` from ``data``, or raise ONE ConfigError listing every problem of the mapping.

    ``ignore``: keys accepted silently (read by someone else). ``no_effect``: key -> why (text after
    the key, e.g. "no effect (not implemented in zenav)") for keys accepted without effect; they, and
    fields declared ``param(..., no_effect=True)``, are appended to ``notes`` (a list of ``Note``) when
    the mapping sets them. Unknown keys get a did-you-mean over every accepted name."""
    data = dict(data or {})
    hints = typing.get_type_hints(cls)
    by_name: dict[str, dataclasses.Field] = {}
    for f in dataclasses.fields(cls):
        by_name[f.name] = f
        for a in f.metadata.get("aliases", ()):
            by_name[a] = f
    ignore, no_effect = set(ignore), dict(no_effect or {})
    kwargs: dict[str, Any] = {}
    prefix = f"{section}." if section else ""
    problems: list[Problem] = []
    found: list[Note] = []
    for key, value in data.items():
        k = str(key)
        if k in ignore:
            continue
        f = by_name.get(k)
        if f is None:
            if k in no_effect:
                found.append(Note(source, prefix + k, no_effect[k]))
            else:
                problems.append((source, prefix + k, unknown_key_message(k, by_name, [*ignore, *no_effect])))
            continue
        try:
            kwargs[f.name] = _checked(f, hints[f.name], value, source, prefix + k)
        except ConfigError as e:
            problems.extend(e.problems)
            continue
        if f.metadata.get("no_effect"):
            why = f.metadata.get("doc", "").strip("() ")
            why = why[len("accepted"):].lstrip(";,: ") if why.startswith("accepted") else why
            found.append(Note(source, prefix + k, f"no effect ({why or 'not used by zenav'})"))
    if problems:
        raise ConfigError.of(problems)
    try:
        obj = cls(**kwargs)
        check = getattr(obj, "validate", None)
        if check is not None:
            check()
    except (TypeError, ValueError) as e:
        raise ConfigError(source, section or cls.__name__, str(e)) from e
    if notes is not None:
        notes.extend(found)
    return obj


def _checked(f: dataclasses.Field, ann: Any, value: Any, source: str, key: str) -> Any:
    """``value`` coerced to the field's type and checked against its choices / range."""
    v = _coerce(ann, value, source, key)
    m = f.metadata
    if m.get("choices") and v not in m["choices"]:
        raise ConfigError(source, key, f"{v!r} is not allowed; must be {_allowed(f)}")
    if isinstance(v, (int, float)) and not isinstance(v, bool):
        if isinstance(v, float) and math.isnan(v):
            raise ConfigError(source, key, "NaN is not allowed")
        lo, hi = m.get("lo"), m.get("hi")
        if (lo is not None and v < lo) or (hi is not None and v > hi):
            raise ConfigError(source, key, f"{v} is out of range; must be {_allowed(f)}")
    return v


def read_yaml(path: str | Path) -> dict:
    """Read a YAML mapping; an empty file is ``{}``; a non-mapping or a syntax error raises ConfigError."""
    p = Path(path)
    try:
        text = p.read_text()
    except OSError as e:
        raise ConfigError(str(p), "<file>", f"cannot read: {e.strerror}") from e
    except UnicodeDecodeError as e:
        why = f"not a text (UTF-8) file: byte {e.start} is 0x{e.object[e.start]:02x}"
        raise ConfigError(str(p), "<file>", why) from e
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as e:
        raise ConfigError(str(p), "<file>", f"invalid YAML: {e}") from e
    if data is None:
        return {}
    if not isinstance(data, dict):
        raise ConfigError(str(p), "<file>", "top level must be a mapping")
    return data


def load_params_file(cls: type, path: str | Path | None, section: str = "", overrides: Mapping | None = None,
                     **kw) -> Any:
    """``load_params`` of ``cls`` from a YAML file's ``section`` (the whole file without one; defaults
    without a file), ``overrides`` winning over the file; ``kw`` as for ``load_params``."""
    data: dict = {}
    if path is not None:
        data = read_yaml(path)
        if section:
            data = data.get(section, {}) or {}
    data.update(overrides or {})
    return load_params(cls, data, source=str(path or "<defaults>"), section=section, **kw)


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


def overlay(base: dict, over: dict) -> dict:
    """``over``'s keys over ``base``'s; where both hold a mapping under a key, merged key by key (one level:
    a fleet host's section over the defaults, a recovery's namespace over an included move_base file's)."""
    out = dict(base)
    for k, v in over.items():
        out[k] = {**out[k], **v} if isinstance(v, dict) and isinstance(out.get(k), dict) else v
    return out


def include_chain(cfg: dict, source: str, section: str = "", merge=overlay, limit: int = 8) -> tuple[dict, str]:
    """zenav's ``include: FILE`` in a file (or in its ``section``, e.g. a planner file's ``DWAPlannerROS``):
    that file's mapping (its ``section`` if it has one) as the base, ``cfg``'s other keys ``merge``d over it;
    the base may include another in turn, its path relative to the file that names it. Returns the mapping
    and the source to name in errors. A file included twice in one chain (a loop) or a chain of more than
    ``limit`` files is refused."""
    chain = [os.path.normpath(source)]
    key = f"{section}.include" if section else "include"
    while "include" in cfg:
        cfg = dict(cfg)
        base, src = include(cfg.pop("include"), chain[-1], key)
        src = os.path.normpath(src)
        if src in chain:
            raise ConfigError(chain[-1], key, f"{src} is already in this chain of includes: "
                              + " -> ".join([*chain, src]))
        if len(chain) > limit:
            raise ConfigError(chain[-1], key, f"more than {limit} files in one chain of includes")
        base = dict(base.get(section, base) or {}) if section else base
        cfg = merge(base, cfg)
        chain.append(src)
    if len(chain) == 1:
        return cfg, source
    chain[0] = source
    return cfg, f"{chain[-1]} (+ overrides in {', then '.join(reversed(chain[:-1]))})"


def merge_included(cfg: dict, key: str, source: str) -> tuple[dict, str]:
    """``cfg`` with ``key: FILE`` (or an inline mapping) as its base and the other keys overriding it,
    plus the source to name in errors. Without ``key``, ``cfg`` and ``source`` unchanged."""
    if key not in cfg:
        return cfg, source
    base, src = include(cfg[key], source, key)
    return {**base, **{k: v for k, v in cfg.items() if k != key}}, f"{src} (+ overrides in {source})"
