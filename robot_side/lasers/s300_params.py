"""SICK S300 parameters: the cob_sick_s300 names, the measurement fields, checked all at once."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

from common.config import ConfigError, load_params, param


@dataclass(frozen=True)
class S300Field:
    """One measurement field (ROS ``fields: {N: {scale, start_angle, stop_angle}}``)."""

    scale: float = 0.01  # m per distance unit (cm)
    start_angle: float = -math.radians(135.0)  # rad, angle of the first value
    stop_angle: float = math.radians(135.0)  # rad, angle of the last value


def _default_fields() -> dict:
    return {1: S300Field()}


@dataclass(frozen=True)
class S300Params:
    """cob_sick_s300 parameters (ROS names) plus ``topic``, ``range_min`` / ``range_max`` and the cut."""

    port: str = param("/dev/ttyUSB0", doc="serial device (RS-422 adapter) or a pyserial URL")
    baud: int = param(500000, choices=(9600, 19200, 38400, 115200, 500000), doc="the S300's RS-422 rate")
    scan_id: int = param(7, lo=0, hi=255, doc="device address of the scanner to read (7; 8 = slave)")
    inverted: bool = param(False, doc="scanner mounted upside down: beams reversed")
    frame_id: str = param("laser", doc="frame of the scan")
    scan_duration: float = param(0.025, lo=0.0, hi=1.0, unit="s", doc="time to sweep the beams")
    scan_cycle_time: float = param(0.040, lo=0.001, hi=10.0, unit="s", doc="time between scans")
    debug: bool = param(False, doc="log every telegram header and every dropped telegram")
    communication_timeout: float = param(0.2, lo=0.01, hi=60.0, unit="s",
                                         doc="no telegram for this long: warn (the scan stops)")
    fields: dict = param(default_factory=_default_fields,
                         doc="measurement field number -> {scale (m/unit), start_angle, stop_angle (rad)}")
    topic: str = param("scan", doc="bus topic of the LaserScan")
    range_min: float = param(0.05, lo=0.0, hi=10.0, unit="m", doc="closer returns are published as -inf")
    range_max: float = param(30.0, lo=0.1, hi=81.91, unit="m", doc="returns at or beyond it are +inf")
    angle_min: float | None = param(None, lo=-math.pi, hi=math.pi, unit="rad", doc="cut: first beam kept")
    angle_max: float | None = param(None, lo=-math.pi, hi=math.pi, unit="rad", doc="cut: last beam kept")


def load(cfg: dict | None, source: str = "<config>") -> S300Params:
    """S300Params from a node's YAML mapping; every problem (fields included) in one ConfigError."""
    problems: list[tuple[str, str, str]] = []
    try:
        p = load_params(S300Params, cfg, source)
    except ConfigError as e:
        p = None
        problems += e.problems
    fields: dict[int, S300Field] = {}
    raw = (cfg or {}).get("fields")
    for key, spec in (raw.items() if isinstance(raw, dict) else ()):
        k = f"fields.{key}"
        try:
            num = int(key)
        except (TypeError, ValueError):
            num = 0
        if not 1 <= num <= 5:
            problems.append((source, k, "a measurement field number is 1 .. 5"))
            continue
        if not isinstance(spec, dict):
            problems.append((source, k, "expected a mapping {scale, start_angle, stop_angle}"))
            continue
        bad = [x for x in spec if x not in ("scale", "start_angle", "stop_angle")]
        problems += [(source, f"{k}.{x}", "unknown key; expected scale, start_angle, stop_angle") for x in bad]
        vals = {}
        for name in ("scale", "start_angle", "stop_angle"):
            v = spec.get(name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                problems.append((source, f"{k}.{name}", f"missing or not a number: {v!r}"))
            else:
                vals[name] = float(v)
        if vals.get("scale", 1.0) <= 0:
            problems.append((source, f"{k}.scale", "must be > 0"))
        elif len(vals) == 3 and vals["stop_angle"] <= vals["start_angle"]:
            problems.append((source, f"{k}.stop_angle", "must be greater than start_angle"))
        elif len(vals) == 3:
            fields[num] = S300Field(**vals)
    if raw is not None and not fields and not problems:
        problems.append((source, "fields", "at least one field is needed"))
    if p is not None and p.range_max <= p.range_min:
        problems.append((source, "range_max", "must be greater than range_min"))
    if p is not None and None not in (p.angle_min, p.angle_max) and p.angle_max <= p.angle_min:
        problems.append((source, "angle_max", "must be greater than angle_min"))
    if problems or p is None:
        raise ConfigError.of(problems)
    return dataclasses.replace(p, fields=fields or _default_fields())
