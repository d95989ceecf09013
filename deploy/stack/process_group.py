"""A group of `zenav` subprocesses on a private loopback Zenoh network (the demo, the BARN bench).

Each process is ``python -m deploy.cli <args> --robot R --no-multicast --listen <its own port> --connect
<the owner's endpoint>,<every running process's port>`` in its own session (so Ctrl-C / SIGINT reaches its
children), logging to ``<workdir>/<name>.log``. The owner's node listens on ``endpoint``
(``ProcessGroup.hub_config``). The owner stops them in a ``finally`` under ``terminate_as_interrupt()``, so
SIGTERM stops them too.

Every link between two of these peers is one a process was told to open, and gossip is off: Zenoh dials a
configured endpoint again until it answers, but a link it found by gossip, once closed, is not dialled again
while the two peers' other links stand (common/zenoh_config.py, ``gossip``). With gossip, `zenav explore`
once heard no clock from the simulator for six minutes of an office run.
"""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterable
from pathlib import Path

from common.ports import free_port
from common.zenoh_config import BusConfig

_deferral = {"depth": 0, "pending": 0}  # a signal that came inside _deferred_interrupts()


def _interrupt(signum, _frame) -> None:
    if _deferral["depth"]:
        _deferral["pending"] = signum
        return
    raise KeyboardInterrupt(signal.Signals(signum).name)


def _already_stopping(signum, _frame) -> None:
    # os.write, not print: a handler that prints while the interrupted code prints raises "reentrant call"
    os.write(2, f"{signal.Signals(signum).name}: already stopping\n".encode())


@contextlib.contextmanager
def _deferred_interrupts():
    """Inside: a signal handled by terminate_as_interrupt() waits until the block is over, so a process
    is never started without being recorded for the stop (a SIGTERM right after the child's exec, still
    inside Popen, left a master agent and its nodes running)."""
    _deferral["depth"] += 1
    try:
        yield
    finally:
        _deferral["depth"] -= 1
        if not _deferral["depth"] and _deferral["pending"]:  # an inner block keeps it for the outer one
            signum, _deferral["pending"] = _deferral["pending"], 0
            raise KeyboardInterrupt(signal.Signals(signum).name)


@contextlib.contextmanager
def terminate_as_interrupt(once: bool = False):
    """Within the block, SIGINT, SIGTERM and SIGHUP raise KeyboardInterrupt (named after the signal), so
    the caller's ``finally`` stops its process group (Ctrl-C, `timeout`, `kill`, a closed terminal); the
    old handlers after. ``once``: only the first signal does; later ones are noted on stderr and change
    nothing, so a second Ctrl-C or SIGTERM does not cut short a stop that measures, saves and reports what
    was done (``bench/explore.py``: it printed a traceback and no table). That stop must be bounded: each
    process gets a grace period, then SIGKILL."""
    signals = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)

    def first(signum, frame) -> None:
        if once:  # deferred or not, this one raises (now or at the block's end) and no other does
            for s in signals:
                signal.signal(s, _already_stopping)
        _interrupt(signum, frame)

    old = {s: signal.signal(s, first) for s in signals}
    try:
        yield
    finally:
        for s, h in old.items():
            signal.signal(s, h)



def set_options(assignments: Iterable[str]) -> list[str]:
    """``NODE.KEY=VALUE`` assignments as the options of ``zenav robot`` / ``zenav master``: ``--set A --set B``."""
    return [w for kv in assignments for w in ("--set", kv)]


def checkout_env(base: dict[str, str] | None = None, drop_zenav: bool = False) -> dict[str, str]:
    """Environment for a child process that runs this checkout's code (first on PYTHONPATH, whatever
    ``pip install -e`` last pointed at), unbuffered; ``drop_zenav``: without inherited ZENAV_* settings."""
    from pathlib import Path

    env = {k: v for k, v in (os.environ if base is None else base).items()
           if not (drop_zenav and k.startswith("ZENAV_"))}
    root = str(Path(__file__).resolve().parents[2])
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [root, env.get("PYTHONPATH", "")]))
    env["PYTHONUNBUFFERED"] = "1"
    return env

class ProcessGroup:
    def __init__(self, robot: str, endpoint: str, workdir: Path):
        self.robot, self.endpoint, self.work = robot, endpoint, Path(workdir)
        self.procs: list[tuple[str, subprocess.Popen, str]] = []  # name, process, its own endpoint

    def hub_config(self) -> BusConfig:
        """The owner's node: listening on ``endpoint``, which every process of the group dials."""
        return BusConfig(robot=self.robot, multicast=False, listen=(self.endpoint,), gossip=False)

    def bus_args(self, listen: str = "") -> list[str]:
        """Options that join the group: dial the owner and every process still running (each of those links
        is then dialled again by this process if it closes); ``listen``: this process's own endpoint, for
        the processes started after it."""
        peers = [self.endpoint, *(ep for _, p, ep in self.procs if p.poll() is None)]
        return ["--robot", self.robot, "--no-multicast", "--connect", ",".join(peers),
                *(["--listen", listen] if listen else [])]

    def spawn(self, name: str, args: list[str]) -> subprocess.Popen:
        log = open(self.work / f"{name}.log", "w")  # noqa: SIM115 - closed with the process
        listen = f"tcp/127.0.0.1:{free_port()}"
        env = checkout_env()
        env["ZENAV_GOSSIP"] = "0"
        with _deferred_interrupts():  # started => recorded, so stop() reaches it
            p = subprocess.Popen([sys.executable, "-m", "deploy.cli", *args, *self.bus_args(listen)], stdout=log,
                                 stderr=subprocess.STDOUT, env=env, start_new_session=True, cwd=self.work)
            self.procs.append((name, p, listen))
        return p

    def stop(self, name: str | None = None, grace: float = 10.0) -> None:
        """SIGINT the process (all when ``name`` is None), SIGKILL after ``grace`` s."""
        keep = []
        for entry in self.procs:
            n, p, _ = entry
            if name is not None and n != name:
                keep.append(entry)
                continue
            if p.poll() is None:
                os.killpg(p.pid, signal.SIGINT)
                try:
                    p.wait(grace)
                except subprocess.TimeoutExpired:
                    os.killpg(p.pid, signal.SIGKILL)
                    p.wait(5)
        self.procs = keep

    def check_alive(self, ignore: tuple[str, ...] = ()) -> None:
        for n, p, _ in self.procs:
            if n not in ignore and p.poll() is not None:
                raise RuntimeError(f"{n} exited with status {p.returncode} (log: {self.work / (n + '.log')})")

    def wait(self, what: str, cond, timeout: float, ignore: tuple[str, ...] = ()) -> None:
        t0 = time.monotonic()
        while not cond():
            self.check_alive(ignore)
            if time.monotonic() - t0 > timeout:
                raise RuntimeError(f"timed out after {timeout:.0f} s waiting for {what}")
            time.sleep(0.1)
