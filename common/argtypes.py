"""argparse ``type=`` functions that refuse what a command could not use: NaN / Inf (a goal at
infinity, a duration that never ends), negative durations and rates, ports out of range. Each raises
``argparse.ArgumentTypeError``, so argparse prints ``argument --x: ...`` and exits 2."""

from __future__ import annotations

import argparse
import math


def finite(text: str) -> float:
    """A finite number."""
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not math.isfinite(v):
        raise argparse.ArgumentTypeError(f"{text!r} is not a finite number")
    return v


def positive(text: str) -> float:
    """A finite number > 0 (seconds, rates, speed factors)."""
    v = finite(text)
    if v <= 0:
        raise argparse.ArgumentTypeError(f"{text!r} must be > 0")
    return v


def nonneg(text: str) -> float:
    """A finite number >= 0 (0 usually means 'no limit')."""
    v = finite(text)
    if v < 0:
        raise argparse.ArgumentTypeError(f"{text!r} must be >= 0")
    return v


def _integer(text: str) -> int:
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None


def positive_int(text: str) -> int:
    v = _integer(text)
    if v <= 0:
        raise argparse.ArgumentTypeError(f"{text!r} must be > 0")
    return v


def nonneg_int(text: str) -> int:
    v = _integer(text)
    if v < 0:
        raise argparse.ArgumentTypeError(f"{text!r} must be >= 0")
    return v


def port(text: str) -> int:
    v = _integer(text)
    if not 1 <= v <= 65535:
        raise argparse.ArgumentTypeError(f"{text!r} is not a TCP port (1-65535)")
    return v
