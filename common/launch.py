"""Launch files for the zenav agents: one YAML -> an ordered list of ``common.node_spec.NodeSpec``.

Layout (sections depend on the agent: robot = platform / transforms / sensors, master = nodes)::

    robot: pioneer1              # optional; --robot and $ZENAV_ROBOT win
    use_sim_time: true           # exports ZENAV_USE_SIM_TIME=1 to every node
    env: {SOME_VAR: "1"}         # extra environment for every node
    supervisor: {grace: 3.0, crash_loop_deaths: 5, crash_loop_window: 10.0, status: true}
    sensors:
      depth_to_scan:             # node name (letters, digits, _ and -)
        module: robot_side.depth.depth_to_scan_node   # or cmd: [prog, arg, ...]
        params: {range_max: 6.0}                      # the node's own mapping (or config: FILE, section: KEY)
        respawn: true
        wait_for: [camera/depth/image_raw]
        after: [sim]

A node's parameters reach it as ``--config FILE --section KEY``: the launch file itself when the
mapping is a part of it (so a node's ConfigError names the user's file and key), otherwise a
generated YAML (CLI overrides, transforms written as a plain string).
"""

from __future__ import annotations

import copy
import os
import re
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from common.config import ConfigError, load_params, param, read_yaml
from common.node_spec import NodeSpec, validate_launch

NAME_RE = re.compile(r"^[A-Za-z0-9_-]+$")
_NUMBER_RE = re.compile(r"^[+-]?(\d+\.?\d*|\.\d+)[eE][+-]?\d+$")
TOP_KEYS = ("robot", "use_sim_time", "env", "supervisor")


@dataclass(frozen=True)
class EntryParams:
    module: str = param("", doc="python module run as `python -m MODULE`")
    cmd: tuple[str, ...] | str = param((), doc="explicit command line instead of module")
    args: tuple[str, ...] | str = param((), doc="extra command-line arguments")
    params: dict | None = param(None, doc="the node's parameter mapping")
    config: str = param("", doc="external parameter file (relative to the launch file)")
    section: str = param("", doc="key of the node's mapping inside `config`")
    env: dict | None = param(None, doc="extra environment variables")
    respawn: bool = param(False, doc="restart the node when its process ends")
    respawn_delay: float = param(0.2, lo=0.0, hi=60.0, unit="s")
    required: bool = param(False, doc="the launch stops when this node ends or fails")
    wait_for: tuple[str, ...] | str = param((), doc="topics that must carry a message before the start")
    wait_timeout: float = param(30.0, lo=0.0, unit="s", doc="then FAILED")
    after: tuple[str, ...] | str = param((), doc="nodes that must be running first")
    stop_first: bool | None = param(None, doc="stopped (and waited for) before all other nodes")
    enabled: bool = param(True, doc="false = skip this node")


@dataclass(frozen=True)
class SupervisorParams:
    grace: float = param(3.0, lo=0.1, hi=60.0, unit="s", doc="SIGTERM -> SIGKILL delay at shutdown")
    crash_loop_deaths: int = param(5, lo=1, hi=1000, doc="more deaths than this within the window -> FAILED")
    crash_loop_window: float = param(10.0, lo=0.1, hi=3600.0, unit="s")
    max_respawn_delay: float = param(5.0, lo=0.0, hi=600.0, unit="s", doc="cap of the doubling respawn delay")
    status: bool = param(True, doc="print the node table on stderr on every change")


@dataclass(frozen=True)
class Section:
    """How an agent reads one section: defaults for its entries, and the transforms shorthand."""
    name: str
    default_module: str = ""
    stop_first: bool = False
    tf_args: bool = False       # entries are `args: "x y z ..."` for common.static_tf_node


@dataclass
class Entry:
    name: str
    key: str                     # dotted path in the launch file, e.g. "sensors.laser"
    opts: EntryParams
    params: dict | None          # mapping to hand to the node (None = none / external file)
    params_key: str = ""         # dotted path of `params` in the launch file ('' = must be generated)
    stop_first: bool = False


