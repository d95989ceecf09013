"""Start an agent's nodes as forks of one process that has already imported them (a fork server).

A zenav node is a Python process that imports numpy, scipy, Zenoh, numba and its own modules before it
does anything: 0.3-1.2 s of CPU each, about 8.5 s for the simulated P3-AT's robot and master
(``bench/stack_cpu.py``), paid again at every respawn. The fork server imports the launch's node modules
once; each node is then a fork of it that runs its module as ``python -m`` would (``runpy``), with its
own environment, working directory, process group and output pipe. Forking is safe only from a process
with one thread, so the server checks that after its imports and never starts a thread; if a module
started one, the server says so and the agent starts its nodes with ``python -m`` as before.
On by default (``ZENAV_FORK_SERVER=0`` starts every node with ``python -m``): the simulated P3-AT's two
agents start in 6.0-7.2 s of CPU instead of 9.2-10.2 s (``bench/stack_cpu.py``, ``stack_start_cpu_s``).
The imports are frozen out of the garbage collector (``gc.freeze``) before the first fork, after each
module's ``warm_before_fork()`` if it has one (WARM_HOOK below).

    python -u -m common.fork_server FD MODULE... PAD   (started by ForkServer, FD a SOCK_SEQPACKET socket)

A fork's command line (``ps``, ``/proc/<pid>/cmdline``) is rewritten to the node's own
``python -m module --name N ...`` in the server's argument area, which PAD (blanks) makes long enough.

Messages are JSON, one per packet. Agent -> server: ``{"module", "args", "env", "cwd"}`` with the
node's output pipe as the packet's one file descriptor (SCM_RIGHTS). Server -> agent: ``{"ready": [...]}``
or ``{"unsafe": [thread names]}`` once, ``{"pid": N}`` or ``{"error": text}`` per request,
``{"exit": pid, "code": c}`` when a node ends (``c`` as ``Popen.returncode``: ``-signal`` if killed).
The nodes die with the server (PR_SET_PDEATHSIG) and the server with the agent's supervising thread.
"""

from __future__ import annotations

import contextlib
import gc
import importlib
import json
import os
import select
import signal
import socket
import subprocess
import sys
import threading

from common.child_process import make_preexec

_MAX = 1 << 20  # largest request: a node's environment
_PAD = 4096  # room for a node's command line


def _set_cmdline(argv: list[str]) -> None:
    """Write ``argv`` over this process's argument area (where /proc/self/cmdline is read from)."""
    import ctypes

    with open("/proc/self/stat") as f:  # arg_start, arg_end: fields 48 and 49
        fields = f.read().rsplit(")", 1)[1].split()
    start, end = int(fields[45]), int(fields[46])
    data = b"\0".join(a.encode() for a in argv)[:end - start - 1]
    ctypes.memmove(start, data.ljust(end - start, b"\0"), end - start)


def _send(sock: socket.socket, msg: dict, fds: tuple[int, ...] = ()) -> None:
    data = json.dumps(msg).encode()
    if fds:
        socket.send_fds(sock, [data], list(fds))
    else:
        sock.send(data)


# -- the server (its own process) ---------------------------------------------------------------------
# A node module may define ``warm_before_fork()``: the server calls it after importing the module, before
# any fork, so what every node of that module would load at its start (numba's kernels, from their cache:
# about 0.5 s of CPU per process for numba's start alone) is loaded once per agent and shared by the forks.
# What it loads must live in other modules (the kernels' own): the node's module runs afresh as __main__
# in each fork. It must not start a thread (the server checks, as after the imports); a failure is ignored
# there and met again, with the node's own output, when the node warms itself at its start.
WARM_HOOK = "warm_before_fork"


def serve(fd: int, modules: list[str]) -> None:
    sock = socket.socket(fileno=fd)
    for m in modules:  # a module that fails to import fails again in its node, with the node's output
        with contextlib.suppress(BaseException):  # SystemExit too: the node reports it
            mod = importlib.import_module(m)
            # what each node would load at its start, loaded once here for every fork (WARM_HOOK)
            hook = getattr(mod, WARM_HOOK, None)
            if callable(hook):
                hook()
    others = [t.name for t in threading.enumerate() if t is not threading.main_thread()]
    if others:
        _send(sock, {"unsafe": others})
        return
    # what the imports made is never freed: the forks' collectors skip it (and leave its pages shared)
    gc.collect()
    gc.freeze()
    _send(sock, {"ready": modules})
    server = os.getpid()
    while True:
        readable, _, _ = select.select([sock], [], [], 0.05)
        if readable:
            data, fds, _, _ = socket.recv_fds(sock, _MAX, 1)
            if not data:  # the agent is gone: our nodes go with us (their death signal)
                return
            req = json.loads(data)
            try:
                pid = os.fork()
            except OSError as e:
                _send(sock, {"error": f"fork: {e}"})
                for f in fds:
                    os.close(f)
                continue
            if pid == 0:
                sock.close()
                _run_node(req, fds[0], server)  # never returns
            for f in fds:
                os.close(f)
            _send(sock, {"pid": pid})
        while True:  # report every node that ended
            try:
                pid, status = os.waitpid(-1, os.WNOHANG)
            except ChildProcessError:
                break
            if pid == 0:
                break
            _send(sock, {"exit": pid, "code": os.waitstatus_to_exitcode(status)})


