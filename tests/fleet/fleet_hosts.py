"""Test hosts for ``zenav fleet``: network namespaces joined by a bridge, each running a real sshd
(Debian's openssh-server) on port 22 of its own address, root login with a key made here.

The bridge has an address in the root namespace, so the test (the "laptop") reaches every host over
ssh. All hosts share this machine's filesystem: each gets its own install_dir and sysroot under the
temp dir. No systemd runs here, so the hosts use the supervisor (service_manager: auto detects it).

Also the test's helpers: the inventory it writes, ``zenav`` run as a subprocess, processes started in
a host's namespace with that host's Zenoh identity (its generated zenav.env).
"""

from __future__ import annotations

import contextlib
import os
import shutil
import signal
import subprocess
import sys
import time
import uuid
from pathlib import Path

import pytest

from tests.support import ip

REPO = Path(__file__).resolve().parents[2]
SSHD = "/usr/sbin/sshd"
SSH_OPTS = ["StrictHostKeyChecking=no", "UserKnownHostsFile=/dev/null"]

SSHD_CONFIG = """\
Port 22
ListenAddress {address}
HostKey {host_key}
PidFile {pidfile}
AuthorizedKeysFile {authorized}
PermitRootLogin prohibit-password
PubkeyAuthentication yes
PasswordAuthentication no
KbdInteractiveAuthentication no
UsePAM no
StrictModes no
X11Forwarding no
PrintMotd no
"""


def _keygen(path: Path) -> None:
    subprocess.run(["ssh-keygen", "-q", "-t", "ed25519", "-N", "", "-f", str(path)], check=True, timeout=30)


def _ns_pids(ns: str) -> list[int]:
    r = ip("netns", "pids", ns, check=False)
    return [int(x) for x in r.stdout.split()]


class FleetHosts:
    """``names`` -> namespaces with sshd; ``address(name)``; ``key`` (client private key)."""

    def __init__(self, tmp: Path, names: list[str]):
        self.tmp, self.names = tmp, names
        self.sfx = uuid.uuid4().hex[:5]
        n = int(self.sfx, 16)
        self.subnet = f"10.{100 + n % 100}.{n // 100 % 250}"
        self.bridge = f"zfb{self.sfx}"
        self.ns = {h: f"zf{self.sfx}{i}" for i, h in enumerate(names)}
        self.sshd: dict[str, subprocess.Popen] = {}
        self.key = tmp / "id_fleet"

    def address(self, name: str) -> str:
        return f"{self.subnet}.{self.names.index(name) + 1}"

    def up(self) -> None:
        ip("link", "add", self.bridge, "type", "bridge")
        with contextlib.suppress(OSError):
            Path(f"/sys/class/net/{self.bridge}/bridge/multicast_snooping").write_text("0")
        ip("addr", "add", f"{self.subnet}.254/24", "dev", self.bridge)
        ip("link", "set", self.bridge, "up")
        for i, (h, ns) in enumerate(self.ns.items()):
            outer, inner = f"zfo{self.sfx}{i}", f"zfi{self.sfx}{i}"
            ip("netns", "add", ns)
            ip("link", "add", outer, "type", "veth", "peer", "name", inner)
            ip("link", "set", inner, "netns", ns)
            ip("link", "set", outer, "master", self.bridge)
            ip("link", "set", outer, "up")
            ip("-n", ns, "addr", "add", f"{self.address(h)}/24", "dev", inner)
            ip("-n", ns, "link", "set", inner, "up")
            ip("-n", ns, "link", "set", "lo", "up")
            ip("-n", ns, "route", "add", "224.0.0.0/4", "dev", inner)
        _keygen(self.key)
        (self.tmp / "authorized_keys").write_text((self.tmp / "id_fleet.pub").read_text())
        os.makedirs("/run/sshd", exist_ok=True)  # sshd's privilege separation directory
        for h, ns in self.ns.items():
            d = self.tmp / "sshd" / h
            d.mkdir(parents=True)
            _keygen(d / "host_key")
            cfg = d / "sshd_config"
            cfg.write_text(SSHD_CONFIG.format(address=self.address(h), host_key=d / "host_key",
                                              pidfile=d / "sshd.pid", authorized=self.tmp / "authorized_keys"))
            with open(d / "sshd.log", "wb") as log:
                self.sshd[h] = subprocess.Popen(["ip", "netns", "exec", ns, SSHD, "-D", "-e", "-f", str(cfg)],
                                                stdout=subprocess.DEVNULL, stderr=log)
        for h in self.names:
            self._wait_ssh(h)

    def _wait_ssh(self, h: str, timeout: float = 30.0) -> None:
        deadline = time.monotonic() + timeout
        while True:
            r = self.ssh(h, "true", check=False)
            if r.returncode == 0:
                return
            if time.monotonic() > deadline or self.sshd[h].poll() is not None:
                log = (self.tmp / "sshd" / h / "sshd.log").read_text()
                raise AssertionError(f"sshd of {h} not reachable: {r.stderr.strip()} | {log[-500:]}")
            time.sleep(0.2)

    def ssh(self, h: str, command: str, check: bool = True, timeout: float = 60) -> subprocess.CompletedProcess:
        argv = ["ssh", "-i", str(self.key), "-o", "BatchMode=yes", "-o", "LogLevel=ERROR",
                *[x for o in SSH_OPTS for x in ("-o", o)], f"root@{self.address(h)}", command]
        return subprocess.run(argv, capture_output=True, text=True, timeout=timeout, check=check)

    def pids(self, h: str) -> list[int]:
        return _ns_pids(self.ns[h])

    def down(self) -> None:
        """Kill what runs in the namespaces (started by this test), delete them and the bridge."""
        for sig in (signal.SIGTERM, signal.SIGKILL):
            for ns in self.ns.values():
                for pid in _ns_pids(ns):
                    with contextlib.suppress(ProcessLookupError):
                        os.kill(pid, sig)
            if sig == signal.SIGTERM:
                deadline = time.monotonic() + 5
                while time.monotonic() < deadline and any(_ns_pids(ns) for ns in self.ns.values()):
                    time.sleep(0.1)
        for p in self.sshd.values():
            with contextlib.suppress(subprocess.TimeoutExpired):
                p.wait(timeout=5)
        for ns in self.ns.values():
            ip("netns", "del", ns, check=False)
        ip("link", "del", self.bridge, check=False)


