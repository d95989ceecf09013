"""Start, stop and query a host's zenav service: systemd when the host runs it, else the pidfile
supervisor (deploy/fleet/supervise.py under install_dir).

``service_manager: auto`` (the default) asks the host: ``/run/systemd/system`` exists only when systemd
is PID 1. ``systemd`` / ``supervisor`` force one. The supervisor is started with ``setsid`` semantics
(its own session, detached from the ssh connection) and restarts the agent on failure like
``Restart=on-failure``; it does not start at boot (use systemd for that).
"""

from __future__ import annotations

import json
import shlex

from deploy.fleet import FleetError
from deploy.fleet.inventory import Host
from deploy.fleet.render import paths
from deploy.fleet.ssh import Remote

_cache: dict[tuple[str, str], str] = {}


def manager(r: Remote) -> str:
    h = r.host
    if h.service_manager != "auto":
        return h.service_manager
    key = (h.address, h.sysroot)
    if key not in _cache:
        if r.dry_run:
            return "systemd or supervisor (auto: chosen on the host)"
        out = r.text("[ -d /run/systemd/system ] && echo systemd || echo supervisor", what="detect systemd")
        _cache[key] = out.strip() or "supervisor"
    return _cache[key]


def _sup(h: Host, verb: str) -> str:
    p = paths(h)
    return f"{shlex.quote(p['python'])} {shlex.quote(p['src'] + '/deploy/fleet/supervise.py')} {verb} " \
           f"{shlex.quote(p['spec'])}"


def _systemd(r: Remote) -> bool:
    return manager(r) == "systemd"


def start(r: Remote) -> None:
    unit = f"{r.host.service}.service"
    cmd = f"systemctl start {unit}" if _systemd(r) else _sup(r.host, "start")
    r.run(cmd, what=f"start {r.host.service}", timeout=60)


def stop(r: Remote) -> None:
    unit = f"{r.host.service}.service"
    cmd = f"systemctl stop {unit}" if _systemd(r) else _sup(r.host, "stop")
    r.run(cmd, what=f"stop {r.host.service}", timeout=60)


def restart(r: Remote) -> None:
    if _systemd(r):
        r.run(f"systemctl restart {r.host.service}.service", what=f"restart {r.host.service}", timeout=60)
    else:
        stop(r)
        start(r)


def state(r: Remote) -> dict:
    """{"state": active|activating|inactive|failed|unknown, "pid", "since", "restarts", "manager", "detail"}."""
    h = r.host
    m = manager(r)
    if m == "systemd":
        out = r.text(f"systemctl show {h.service}.service -p ActiveState,SubState,MainPID,NRestarts,"
                     "ActiveEnterTimestamp,LoadState", check=False, what="systemctl show")
        kv = dict(line.split("=", 1) for line in out.splitlines() if "=" in line)
        st = kv.get("ActiveState", "unknown")
        if kv.get("LoadState") == "not-found":
            st = "not-installed"
        return {"state": st, "pid": int(kv.get("MainPID") or 0) or None, "since": kv.get("ActiveEnterTimestamp"),
                "restarts": int(kv.get("NRestarts") or 0), "manager": m, "detail": kv.get("SubState", "")}
    p = paths(h)
    out = r.text(f"if [ -f {shlex.quote(p['spec'])} ] && [ -x {shlex.quote(p['python'])} ]; then "
                 f"{_sup(h, 'status')}; else echo '{{\"state\": \"not-installed\"}}'; fi",
                 check=False, what="supervisor status")
    try:
        st = json.loads(out.strip().splitlines()[-1])
    except (ValueError, IndexError):
        raise FleetError(f"{h.name}: cannot read the service state: {out.strip()[-200:]!r}") from None
    return {**st, "manager": m, "detail": ""}


def log_command(r: Remote, node: str = "", lines: int = 100, follow: bool = False) -> str:
    """Shell line printing the service log's last ``lines`` lines, or one node's last ``lines`` (the agents
    prefix them ``[node] ``), then following it with ``follow``. A node's lines are picked before they are
    counted: picked from the log's last ``lines`` lines, ``zenav fleet logs robot1 sim -n 5`` printed nothing
    and failed whenever other nodes had logged last."""
    h = r.host
    if _systemd(r):
        whole = f"journalctl -u {h.service}.service --no-pager -o cat"
        last, coming = f"{whole} -n {lines}", f"{whole} -n 0 -f"
        follow_last = f"{last} -f"
    else:
        log = shlex.quote(f"{paths(h)['log']}/{h.service}.log")
        whole, last, coming = f"cat {log}", f"tail -n {lines} {log}", f"tail -n 0 -F {log}"
        follow_last = f"tail -n {lines} -F {log}"
    if not node:
        return follow_last if follow else last
    pick = f"grep --line-buffered -F {shlex.quote(f'[{node}] ')}"
    last = f"{whole} | {pick} | tail -n {lines}"
    return f"{{ {last}; {coming} | {pick}; }}" if follow else last


def last_errors(r: Remote, n: int = 3) -> list[str]:
    """The last lines of the service log that look like errors."""
    cmd = log_command(r, lines=400) + " | grep -E 'Traceback|Error|error:|ERROR|FAILED|exited [1-9]' " \
                                      f"| grep -v ' supervise: exited' | tail -n {4 * n}"
    out: list[str] = []
    for line in r.text(cmd, check=False, what="last errors").splitlines():
        if line.strip() and line.strip() not in out:
            out.append(line.strip())
    return out[-n:]
