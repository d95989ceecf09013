"""A process supervisor for zenav agents (the roslaunch replacement).

A launch is an ordered list of ``NodeSpec``. Each node runs as its own process in its own session
(process group), started in order once its ``after`` nodes are RUNNING and a message was seen on each
of its ``wait_for`` topics (the tutorial's "merger launched before virtualizer" problem). Respawn-marked
nodes are restarted after ``respawn_delay`` (doubling while deaths pile up; more than
``crash_loop[0]`` deaths in ``crash_loop[1]`` s -> FAILED), except after exit status 2 (a configuration
error, ``common.runner.EXIT_CONFIG``): FAILED at once, the error as the reason. A ``required`` node that
ends or fails stops the whole launch. Shutdown: ``stop_first`` nodes (the base) are stopped and waited
for first, then the others in reverse start order, one at a time: SIGTERM to its process group, SIGKILL
after ``grace`` s.
Children get ``PR_SET_PDEATHSIG`` (SIGKILL) so they die with the supervising thread even if the agent
itself is SIGKILLed. All spawning happens on the supervisor's own thread for that reason.

Child output lines are prefixed ``[name] ``; a status table goes to stderr on every change; with a
bus ``Node`` the states are published as ``NodeState`` on ``agent/<agent>/state``. The launch data
(``NodeSpec``, states) is in ``common.node_spec``; child process plumbing in ``common.child_process``;
the table and state publishing in ``common.supervisor_status``; ``wait_for`` subscriptions in
``common.supervisor_watch``.
"""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import threading
import time
from typing import Any, TextIO

from common.child_process import child_bus_env, killpg, make_preexec
from common.fork_server import ForkedProc, ForkServer
from common.node_spec import (
    EXITED,
    FAILED,
    RESTARTING,
    RUNNING,
    STOPPED,
    STOPPING,
    TERMINAL,
    WAITING,
    NodeSpec,
    NodeStatus,
    validate_launch,
)
from common.runner import EXIT_CONFIG
from common.supervisor_status import StatusReporter, status_table
from common.supervisor_watch import TopicWatcher
from common.zenoh_config import BusConfig


