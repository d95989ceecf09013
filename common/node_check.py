"""The agents' parameter check before anything starts.

A node module MAY define ``check(cfg: dict, source: str) -> list[str]``: it loads and validates the
node's parameters as ``start`` would, without opening the bus, raises ``ConfigError`` (every problem)
and returns the notes of parameters accepted with no effect. ``check_nodes`` imports the module of each
``module:`` entry of a launch and calls its ``check``; all problems of all nodes become one ConfigError
(the agent exits 2 and starts nothing), and the notes are printed once, grouped per node.
"""

from __future__ import annotations

import importlib
import os
from pathlib import Path
from typing import TYPE_CHECKING

from common.config import ConfigError, Note, Problems

if TYPE_CHECKING:
    from common.launch import Entry, Launch


def check_nodes(launch: Launch) -> dict[str, list[str]]:
    """node name -> its no-effect notes. Raises one ConfigError with every problem of every node
    (a problem in the launch file itself is keyed by its dotted path there)."""
    problems, notes = Problems(), {}
    for e in launch.entries:
        if not e.opts.module:
            continue
        with problems.collect():
            found = _check_entry(launch, e)
            notes[e.name] = [_rekey(launch, e, n) for n in found or ()]
    if problems:
        raise ConfigError.of(list(dict.fromkeys(problems.items)))
    return notes


def _check_entry(launch: Launch, e: Entry) -> list[str]:
    try:
        module = importlib.import_module(e.opts.module)
    except Exception as err:  # noqa: BLE001 - ImportError or an error while importing: the node cannot start
        raise ConfigError(launch.source, f"{e.key}.module", f"cannot import {e.opts.module!r}: {err}") from None
    check = getattr(module, "check", None)
    if check is None:
        return []
    cfg, source = launch.node_params(e)
    try:
        found = check(cfg, source)
    except ConfigError as err:
        raise ConfigError.of([(s, _key(launch, e, s, k), m) for s, k, m in err.problems]) from None
    except Exception as err:  # noqa: BLE001 - a check that crashes is a problem of this node's config
        raise ConfigError(source, e.key, f"parameter check failed: {type(err).__name__}: {err}") from None
    return list(found or ())


def _in_file(launch: Launch) -> str:
    return str(Path(launch.source).resolve())


def _key(launch: Launch, e: Entry, source: str, key: str) -> str:
    """A key of a node's mapping that lives in the launch file, as its dotted path there."""
    if e.params is not None and e.params_key and source == _in_file(launch):
        return f"{e.params_key}.{key}" if key else e.params_key
    return key


def _rekey(launch: Launch, e: Entry, note: str) -> str:
    if isinstance(note, Note):
        return Note(note.source, _key(launch, e, note.source, note.key), note.why)
    prefix = _in_file(launch) + ": "
    if e.params_key and note.startswith(prefix):
        return prefix + f"{e.params_key}." + note[len(prefix):]
    return note


def short_path(text: str) -> str:
    """Paths under the current directory shown relative to it."""
    cwd = os.getcwd().rstrip("/") + "/"
    return text.replace(cwd, "")


def format_config_error(agent: str, e: ConfigError) -> str:
    if len(e.problems) == 1:
        return f"zenav {agent}: config error: {short_path(str(e))}"
    lines = [f"zenav {agent}: config error ({len(e.problems)} problems; nothing started):"]
    return "\n".join(lines + [f"  {short_path(f'{s}: {k}: {m}')}" for s, k, m in e.problems])


def format_notes(agent: str, notes: dict[str, list[str]]) -> str:
    """One warning block ('' if nothing to say): per node, per file, the parameters accepted with no
    effect and why (keys with the same reason on one line)."""
    total = sum(len(v) for v in notes.values())
    if not total:
        return ""
    lines = [f"zenav {agent}: warning: {total} parameter{'s' * (total > 1)} accepted with no effect:"]
    for node, found in notes.items():
        if not found:
            continue
        lines.append(f"  {node}:")
        by_file: dict[str, dict[str, list[str]]] = {}
        for n in found:
            if isinstance(n, Note):
                by_file.setdefault(n.source, {}).setdefault(n.why, []).append(n.key)
            else:
                by_file.setdefault("", {}).setdefault(str(n), [])
        for file, whys in by_file.items():
            if file:
                lines.append(f"    {short_path(file)}:")
                lines += [f"      {', '.join(keys)}: {why}" for why, keys in whys.items()]
            else:
                lines += [f"    {short_path(text)}" for text in whys]
    return "\n".join(lines)