@dataclass
class Launch:
    source: str
    robot: str | None
    use_sim_time: bool
    env: dict[str, str]
    supervisor: SupervisorParams
    entries: list[Entry] = field(default_factory=list)
    generated_dir: str = ""      # temp dir made by specs() for generated parameters ('' = none)

    def entry(self, name: str) -> Entry:
        return next(e for e in self.entries if e.name == name)

    def node_params(self, e: Entry) -> tuple[dict, str]:
        """A node's parameter mapping and the file it comes from (paths in it are relative to that file):
        its ``params:`` in this launch file, its ``config:`` file (``section:`` of it), or none."""
        if e.params is not None:
            return e.params, str(Path(self.source).resolve())
        if e.opts.config:
            from common.runner import node_config
            return node_config(self._path(e.opts.config), e.opts.section or None)
        return {}, "<defaults>"

    def override(self, name: str, **values: Any) -> None:
        """Change parameters of one node (CLI options); its mapping is then generated. The generated file
        lives elsewhere, so the node's other values that name a file relative to its source (``move_base:
        p3at/move_base.yaml``) are made absolute first."""
        e = self.entry(name)
        if e.params_key or (e.params is None and e.opts.config):
            mapping, source = self.node_params(e)
            e.params = absolute_paths(copy.deepcopy(mapping), Path(source).parent)
        e.params = {**(e.params or {}), **values}
        e.params_key = ""

    def set(self, assignment: str) -> None:
        """Apply one ``NODE.KEY=VALUE`` (``zenav master --set``, ``zenav robot --set``), or
        ``NODE.SECTION.KEY=VALUE`` for a key of a nested mapping; VALUE is read as YAML (``3``, ``1e-3``,
        ``true``, ``[1, 2]``); a file named relative to this directory, or else to the node's own parameter
        file, is made absolute (the node reads a generated copy elsewhere)."""
        target, sep, text = assignment.partition("=")
        name, dot, key = target.strip().partition(".")
        if not sep or not dot or not name or not key:
            raise ConfigError("--set", assignment, "expected NODE.KEY=VALUE, e.g. map_server.map=office.yaml")
        e = next((x for x in self.entries if x.name == name), None)
        if e is None:
            raise ConfigError("--set", assignment,
                              f"no node {name!r} in {self.source} (nodes: {', '.join(x.name for x in self.entries)})")
        if e.opts.cmd:
            raise ConfigError("--set", assignment, f"node {name!r} is a cmd: node; parameters only apply to "
                              "module nodes")
        try:
            value = yaml.safe_load(text) if text.strip() else ""
        except yaml.YAMLError as err:
            raise ConfigError("--set", assignment, f"value is not valid YAML: {err}") from None
        if isinstance(value, str) and _NUMBER_RE.match(value):  # YAML 1.1 reads 1e-3 as a string
            value = float(value)
        if isinstance(value, str) and os.path.isfile(value):
            value = os.path.abspath(value)
        mapping, source = self.node_params(e)
        top, *inner = parts = key.split(".")
        if not all(parts):
            raise ConfigError("--set", assignment, "an empty key in the path, e.g. sim.base.odom_frame_id=odom")
        values = absolute_paths({parts[-1]: value}, Path(source).parent)  # else beside its file
        if inner:  # NODE.SECTION.KEY: one key of a nested mapping, the section's other keys kept
            section = copy.deepcopy(mapping)
            leaf, path = section, name
            for k in parts[:-1]:
                path += f".{k}"
                if k not in leaf:
                    leaf[k] = {}
                elif not isinstance(leaf[k], dict):  # null switches a sensor off: --set does not switch it on
                    raise ConfigError("--set", assignment, f"{path} is {leaf[k]!r}, not a mapping of parameters")
                leaf = leaf[k]
            leaf.update(values)
            values = {top: section[top]}
        self.override(name, **values)

    def _path(self, p: str) -> str:
        return str((Path(self.source).parent / p).resolve()) if p and not os.path.isabs(p) else p

    def specs(self, gen_dir: str | None = None) -> list[NodeSpec]:
        """NodeSpecs in file order; a generated parameter file goes to ``gen_dir`` (a temp dir if None)."""
        generated = {e.name: e.params for e in self.entries if e.params is not None and not e.params_key}
        gen_file = ""
        if generated:
            if gen_dir is None:
                gen_dir = self.generated_dir = tempfile.mkdtemp(prefix="zenav-launch-")
            os.makedirs(gen_dir, exist_ok=True)
            gen_file = str(Path(gen_dir) / f"generated-{Path(self.source).stem}.yaml")
            with open(gen_file, "w") as f:
                f.write(f"# generated by the zenav agent from {self.source}\n")
                yaml.safe_dump(generated, f, sort_keys=False)
        out = []
        for e in self.entries:
            o = e.opts
            if e.params is not None:
                in_file = (str(Path(self.source).resolve()), e.params_key)
                cfg, section = in_file if e.params_key else (gen_file, e.name)
            else:
                cfg, section = self._path(o.config), o.section
            out.append(NodeSpec(
                name=e.name, module=o.module, cmd=_words(o.cmd), args=_words(o.args), config=cfg,
                section=section, env={str(k): str(v) for k, v in (o.env or {}).items()},
                respawn=o.respawn, respawn_delay=o.respawn_delay, required=o.required,
                wait_for=_words(o.wait_for), wait_timeout=o.wait_timeout, after=_words(o.after),
                stop_first=e.stop_first))
        return out


