"""The fleet inventory (``fleet.yaml``): hosts, their role, robot, zenav config, SSH and Zenoh settings.

Loaded into frozen dataclasses and validated at once: every problem is reported as ``file: key: why``
(``common.config_errors.ConfigError``). ``defaults:`` is merged under every host (a host's own keys
win; ``ssh:`` / ``zenoh:`` are merged key by key). Relative file paths (SSH key, password / TLS files,
``security.secrets_dir``) are relative to the inventory file; ``config`` is relative to the checkout.
See deploy/hosts/fleet.example.yaml and docs/fleet.md.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from common.config import overlay
from common.config_errors import ConfigError, Problems, suggest

ROLES = ("robot", "master", "router")
MODES = ("peer", "client", "router")
MANAGERS = ("auto", "systemd", "supervisor")
NAME_RE = re.compile(r"^[A-Za-z0-9_.-]+$")
HOST_KEYS = ("address", "role", "robot", "config", "args", "ssh", "install_dir", "python", "service_manager",
             "service_user", "sysroot", "zenoh", "labels", "expect_topics", "clock_cmd", "udev_adapter", "pip_args",
             "install_mode")
SSH_KEYS = ("user", "port", "key", "options")
ZENOH_KEYS = ("mode", "router", "connect", "listen", "multicast", "lease_ms", "shared_memory", "user",
              "password_file", "users_file", "tls_ca", "tls_cert", "tls_key", "mtls")
DEFAULT_TOPICS = {"robot": ("odom", "scan", "tf"), "master": ("move_base/status",), "router": ()}


@dataclass(frozen=True)
class SshSettings:
    user: str = "root"
    port: int = 22
    key: str = ""  # private key file ('' = ssh's default)
    options: tuple[str, ...] = ()  # extra `-o` values, e.g. StrictHostKeyChecking=accept-new


@dataclass(frozen=True)
class ZenohSettings:
    mode: str = "peer"
    router: str = ""  # name of a router host in this inventory: connect to it (client / peer)
    connect: tuple[str, ...] = ()
    listen: tuple[str, ...] = ()
    multicast: bool | None = None  # None: on for peer / router, off for client
    lease_ms: int = 1000
    shared_memory: bool | None = None  # false across containers / network namespaces
    user: str = ""  # usrpwd identity of this host, with password_file
    password_file: str = ""
    users_file: str = ""
    tls_ca: str = ""
    tls_cert: str = ""
    tls_key: str = ""
    mtls: bool = False


@dataclass(frozen=True)
class Host:
    name: str
    address: str
    role: str
    robot: str = ""
    config: str = ""  # zenav YAML, relative to the checkout (robot / master)
    args: tuple[str, ...] = ()  # extra agent arguments, e.g. ("--world", "room")
    ssh: SshSettings = SshSettings()
    install_dir: str = "/opt/zenav"
    python: str = "python3"
    service_manager: str = "auto"
    service_user: str = "zenav"
    sysroot: str = "/"  # where /etc/... files are written (a directory per host in tests)
    zenoh: ZenohSettings = ZenohSettings()
    labels: tuple[tuple[str, str], ...] = ()
    expect_topics: tuple[str, ...] = ()
    clock_cmd: str = "date +%s.%N"  # prints the host's wall clock in s (replaceable for tests)
    udev_adapter: str = "all"
    pip_args: tuple[str, ...] = ()  # extra `pip install` options, e.g. an offline index on the robot LAN
    install_mode: str = "pip"  # pip (pip install -e) | link (.pth + script: dependencies already there)

    @property
    def service(self) -> str:
        return f"zenav-{self.role}"

    def sys_path(self, path: str) -> str:
        return os.path.join(self.sysroot, path.lstrip("/"))


@dataclass(frozen=True)
class Security:
    cmd_vel_acl: bool = False  # each robot accepts cmd_vel only from its own master(s)
    secrets_dir: str = ""  # generated passwords, kept between runs (idempotent)


@dataclass(frozen=True)
class Inventory:
    path: str
    hosts: tuple[Host, ...] = ()
    security: Security = Security()

    def host(self, name: str) -> Host:
        for h in self.hosts:
            if h.name == name:
                return h
        raise ConfigError(self.path, f"hosts.{name}", "no such host" + suggest(name, self.names()))

    def names(self) -> list[str]:
        return [h.name for h in self.hosts]

    def select(self, names: list[str] | tuple[str, ...] = ()) -> list[Host]:
        """The named hosts (all by default), in start order: routers, robots, masters."""
        hosts = [self.host(n) for n in names] if names else list(self.hosts)
        return sorted(hosts, key=lambda h: ROLES.index(h.role) if h.role != "router" else -1)

    def masters_of(self, robot: str) -> list[Host]:
        return [h for h in self.hosts if h.role == "master" and h.robot == robot]


class _Reader:
    def __init__(self, src: str, base: Path, problems: Problems):
        self.src, self.base, self.p = src, base, problems

    def unknown(self, raw: dict, known: tuple[str, ...], where: str) -> None:
        for k in raw:
            if k not in known:
                self.p.add(self.src, f"{where}.{k}", "unknown key" + suggest(str(k), known))

    def typed(self, raw: dict, key: str, kind, where: str, default: Any):
        v = raw.get(key, default)
        if v is None or v is default:
            return default
        if kind is int and isinstance(v, bool) or not isinstance(v, kind):
            names = kind.__name__ if isinstance(kind, type) else "/".join(k.__name__ for k in kind)
            self.p.add(self.src, f"{where}.{key}", f"expected {names}, got {type(v).__name__} {v!r}")
            return default
        return v

    def strings(self, raw: dict, key: str, where: str) -> tuple[str, ...]:
        v = raw.get(key, [])
        if isinstance(v, str):
            v = v.split(",") if key != "args" else v.split()
        if not isinstance(v, list) or not all(isinstance(x, (str, int, float)) for x in v):
            self.p.add(self.src, f"{where}.{key}", f"expected a list of strings, got {v!r}")
            return ()
        return tuple(str(x).strip() for x in v if str(x).strip())

    def file(self, raw: dict, key: str, where: str) -> str:
        v = self.typed(raw, key, str, where, "")
        if not v:
            return ""
        path = (self.base / os.path.expanduser(v)).resolve()
        if not path.is_file():
            self.p.add(self.src, f"{where}.{key}", f"{path}: no such file")
        return str(path)

    def ssh(self, raw: Any, where: str) -> SshSettings:
        raw = raw or {}
        self.unknown(raw, SSH_KEYS, where)
        port = self.typed(raw, "port", int, where, 22)
        if not 0 < port < 65536:
            self.p.add(self.src, f"{where}.port", f"must be 1..65535, got {port}")
        return SshSettings(self.typed(raw, "user", str, where, "root"), port, self.file(raw, "key", where),
                           self.strings(raw, "options", where))

    def zenoh(self, raw: Any, where: str) -> ZenohSettings:
        raw = raw or {}
        self.unknown(raw, ZENOH_KEYS, where)
        t, f = self.typed, self.file
        mode = t(raw, "mode", str, where, "peer")
        if mode not in MODES:
            self.p.add(self.src, f"{where}.mode", f"must be one of {', '.join(MODES)}, not {mode!r}")
        lease = t(raw, "lease_ms", int, where, 1000)
        if lease < 100:
            self.p.add(self.src, f"{where}.lease_ms", f"must be >= 100 ms, got {lease}")
        z = ZenohSettings(mode, t(raw, "router", str, where, ""), self.strings(raw, "connect", where),
                          self.strings(raw, "listen", where), t(raw, "multicast", bool, where, None), lease,
                          t(raw, "shared_memory", bool, where, None), t(raw, "user", str, where, ""),
                          f(raw, "password_file", where), f(raw, "users_file", where), f(raw, "tls_ca", where),
                          f(raw, "tls_cert", where), f(raw, "tls_key", where), t(raw, "mtls", bool, where, False))
        if bool(z.user) != bool(z.password_file):
            self.p.add(self.src, f"{where}.user", "user and password_file go together")
        if mode == "client" and not (z.connect or z.router):
            self.p.add(self.src, f"{where}.mode", "a client needs router: <host> or connect: [tcp/<addr>:7447]")
        for ep in (*z.connect, *z.listen):
            if not re.match(r"^(tcp|udp|tls|quic)/.+:\d+$", ep):
                self.p.add(self.src, f"{where}", f"endpoint {ep!r} must look like tcp/<host>:<port>")
        return z

    def host(self, name: Any, raw: Any, defaults: dict, checkout: Path) -> Host | None:
        where = f"hosts.{name}"
        if not isinstance(name, str) or not NAME_RE.match(name):
            self.p.add(self.src, where, "host names use only letters, digits, '_', '.' and '-'")
            return None
        if not isinstance(raw, dict):
            self.p.add(self.src, where, f"expected a mapping (address:, role: ...), got {raw!r}")
            return None
        raw = overlay(defaults, raw)
        self.unknown(raw, HOST_KEYS, where)
        t = self.typed
        address, role = t(raw, "address", str, where, ""), t(raw, "role", str, where, "")
        if not address:
            self.p.add(self.src, f"{where}.address", "missing: the host's IP address or DNS name for ssh")
        if role not in ROLES:
            self.p.add(self.src, f"{where}.role", f"must be one of {', '.join(ROLES)}, got {role!r}")
        robot, config = t(raw, "robot", str, where, ""), t(raw, "config", str, where, "")
        if role in ("robot", "master"):
            if not robot or not NAME_RE.match(robot):
                self.p.add(self.src, f"{where}.robot", f"a {role} needs the robot name it serves (letters, "
                           f"digits, _ . -), got {robot!r}")
            if not config:
                self.p.add(self.src, f"{where}.config", f"a {role} needs its zenav YAML (relative to the checkout)")
            elif not (checkout / config).is_file():
                self.p.add(self.src, f"{where}.config", f"{checkout / config}: no such file in this checkout")
        manager = t(raw, "service_manager", str, where, "auto")
        if manager not in MANAGERS:
            self.p.add(self.src, f"{where}.service_manager", f"must be one of {', '.join(MANAGERS)}")
        mode_ = t(raw, "install_mode", str, where, "pip")
        if mode_ not in ("pip", "link"):
            self.p.add(self.src, f"{where}.install_mode", f"must be pip or link, got {mode_!r}")
        install_dir = t(raw, "install_dir", str, where, "/opt/zenav")
        if not install_dir.startswith("/"):
            self.p.add(self.src, f"{where}.install_dir", f"must be an absolute path, got {install_dir!r}")
        labels = t(raw, "labels", dict, where, {})
        topics = self.strings(raw, "expect_topics", where) if "expect_topics" in raw else DEFAULT_TOPICS.get(role, ())
        return Host(name, address, role, robot, config, self.strings(raw, "args", where),
                    self.ssh(raw.get("ssh"), f"{where}.ssh"), install_dir.rstrip("/") or "/",
                    t(raw, "python", str, where, "python3"), manager, t(raw, "service_user", str, where, "zenav"),
                    t(raw, "sysroot", str, where, "/"), self.zenoh(raw.get("zenoh"), f"{where}.zenoh"),
                    tuple(sorted((str(k), str(v)) for k, v in labels.items())), topics,
                    t(raw, "clock_cmd", str, where, "date +%s.%N"), t(raw, "udev_adapter", str, where, "all"),
                    self.strings(raw, "pip_args", where), mode_)


def load(path: str | os.PathLike, checkout: str | os.PathLike | None = None) -> Inventory:
    """Read and validate ``path``; raises ConfigError listing every problem."""
    src = str(path)
    checkout = Path(checkout or Path(__file__).resolve().parents[2])
    try:
        data = yaml.safe_load(Path(path).read_text(encoding="utf-8"))
    except OSError as e:
        raise ConfigError(src, "(file)", f"cannot read: {e.strerror or e}") from None
    except yaml.YAMLError as e:
        raise ConfigError(src, "(file)", f"not valid YAML: {e}") from None
    if not isinstance(data, dict) or not isinstance(data.get("hosts"), dict) or not data["hosts"]:
        raise ConfigError(src, "hosts", "expected a mapping of host name -> {address:, role:, ...}")
    p = Problems()
    r = _Reader(src, Path(path).resolve().parent, p)
    r.unknown(data, ("hosts", "defaults", "security"), "(top)")
    defaults = data.get("defaults") or {}
    if not isinstance(defaults, dict):
        p.add(src, "defaults", "expected a mapping of host keys")
        defaults = {}
    hosts = tuple(h for n, raw in data["hosts"].items() if (h := r.host(n, raw, defaults, checkout)))
    sec_raw = data.get("security") or {}
    r.unknown(sec_raw, ("cmd_vel_acl", "secrets_dir"), "security")
    secrets = r.typed(sec_raw, "secrets_dir", str, "security", "fleet-secrets")
    security = Security(r.typed(sec_raw, "cmd_vel_acl", bool, "security", False), str(r.base / secrets))
    inv = Inventory(src, hosts, security)
    from deploy.fleet.inventory_checks import cross_checks  # (it uses this module's classes)

    cross_checks(inv, p)
    p.raise_if_any()
    return inv