class Supervisor:
    def __init__(self, specs: list[NodeSpec], bus_config: BusConfig | None = None, node: Any = None,
                 agent: str = "agent", grace: float = 3.0, crash_loop: tuple[int, float] = (5, 10.0),
                 out: TextIO | None = None, status: TextIO | None = None, extra_env: dict | None = None,
                 max_respawn_delay: float = 5.0, agent_endpoint: str = "", fork_server: bool | None = None) -> None:
        validate_launch(specs)
        self.specs, self.agent, self.grace, self.crash_loop = list(specs), agent, grace, crash_loop
        self.bus_config = bus_config or BusConfig.from_env()
        self.node, self.out, self.status_out = node, out or sys.stdout, status
        self.max_respawn_delay = max_respawn_delay
        self.nodes = {s.name: NodeStatus(s) for s in specs}
        self.start_order: list[str] = []
        self.reason = ""            # why the launch stopped ('' = asked to)
        self.failed = False         # stopped because of a failure
        self._env = {**os.environ, **child_bus_env(self.bus_config, agent_endpoint), **(extra_env or {}),
                     "ZENAV_PARENT_PID": str(os.getpid()), "PYTHONUNBUFFERED": "1"}
        self._wake = threading.Event()
        if fork_server is None:
            # on unless ZENAV_FORK_SERVER=0 (common/fork_server.py, the README)
            fork_server = os.environ.get("ZENAV_FORK_SERVER", "1") not in ("0", "false", "no")
        self._fork_modules = sorted({s.module for s in specs if s.module}) if fork_server else []
        self._forker: ForkServer | None = None
        self._stop_req = threading.Event()
        self._done = threading.Event()
        self._lock = threading.RLock()
        self._out_lock = threading.Lock()
        self._dirty: set[str] = set()
        self._watcher = TopicWatcher(node, self.nodes, self._wake)
        self._reporter = StatusReporter(self.nodes, agent, node, status, self._out_lock)
        self._thread: threading.Thread | None = None

    # -- public API -------------------------------------------------------------------------------
    def start(self) -> Supervisor:
        self._thread = threading.Thread(target=self._loop, name=f"supervisor:{self.agent}", daemon=True)
        self._thread.start()
        return self

    def stop(self, reason: str = "", failed: bool = False) -> None:
        """Ask for an orderly shutdown (any thread, signal handlers included)."""
        with self._lock:
            if not self._stop_req.is_set():
                self.reason, self.failed = reason, failed
                self._stop_req.set()
        self._wake.set()

    def wait(self, timeout: float | None = None) -> bool:
        return self._done.wait(timeout)

    def run(self) -> int:
        """Start, stop on SIGINT / SIGTERM (main thread), return 0 or 1 (launch failed)."""
        def on_signal(signum, _frame):
            if self._stop_req.is_set():     # second Ctrl-C: no more patience
                self.grace = 0.2
            self.stop(f"received {signal.Signals(signum).name}")
        old = {s: signal.signal(s, on_signal) for s in (signal.SIGINT, signal.SIGTERM)}
        try:
            self.start()
            while not self._done.wait(0.2):
                pass
        finally:
            for s, h in old.items():
                signal.signal(s, h)
        return 1 if self.failed else 0

    def state(self, name: str) -> NodeStatus:
        return self.nodes[name]

    def table(self) -> str:
        return status_table(self.nodes)

    # -- state changes ----------------------------------------------------------------------------
    def _set(self, st: NodeStatus, state: str, detail: str = "") -> None:
        with self._lock:
            if (st.state, st.detail) != (state, detail):
                st.state, st.detail = state, detail
                self._dirty.add(st.spec.name)

    def _report(self, force: bool = False) -> None:
        with self._lock:
            dirty, self._dirty = self._dirty, set()
        self._reporter.report(dirty, force)

    # -- processes --------------------------------------------------------------------------------
    def _spawn(self, st: NodeStatus) -> None:
        spec = st.spec
        env = {**self._env, **{k: str(v) for k, v in spec.env.items()}}
        try:
            proc = self._fork(spec, env) or subprocess.Popen(
                spec.argv(), stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                env=env, start_new_session=True, preexec_fn=make_preexec(os.getpid()))
        except OSError as e:
            self._died(st, None, f"cannot start: {e}")
            return
        st.proc, st.pid, st.exit_code = proc, proc.pid, None
        st.pids.append(proc.pid)
        if spec.name not in self.start_order:
            self.start_order.append(spec.name)
        self._set(st, RUNNING, "")
        st.pump = threading.Thread(target=self._pump, args=(st, proc), daemon=True, name=f"out:{spec.name}")
        st.pump.start()
        threading.Thread(target=self._reap, args=(proc,), daemon=True, name=f"wait:{spec.name}").start()

    def _fork(self, spec: NodeSpec, env: dict) -> ForkedProc | None:
        """The node forked from the fork server (``common.fork_server``), or None: start it with python -m."""
        if not spec.module or spec.module not in self._fork_modules:
            return None
        if self._forker is None:
            self._forker = ForkServer(self._fork_modules, self._env, on_exit=self._wake.set)
            if not self._forker.usable:
                with self._out_lock, contextlib.suppress(ValueError, OSError):
                    print(f"zenav {self.agent}: nodes start with python -m ({self._forker.why})",
                          file=self.status_out or sys.stderr, flush=True)
        return self._forker.spawn(spec.module, spec.argv()[3:], env)

    def _pump(self, st: NodeStatus, proc: subprocess.Popen | ForkedProc) -> None:
        prefix = f"[{st.spec.name}] "
        for raw in iter(proc.stdout.readline, b""):
            line = raw.decode(errors="replace").rstrip()
            st.tail.append(line)
            with self._out_lock, contextlib.suppress(ValueError, OSError):
                print(prefix + line, file=self.out, flush=True)
        proc.stdout.close()

    def _reap(self, proc: subprocess.Popen | ForkedProc) -> None:
        proc.wait()
        self._wake.set()

    def _died(self, st: NodeStatus, code: int | None, why: str = "") -> None:
        """Handle the end of a node's process (not during shutdown)."""
        spec, now = st.spec, time.monotonic()
        st.proc, st.exit_code = None, code
        if code == EXIT_CONFIG:   # a configuration error: respawning cannot fix it
            self._config_error(st)
            return
        last = next((ln for ln in reversed(st.tail) if ln.strip()), "")
        why = why or (f"exit code {code}" if code is not None and code >= 0 else f"killed by signal {-code}")
        if last:
            why += f": {last[-120:]}"
        st.deaths.append(now)
        if spec.respawn:
            n_max, window = self.crash_loop
            recent = sum(1 for t in st.deaths if now - t <= window)
            if recent > n_max:
                self._set(st, FAILED, f"crash loop ({recent} deaths in {window:g} s); {why}")
            else:
                delay = min(spec.respawn_delay * 2 ** (recent - 1), self.max_respawn_delay)
                st.start_at = now + delay
                self._set(st, RESTARTING, f"{why}; restart in {delay:.1f} s")
                return
        else:
            self._set(st, EXITED if code == 0 else FAILED, why)
        if spec.required:
            self.stop(f"required node '{spec.name}' ended ({why})", failed=True)

    def _config_error(self, st: NodeStatus) -> None:
        if st.pump is not None:
            st.pump.join(1.0)     # the error is on the last output lines
        lines = [ln.strip() for ln in st.tail if ln.strip()]
        start = next((i for i, ln in enumerate(lines) if "config error" in ln), max(len(lines) - 1, 0))
        reason = "; ".join(ln.split("config error:", 1)[-1].strip() for ln in lines[start:start + 5])
        detail = f"configuration error (exit code {EXIT_CONFIG}, not respawned)" + (f": {reason}" if reason else "")
        self._set(st, FAILED, detail[:400])
        with self._out_lock, contextlib.suppress(ValueError, OSError):
            print(f"zenav {self.agent}: node '{st.spec.name}' FAILED: {detail}",
                  file=self.status_out or sys.stderr, flush=True)
        if st.spec.required:
            self.stop(f"required node '{st.spec.name}' failed: configuration error", failed=True)

    # -- starting (after, wait_for) ---------------------------------------------------------------
    def _try_start(self, st: NodeStatus, now: float) -> None:
        spec = st.spec
        for a in spec.after:
            dep = self.nodes[a]
            if dep.state == FAILED or (dep.state == EXITED and dep.exit_code != 0):
                self._set(st, FAILED, f"dependency '{a}' {dep.state.lower()}")
                if spec.required:
                    self.stop(f"required node '{spec.name}' cannot start: dependency '{a}' failed", True)
                return
        pending = [a for a in spec.after if a not in self.start_order]
        if spec.wait_for and self.node is None:
            self._set(st, FAILED, "wait_for needs a bus node")
            return
        missing = [t for t in spec.wait_for if t not in st.seen]
        if not pending and not missing:
            self._spawn(st)
            return
        if not st.wait_since:
            st.wait_since = now
            for t in spec.wait_for:
                self._watcher.watch(t)
        if missing and not pending and now - st.wait_since > spec.wait_timeout:
            self._set(st, FAILED, f"no message on {', '.join(missing)} within {spec.wait_timeout:g} s")
            if spec.required:
                self.stop(f"required node '{spec.name}' failed: nothing on {', '.join(missing)}", True)
            return
        what = [f"node{'s' * (len(pending) > 1)} {', '.join(pending)}"] if pending else []
        what += [f"topic{'s' * (len(missing) > 1)} {', '.join(missing)}"] if missing else []
        self._set(st, WAITING, "waiting for " + "; ".join(what))

    # -- main loop --------------------------------------------------------------------------------
    def _loop(self) -> None:
        try:
            while not self._stop_req.is_set():
                self._wake.clear()
                now = time.monotonic()
                for st in self.nodes.values():
                    if st.proc is not None and st.proc.poll() is not None:
                        self._died(st, st.proc.returncode)
                if self._stop_req.is_set():
                    break
                for st in self.nodes.values():
                    if st.state == WAITING:
                        self._try_start(st, now)
                    elif st.state == RESTARTING and now >= st.start_at:
                        st.restarts += 1
                        self._spawn(st)
                self._watcher.unwatch_unused()
                self._report()
                if all(st.state in TERMINAL for st in self.nodes.values()):
                    bad = [n for n, st in self.nodes.items() if st.state == FAILED]
                    self.stop("all nodes ended" + (f" ({', '.join(bad)} failed)" if bad else ""),
                              failed=bool(bad))
                    break
                self._wake.wait(0.1)
            self._shutdown()
        finally:
            if self._forker is not None:
                self._forker.close()
            self._report(force=True)
            self._done.set()

    def _shutdown(self) -> None:
        self._watcher.close()
        for st in self.nodes.values():
            if st.proc is None and st.state in (WAITING, RESTARTING):
                self._set(st, STOPPED, "not started" if st.state == WAITING else st.detail)
        order = [n for n in reversed(self.start_order)]
        first = [n for n in order if self.nodes[n].spec.stop_first]
        rest = [n for n in order if not self.nodes[n].spec.stop_first]
        for group in (first, rest):
            self._stop_group([self.nodes[n] for n in group if self.nodes[n].proc is not None])

    def _stop_group(self, sts: list[NodeStatus]) -> None:
        """One node after the other (the order is a guarantee, as in roslaunch): SIGTERM to the
        group, SIGKILL after ``grace`` s, then SIGKILL whatever is left of the group."""
        for st in sts:
            self._set(st, STOPPING, "SIGTERM")
            self._report()
            killpg(st.pid, signal.SIGTERM)
            try:
                st.proc.wait(self.grace)
            except subprocess.TimeoutExpired:
                killpg(st.pid, signal.SIGKILL)
                self._set(st, STOPPING, f"no exit {self.grace:g} s after SIGTERM: SIGKILL")
                with contextlib.suppress(subprocess.TimeoutExpired):
                    st.proc.wait(5.0)
            killpg(st.pid, signal.SIGKILL)    # leftovers of the group (grandchildren)
            st.exit_code = st.proc.returncode
            self._set(st, STOPPED, st.detail if "SIGKILL" in st.detail else f"exit code {st.exit_code}")
            st.proc = None
        self._report()