def absolute_paths(params: dict, base: Path) -> dict:
    """``params`` with every string value that names an existing file relative to ``base`` made absolute."""
    for k, v in params.items():
        if isinstance(v, str) and v and not os.path.isabs(v) and os.path.isfile(base / v):
            params[k] = str((base / v).resolve())
    return params


def _words(v: tuple | str) -> tuple[str, ...]:
    return tuple(v.split()) if isinstance(v, str) else tuple(str(x) for x in v)


def _entry(sec: Section, name: Any, raw: Any, source: str) -> Entry | None:
    key = f"{sec.name}.{name}"
    if not isinstance(name, str) or not NAME_RE.match(name):
        raise ConfigError(source, key, "node names use only letters, digits, '_' and '-'")
    params_key = ""
    if sec.tf_args:
        in_file = isinstance(raw, dict)        # {args: ...} alone can be read from the file itself
        if isinstance(raw, (str, list)):
            raw = {"args": raw}
        if not isinstance(raw, dict) or "args" not in raw:
            raise ConfigError(source, key, 'expected a transform: args: "x y z yaw pitch roll parent child"')
        raw = dict(raw)
        tf = {"args": raw.pop("args")}
        params_key = key if in_file and not raw else ""
        raw = {"module": sec.default_module, **raw, "params": tf}
    if not isinstance(raw, dict):
        raise ConfigError(source, key, "expected a mapping (module, params, respawn, ...)")
    if sec.default_module and "cmd" not in raw:
        raw = {"module": sec.default_module, **raw}
    opts = load_params(EntryParams, raw, source=source, section=key)
    if not opts.enabled:
        return None
    if bool(opts.module) == bool(opts.cmd):
        raise ConfigError(source, key, "give exactly one of 'module' or 'cmd'")
    if opts.params is not None and opts.config:
        raise ConfigError(source, key, "give either 'params' or 'config', not both")
    if opts.section and not opts.config:
        raise ConfigError(source, f"{key}.section", "'section' needs 'config'")
    if opts.cmd and (opts.params is not None or opts.config):
        raise ConfigError(source, key, "'params' / 'config' only apply to module nodes")
    if opts.params is not None and not params_key and not sec.tf_args:
        params_key = f"{key}.params"
    stop_first = sec.stop_first if opts.stop_first is None else opts.stop_first
    return Entry(name, key, opts, opts.params, params_key, stop_first)


def load_launch(path: str | Path, sections: list[Section]) -> Launch:
    """Read and validate a launch file; raises ConfigError naming the file and the key."""
    source = str(path)
    data = read_yaml(path)
    known = {s.name: s for s in sections}
    for k in data:
        if k not in known and k not in TOP_KEYS:
            raise ConfigError(source, str(k), f"unknown section (known: {', '.join([*TOP_KEYS, *known])})")
    robot = data.get("robot")
    if robot is not None and (not isinstance(robot, str) or not robot or set(robot) & set("/* ")):
        raise ConfigError(source, "robot", f"expected a robot name without '/', '*' or spaces, got {robot!r}")
    ust = data.get("use_sim_time", False)
    if not isinstance(ust, bool):
        raise ConfigError(source, "use_sim_time", f"expected true or false, got {ust!r}")
    env = data.get("env") or {}
    if not isinstance(env, dict):
        raise ConfigError(source, "env", "expected a mapping of variable -> value")
    sup = load_params(SupervisorParams, data.get("supervisor") or {}, source=source, section="supervisor")
    launch = Launch(source, robot, ust, {str(k): str(v) for k, v in env.items()}, sup)
    for sec in sections:
        body = data.get(sec.name)
        if body is None:
            continue
        if not isinstance(body, dict):
            raise ConfigError(source, sec.name, "expected a mapping of node name -> node")
        for name, raw in body.items():
            e = _entry(sec, name, raw, source)
            if e is not None:
                launch.entries.append(e)
    if not launch.entries:
        raise ConfigError(source, "<file>", f"no nodes (sections: {', '.join(known)})")
    names = {e.name for e in launch.entries}
    for e in launch.entries:
        for a in _words(e.opts.after):
            if a not in names:
                raise ConfigError(source, f"{e.key}.after", f"unknown node {a!r} (nodes: {', '.join(names)})")
    try:
        validate_launch(_dry_specs(launch))
    except ValueError as err:
        raise ConfigError(source, "<nodes>", str(err)) from err
    return launch


def _dry_specs(launch: Launch) -> list[NodeSpec]:
    return [NodeSpec(name=e.name, module=e.opts.module, cmd=_words(e.opts.cmd), after=_words(e.opts.after))
            for e in launch.entries]
