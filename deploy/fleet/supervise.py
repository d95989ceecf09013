"""A small service supervisor for hosts without systemd (runs ON the host; standard library only).

    python supervise.py start  SPEC    start the service in the background (setsid), if not running
    python supervise.py stop   SPEC    SIGTERM (then SIGKILL after stop_timeout), wait until gone
    python supervise.py status SPEC    one JSON line: state, pid, since, restarts, last_exit
    python supervise.py run    SPEC    the supervisor itself (what `start` detaches)

SPEC is the service.json written by ``zenav fleet install``: argv, cwd, env_file (VAR=value lines),
log, run_dir, restart_sec, stop_timeout. Like systemd's Restart=on-failure: the service is started again
restart_sec after a non-zero exit; exit 0, an exit status in no_restart_exit (2: zenav's
"bad config", which a restart cannot fix) or stop ends it. Its output goes to ``log`` (appended).
Files: <run_dir>/<name>.pid (the supervisor's pid) and <name>.state (JSON).
"""

from __future__ import annotations

import contextlib
import ctypes
import json
import os
import signal
import subprocess
import sys
import time


def _load(spec_path: str) -> dict:
    with open(spec_path, encoding="utf-8") as f:
        spec = json.load(f)
    spec["pidfile"] = os.path.join(spec["run_dir"], spec["name"] + ".pid")
    spec["statefile"] = os.path.join(spec["run_dir"], spec["name"] + ".state")
    return spec


def _env(path: str) -> dict[str, str]:
    env = dict(os.environ)
    with contextlib.suppress(OSError), open(path, encoding="utf-8") as f:
        for line in f:
            line = line.strip()
            if line and not line.startswith("#") and "=" in line:
                k, v = line.split("=", 1)
                env[k.strip()] = v.strip().strip('"')
    return env


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    with contextlib.suppress(OSError), open(f"/proc/{pid}/stat", encoding="utf-8") as f:
        return f.read().rsplit(")", 1)[1].split()[0] != "Z"
    return True


def _pid(spec: dict) -> int | None:
    with contextlib.suppress(OSError, ValueError), open(spec["pidfile"], encoding="utf-8") as f:
        pid = int(f.read().strip())
        return pid if _alive(pid) else None
    return None


def _state(spec: dict) -> dict:
    with contextlib.suppress(OSError, ValueError), open(spec["statefile"], encoding="utf-8") as f:
        return json.load(f)
    return {}


def _write_state(spec: dict, **kw) -> None:
    st = {**_state(spec), **kw}
    tmp = spec["statefile"] + ".tmp"
    with open(tmp, "w", encoding="utf-8") as f:
        json.dump(st, f)
    os.replace(tmp, spec["statefile"])


def status(spec: dict) -> dict:
    pid, st = _pid(spec), _state(spec)
    if pid is not None:
        state = "active" if st.get("child_pid") else "activating"
    elif st.get("last_exit") not in (None, 0) and not st.get("stopped"):
        state = "failed"
    else:
        state = "inactive"
    return {"state": state, "pid": pid, "child_pid": st.get("child_pid") if pid else None,
            "since": st.get("since"), "restarts": st.get("restarts", 0), "last_exit": st.get("last_exit")}


def start(spec: dict) -> int:
    if (pid := _pid(spec)) is not None:
        print(f"{spec['name']} already running (supervisor pid {pid})")
        return 0
    for d in (spec["run_dir"], os.path.dirname(spec["log"])):
        os.makedirs(d, exist_ok=True)
    subprocess.Popen([sys.executable, os.path.abspath(__file__), "run", spec["spec_path"]],
                     stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                     start_new_session=True, close_fds=True)
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline:
        if (pid := _pid(spec)) is not None and _state(spec).get("child_pid"):
            print(f"{spec['name']} started (supervisor pid {pid})")
            return 0
        time.sleep(0.05)
    print(f"{spec['name']} did not start: see {spec['log']}", file=sys.stderr)
    return 1


def stop(spec: dict) -> int:
    pid = _pid(spec)
    if pid is None:
        print(f"{spec['name']} not running")
        return 0
    os.kill(pid, signal.SIGTERM)
    deadline = time.monotonic() + float(spec.get("stop_timeout", 15)) + 5
    while time.monotonic() < deadline and _alive(pid):
        time.sleep(0.05)
    if _alive(pid):
        with contextlib.suppress(ProcessLookupError):
            os.killpg(pid, signal.SIGKILL)
    print(f"{spec['name']} stopped")
    return 0


def _pdeathsig() -> None:  # the service dies with its supervisor (SIGTERM: it stops its nodes)
    with contextlib.suppress(OSError, AttributeError):
        ctypes.CDLL(None).prctl(1, signal.SIGTERM, 0, 0, 0)


def run(spec: dict) -> int:
    with open(spec["pidfile"], "w", encoding="utf-8") as f:
        f.write(str(os.getpid()))
    _write_state(spec, since=time.time(), restarts=0, child_pid=None, stopped=False)
    stopping = [False]
    child: list[subprocess.Popen | None] = [None]

    def on_term(*_a) -> None:
        if not stopping[0]:
            with contextlib.suppress(OSError), open(spec["log"], "ab") as f:
                f.write(f"--- {time.strftime('%Y-%m-%d %H:%M:%S')} supervise: stop requested\n".encode())
        stopping[0] = True
        if child[0] is not None:
            with contextlib.suppress(ProcessLookupError):
                child[0].send_signal(signal.SIGTERM)

    signal.signal(signal.SIGTERM, on_term)
    signal.signal(signal.SIGINT, on_term)
    restarts = 0
    try:
        with open(spec["log"], "ab", buffering=0) as log:
            while not stopping[0]:
                log.write(f"--- {time.strftime('%Y-%m-%d %H:%M:%S')} supervise: start {' '.join(spec['argv'])}\n"
                          .encode())
                p = child[0] = subprocess.Popen(spec["argv"], cwd=spec["cwd"], env=_env(spec["env_file"]),
                                                stdin=subprocess.DEVNULL, stdout=log, stderr=subprocess.STDOUT,
                                                preexec_fn=_pdeathsig)
                _write_state(spec, child_pid=p.pid, child_since=time.time())
                while True:
                    try:
                        code = p.wait(timeout=float(spec.get("stop_timeout", 15)) if stopping[0] else None)
                        break
                    except subprocess.TimeoutExpired:
                        p.kill()
                log.write(f"--- {time.strftime('%Y-%m-%d %H:%M:%S')} supervise: exited {code}\n".encode())
                _write_state(spec, child_pid=None, last_exit=code)
                if stopping[0] or code == 0 or code in spec.get("no_restart_exit", ()):
                    break
                restarts += 1
                _write_state(spec, restarts=restarts)
                end = time.monotonic() + float(spec.get("restart_sec", 2))
                while not stopping[0] and time.monotonic() < end:
                    time.sleep(0.05)
    finally:
        _write_state(spec, child_pid=None, stopped=stopping[0])
        with contextlib.suppress(OSError):
            os.unlink(spec["pidfile"])
    return 0


def main(argv: list[str]) -> int:
    if len(argv) != 2 or argv[0] not in ("start", "stop", "status", "run"):
        print(__doc__, file=sys.stderr)
        return 2
    spec = _load(argv[1])
    spec["spec_path"] = os.path.abspath(argv[1])
    if argv[0] == "status":
        print(json.dumps(status(spec)))
        return 0
    return {"start": start, "stop": stop, "run": run}[argv[0]](spec)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