def _run_node(req: dict, out_fd: int, server: int) -> None:
    """In the fork: become the node (``python -m module args``) and leave through SystemExit, so that the
    interpreter ends as a node's own would (non-daemon threads joined, atexit handlers run)."""
    os.setsid()
    make_preexec(server)()  # die with the server
    null = os.open(os.devnull, os.O_RDONLY)
    os.dup2(null, 0)
    os.dup2(out_fd, 1)
    os.dup2(out_fd, 2)
    os.close(null)
    os.close(out_fd)
    os.environ.clear()
    os.environ.update(req["env"])
    os.chdir(req["cwd"])
    with contextlib.suppress(OSError, ValueError, IndexError):
        _set_cmdline([sys.executable, "-m", req["module"], *req["args"]])
    sys.argv = [req["module"], *req["args"]]
    import runpy

    # as under ``python -m``, the module runs as __main__ only: the server's imported copy would make runpy
    # warn ("found in sys.modules ... prior to execution") on every node start
    sys.modules.pop(req["module"], None)
    runpy.run_module(req["module"], run_name="__main__", alter_sys=True)
    sys.exit(0)


# -- the agent's side ---------------------------------------------------------------------------------
class ForkedProc:
    """A node forked by the server, with the part of ``subprocess.Popen`` the supervisor uses."""

    def __init__(self, pid: int, stdout) -> None:
        self.pid, self.stdout = pid, stdout
        self.returncode: int | None = None
        self._done = threading.Event()

    def _ended(self, code: int) -> None:
        self.returncode = code
        self._done.set()

    def poll(self) -> int | None:
        return self.returncode

    def wait(self, timeout: float | None = None) -> int:
        if not self._done.wait(timeout):
            raise subprocess.TimeoutExpired(f"node pid {self.pid}", timeout)
        return self.returncode


class ForkServer:
    """Starts the server (call from the thread the nodes should die with) and forks nodes from it.
    ``spawn`` returns None when the server is not usable (did not start, a module started a thread, it
    died): the caller then starts the node with ``python -m``."""

    def __init__(self, modules: list[str], env: dict, on_exit=None, ready_timeout: float = 120.0) -> None:
        self._sock, theirs = socket.socketpair(socket.AF_UNIX, socket.SOCK_SEQPACKET)
        self._procs: dict[int, ForkedProc] = {}
        self._early: dict[int, int] = {}  # exits read before spawn() registered the pid
        self._replies: list[dict] = []
        self._cv = threading.Condition()
        self._lock = threading.Lock()  # one request at a time: replies come in request order
        self._on_exit = on_exit
        self.usable, self.why = False, "starting"
        try:
            self.proc = subprocess.Popen(
                [sys.executable, "-u", "-m", "common.fork_server", str(theirs.fileno()), *modules, " " * _PAD],
                pass_fds=[theirs.fileno()], env=env, stdin=subprocess.DEVNULL, start_new_session=True,
                preexec_fn=make_preexec(os.getpid()))
        except OSError as e:
            self.proc, self.why = None, f"cannot start: {e}"
            theirs.close()
            return
        theirs.close()
        threading.Thread(target=self._read, daemon=True, name="fork-server").start()
        with self._cv:
            self._cv.wait_for(lambda: self.why != "starting", ready_timeout)
            if self.why == "starting":
                self.why = f"not ready within {ready_timeout:g} s"
                self.close()

    def _read(self) -> None:
        while True:
            try:
                data = self._sock.recv(_MAX)
            except OSError:
                data = b""
            if not data:
                break
            msg = json.loads(data)
            if "exit" in msg:
                with self._cv:
                    proc = self._procs.pop(msg["exit"], None)
                    if proc is None:
                        self._early[msg["exit"]] = msg["code"]
                if proc is not None:
                    proc._ended(msg["code"])
                    if self._on_exit is not None:
                        self._on_exit()
                continue
            with self._cv:
                if "ready" in msg:
                    self.usable, self.why = True, ""
                elif "unsafe" in msg:
                    self.why = f"a module started threads ({', '.join(msg['unsafe'])}): forking is unsafe"
                else:
                    self._replies.append(msg)
                self._cv.notify_all()
        with self._cv:  # the server is gone, and with it its nodes (their death signal)
            self.usable = False
            self.why = self.why or "the fork server ended"
            procs, self._procs = list(self._procs.values()), {}
            self._cv.notify_all()
        for proc in procs:
            proc._ended(-signal.SIGKILL)
        if procs and self._on_exit is not None:
            self._on_exit()

    def spawn(self, module: str, args: list[str], env: dict, cwd: str | None = None) -> ForkedProc | None:
        if not self.usable:
            return None
        r, w = os.pipe()
        with self._lock:
            try:
                _send(self._sock, {"module": module, "args": args, "env": env, "cwd": cwd or os.getcwd()}, (w,))
            except OSError:
                os.close(r)
                return None
            finally:
                os.close(w)
            with self._cv:
                self._cv.wait_for(lambda: self._replies or not self.usable, 30.0)
                reply = self._replies.pop(0) if self._replies else {"error": self.why or "no answer"}
                if "pid" in reply:
                    proc = ForkedProc(int(reply["pid"]), os.fdopen(r, "rb"))
                    if proc.pid in self._early:
                        proc._ended(self._early.pop(proc.pid))
                    else:
                        self._procs[proc.pid] = proc
                    return proc
        os.close(r)
        raise OSError(reply["error"])

    def close(self) -> None:
        """Stop the server (after the nodes: they die with it)."""
        self.usable = False
        with contextlib.suppress(OSError):
            self._sock.shutdown(socket.SHUT_RDWR)
        if self.proc is not None:
            try:
                self.proc.wait(5.0)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(5.0)


if __name__ == "__main__":
    serve(int(sys.argv[1]), [m for m in sys.argv[2:] if m.strip()])