def requirements() -> None:
    if os.geteuid() != 0:
        pytest.skip("needs root (network namespaces)")
    for tool in ("ip", "ssh", "ssh-keygen"):
        if shutil.which(tool) is None:
            pytest.skip(f"needs {tool}")
    if not os.path.exists(SSHD):
        pytest.skip("needs Debian's openssh-server (/usr/sbin/sshd): bash deploy/install.sh --test")


def python_for_hosts() -> str:
    """The interpreter the hosts use for their venvs (this one: it has zenav's dependencies)."""
    return os.path.realpath(sys.executable)


def inventory(hosts: FleetHosts, robots: dict[str, str], tmp: Path, clock_cmd: str = "", acl: bool = False) -> dict:
    """robot1 + master1 serving ``robots["1"]`` (and robot2 + master2 serving ``robots["2"]`` when given):
    simulated P3-AT on the robot hosts, the master on the known map; ``acl``: ``security.cmd_vel_acl`` (a
    Zenoh router per host, usrpwd, the robot's router holding the cmd_vel access control)."""
    def host(name: str, role: str, config: str) -> dict:
        return {"address": hosts.address(name), "role": role, "robot": robots[name[-1]], "config": config,
                "install_dir": str(tmp / "hosts" / name / "zenav"), "sysroot": str(tmp / "hosts" / name / "root")}

    inv = {
        "security": {"cmd_vel_acl": acl, "secrets_dir": str(tmp / "secrets")},
        "defaults": {"ssh": {"user": "root", "key": str(hosts.key), "options": SSH_OPTS},
                     "python": python_for_hosts(), "zenoh": {"mode": "peer", "shared_memory": False},
                     # the namespaces have no route to PyPI (local wheels); setuptools + wheel come from the
                     # venv's system site-packages instead of an isolated build env (~60 s of CPU saved)
                     "pip_args": ["--retries", "0", "--no-build-isolation"]},
        "hosts": {},
    }
    for n in sorted(robots):
        inv["hosts"][f"robot{n}"] = host(f"robot{n}", "robot", "robot_side/config/p3at_sim.yaml")
        inv["hosts"][f"master{n}"] = host(f"master{n}", "master", "master_side/config/p3at_known_map.yaml")
    # only robot1 installs with pip (install_mode: link elsewhere): pip's build costs CPU this shared
    # 2-core machine lacks
    for name, h in inv["hosts"].items():
        if name != "robot1":
            h["install_mode"] = "link"
    if clock_cmd:
        inv["hosts"]["robot1"]["clock_cmd"] = clock_cmd
    return inv


