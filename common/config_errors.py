"""Configuration problems: ``ConfigError`` (every problem of a load, one ``file: key: why`` per line),
``Problems`` (collects them over several loads), ``Note`` (an accepted parameter without effect) and the
did-you-mean for unknown keys. Re-exported by ``common.config``."""

from __future__ import annotations

import contextlib
import difflib
from typing import Iterable, Iterator

Problem = tuple[str, str, str]  # (source, key, why)


class ConfigError(ValueError):
    """Configuration values that are unknown, of the wrong type or out of range.

    ``problems`` lists every (source, key, why); ``source`` / ``key`` are those of the first one and
    ``str(e)`` is all of them, one ``source: key: why`` per line."""

    def __init__(self, source: str, key: str, message: str, *, problems: Iterable[Problem] | None = None):
        self.problems: list[Problem] = [(p[0], p[1], p[2]) for p in problems or ()] or [(source, key, message)]
        self.source, self.key, self.message = self.problems[0]
        super().__init__("\n".join(f"{s}: {k}: {m}" for s, k, m in self.problems))

    @classmethod
    def of(cls, problems: Iterable[Problem]) -> ConfigError:
        """One error listing ``problems`` (at least one)."""
        items = list(problems)
        return cls(*items[0], problems=items)


class Problems:
    """Collects the problems of several loads, so that one ConfigError reports them all::

        problems = Problems()
        with problems.collect():
            a = load_params(A, ...)      # on error ``a`` stays unset: check ``problems`` before using it
        with problems.collect():
            b = load_params(B, ...)
        problems.raise_if_any()
    """

    def __init__(self) -> None:
        self.items: list[Problem] = []

    def add(self, source: str, key: str, message: str) -> None:
        self.items.append((source, key, message))

    @contextlib.contextmanager
    def collect(self) -> Iterator[None]:
        try:
            yield
        except ConfigError as e:
            self.items.extend(e.problems)

    def raise_if_any(self) -> None:
        if self.items:
            raise ConfigError.of(self.items)

    def __bool__(self) -> bool:
        return bool(self.items)


class Note(str):
    """A parameter that is accepted but has no effect: ``str`` is ``source: key: why``."""

    source: str
    key: str
    why: str

    def __new__(cls, source: str, key: str, why: str) -> Note:
        s = super().__new__(cls, f"{source}: {key}: {why}")
        s.source, s.key, s.why = source, key, why
        return s


def suggest(key: str, known: Iterable[str]) -> str:
    """'; did you mean 'x'?' for the closest names in ``known`` (difflib), or ''."""
    close = difflib.get_close_matches(key, sorted(set(known)), n=3, cutoff=0.6)
    return f"; did you mean {' or '.join(repr(c) for c in close)}?" if close else ""


def unknown_key_message(key: str, known: Iterable[str], more: Iterable[str] = (), list_max: int = 40) -> str:
    """'unknown key' with a did-you-mean over ``known`` (then over ``more``: names accepted elsewhere),
    else with the ``known`` keys when they are few."""
    known = sorted(x for x in set(known) if not x.startswith("_"))
    hint = suggest(key, known) or suggest(key, more)
    if hint:
        return "unknown key" + hint
    if len(known) <= list_max:
        return f"unknown key (known keys: {', '.join(known)})"
    return f"unknown key (none of the {len(known)} known keys is close)"