def seed_kernels(install_dir: Path) -> int:
    """Copy this checkout's compiled numba kernels (deploy/install.sh ran deploy.warm_kernels: they sit in
    ``__pycache__`` beside the modules) into a master host's kernel cache (install_dir/cache/numba, its
    NUMBA_CACHE_DIR), under the directory numba derives from the host's own src path. numba keys a kernel
    by the sha256 of its source file, so a kernel is reused only for an unchanged file; any other is
    compiled on the host as before. The host's install still runs deploy.warm_kernels (now loading instead
    of compiling: ~15 s of CPU less per master). Returns how many files were copied (0 when numba's layout
    is not the one expected: then the host compiles everything)."""
    from numba.core.caching import UserProvidedCacheLocator

    subpath = getattr(UserProvidedCacheLocator, "get_suitable_cache_subpath", None)
    if subpath is None:
        return 0
    n = 0
    for cache in (c for top in ("common", "robot_side", "master_side") for c in (REPO / top).glob("**/__pycache__")):
        files = [*cache.glob("*.nbi"), *cache.glob("*.nbc")]
        if not files:
            continue
        dest = install_dir / "cache" / "numba" / subpath(str(install_dir / "src" / cache.parent.relative_to(REPO)
                                                             / "m.py"))
        dest.mkdir(parents=True, exist_ok=True)
        for f in files:
            shutil.copy2(f, dest / f.name)
            n += 1
    return n


def zenav(*args: str, timeout: float = 240) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if not k.startswith("ZENAV_")}
    t0 = time.monotonic()
    r = subprocess.run([sys.executable, "-m", "deploy.cli", *args], cwd=REPO, env=env, capture_output=True,
                       text=True, timeout=timeout)
    print(f"$ zenav {' '.join(args)}  ({time.monotonic() - t0:.1f} s, exit {r.returncode})\n{r.stdout}{r.stderr}")
    return r


def status_until(inv: Path, ok: bool, timeout: float = 60) -> subprocess.CompletedProcess:
    deadline = time.monotonic() + timeout
    while True:
        r = zenav("fleet", "-i", str(inv), "status", "--seconds", "1.5")
        if (r.returncode == 0) == ok or time.monotonic() > deadline:
            return r
        time.sleep(1)


def host_env(path: Path) -> dict[str, str]:
    return dict(line.split("=", 1) for line in path.read_text().splitlines() if "=" in line and line[0] != "#")


def on_host(hosts: FleetHosts, tmp: Path, host: str, argv: list[str], identity: str = "",
            env: dict | None = None, seconds: float = 0) -> subprocess.Popen:
    """``python argv`` in ``host``'s namespace with the Zenoh settings and identity of the zenav.env of
    ``identity`` (default: ``host`` itself); ``env`` entries win; ``seconds``: killed after that long."""
    e = {k: v for k, v in os.environ.items() if not k.startswith("ZENAV_")}
    e.update(host_env(tmp / "hosts" / (identity or host) / "zenav/etc/zenav.env"), PYTHONPATH=str(REPO))
    e.update(env or {})
    limit = ["timeout", str(seconds)] if seconds else []
    # its own process group: `timeout` forks the python, so killing the Popen alone would leave it running
    return subprocess.Popen(["ip", "netns", "exec", hosts.ns[host], *limit, sys.executable, *argv], cwd=REPO,
                            env=e, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)


def kill_group(p: subprocess.Popen) -> None:
    """SIGKILL an ``on_host`` process and everything it started (its process group)."""
    with contextlib.suppress(ProcessLookupError):
        os.killpg(p.pid, signal.SIGKILL)


def output(p: subprocess.Popen, timeout: float = 30) -> str:
    try:
        out, err = p.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        kill_group(p)
        out, err = p.communicate()
    return out + err


def node_pid(hosts: FleetHosts, host: str, node: str) -> int:
    for pid in hosts.pids(host):
        try:
            argv = Path(f"/proc/{pid}/cmdline").read_bytes().split(b"\0")
        except OSError:
            continue
        if b"--name" in argv and argv[argv.index(b"--name") + 1] == node.encode():
            return pid
    raise AssertionError(f"no process of node {node} on {host}")
