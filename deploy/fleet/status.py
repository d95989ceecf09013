"""``zenav fleet status``: per host the service state, zenav's nodes (liveliness), topic rates, the clock
offset between hosts and the last errors — one table, then every problem with how to fix it.

Everything is asked over ssh (the machine running ``zenav fleet`` need not be on the robots' Zenoh
network): the service manager, ``deploy.fleet.probe`` in the host's venv, the log, and the host clock.
Clock offset: the host's ``clock_cmd`` (default ``date +%s.%N``) is run 5 times over one ssh connection,
each time on a line sent from here; offset = host time - midpoint of the exchange (the fastest exchange
counts). Hosts are compared with the median of all hosts' clocks and this machine's (one vote among many).
"""

from __future__ import annotations

import shlex
import statistics
import subprocess
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field

from deploy.doctor.host_checks import OK_STATES, Check
from deploy.fleet import FleetError, services
from deploy.fleet.inventory import Host, Inventory
from deploy.fleet.render import paths
from deploy.fleet.ssh import CHECKOUT, Remote, ssh_argv

MAX_OFFSET = 0.05  # s, as `zenav doctor --max-skew`
MIN_RATE = 0.5  # Hz: below this an expected topic counts as silent


@dataclass
class HostStatus:
    host: Host
    service: dict = field(default_factory=dict)
    probe: dict = field(default_factory=dict)
    expected: list[str] = field(default_factory=list)
    clock: float | None = None  # host clock - controller clock, s
    clock_rtt: float | None = None
    errors: list[str] = field(default_factory=list)
    checks: list[Check] = field(default_factory=list)


def expected_nodes(h: Host) -> list[str]:
    """The nodes the host's agent runs (its config's entries + the agent itself)."""
    if h.role == "router":
        return []
    from common.launch import load_launch

    if h.role == "robot":
        from robot_side.agent import SECTIONS
    else:
        from master_side.agent import SECTIONS
    return [f"{h.role}_agent", *(e.name for e in load_launch(str(CHECKOUT / h.config), SECTIONS).entries)]


def clock_offset(h: Host, samples: int = 5) -> tuple[float, float]:
    """(host clock - this clock, round trip) in s, from the fastest of ``samples`` exchanges."""
    loop = f"while read -r _; do {h.clock_cmd}; done"
    p = subprocess.Popen([*ssh_argv(h), loop], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                         stderr=subprocess.DEVNULL, text=True, bufsize=1)
    best: tuple[float, float] | None = None
    try:
        for _ in range(samples):
            t0 = time.time()
            p.stdin.write("x\n")
            p.stdin.flush()
            line = p.stdout.readline()
            t1 = time.time()
            if not line.strip():
                raise FleetError(f"{h.name}: clock command {h.clock_cmd!r} printed nothing")
            off = float(line.strip()) - (t0 + t1) / 2
            if best is None or t1 - t0 < best[1]:
                best = (off, t1 - t0)
    except ValueError:
        raise FleetError(f"{h.name}: clock command {h.clock_cmd!r} printed {line.strip()!r}, not seconds") from None
    finally:
        p.stdin.close()
        try:
            p.wait(timeout=5)
        except subprocess.TimeoutExpired:
            p.kill()
    return best


def probe_command(h: Host, seconds: float) -> str:
    p = {k: shlex.quote(v) for k, v in paths(h).items()}
    return (f"cd {p['src']} && set -a && . {p['env']} && set +a && {p['python']} -m deploy.fleet.probe "
            f"--robot {shlex.quote(h.robot)} --topics {shlex.quote(','.join(h.expect_topics))} --seconds {seconds}")


def gather(h: Host, seconds: float = 2.0) -> HostStatus:
    import json

    st, r = HostStatus(h), Remote(h)
    try:
        st.service = services.state(r)
    except FleetError as e:
        st.service = {"state": "unreachable", "detail": str(e)}
        return st

    def clock() -> None:
        try:
            st.clock, st.clock_rtt = clock_offset(h)
        except FleetError as e:
            st.errors.append(str(e))

    with ThreadPoolExecutor(max_workers=1) as ex:  # the clock exchange while the probe listens
        clocked = ex.submit(clock)
        st.expected = expected_nodes(h)
        if st.service.get("state") == "active" and h.role != "router":
            out = r.text(probe_command(h, seconds), check=False, timeout=60, what="probe")
            try:
                st.probe = json.loads(out.strip().splitlines()[-1])
            except (ValueError, IndexError):
                st.probe = {"error": f"probe failed: {out.strip()[-300:]}"}
        clocked.result()
    if st.service.get("state") != "not-installed":
        st.errors += services.last_errors(r)
    return st


def reference_clock(statuses: list[HostStatus]) -> float:
    """The median of the hosts' clocks and this machine's (one vote: with two hosts it decides which one
    is off)."""
    return statistics.median([0.0, *(s.clock for s in statuses if s.clock is not None)])


def evaluate(statuses: list[HostStatus]) -> None:
    """Fill each HostStatus.checks: service, nodes, topics, clock."""
    ref = reference_clock(statuses)
    robots_up = {s.host.robot for s in statuses if s.host.role == "robot" and "robot_agent" in s.probe.get("nodes", [])}
    for s in statuses:
        h, c = s.host, s.checks
        state = s.service.get("state", "unknown")
        if state == "active" and s.service.get("restarts"):
            c.append(Check("service", "WARN", f"{h.service} active but restarted {s.service['restarts']} time(s) "
                           "(crashing?)", f"zenav fleet logs {h.name}   (why it exits), then zenav fleet restart "
                           f"{h.name}"))
        elif state == "active":
            c.append(Check("service", "PASS", f"{h.service} active ({s.service.get('manager')}, pid "
                           f"{s.service.get('pid')}, restarts {s.service.get('restarts', 0)})"))
        else:
            fix = {"not-installed": f"zenav fleet install {h.name}",
                   "unreachable": "check the host is up and its sshd, address and ssh key in the inventory"}.get(
                state, f"zenav fleet up {h.name}   (why it stopped: zenav fleet logs {h.name})")
            c.append(Check("service", "FAIL", f"{h.service} {state} {s.service.get('detail', '')}".strip(), fix))
        if state == "active" and h.role != "router":
            if s.probe.get("error"):
                c.append(Check("zenoh", "FAIL", s.probe["error"], f"check {paths(h)['env']} and the Zenoh "
                               f"config; `zenav fleet logs {h.name}`"))
            nodes = set(s.probe.get("nodes", []))
            missing = [n for n in s.expected if n not in nodes]
            if missing:
                c.append(Check("nodes", "FAIL", f"missing {', '.join(missing)} ({len(nodes)} alive)",
                               f"zenav fleet logs {h.name} {missing[0]}   (why it died), then "
                               f"zenav fleet restart {h.name}"))
            elif s.expected:
                c.append(Check("nodes", "PASS", f"{len(s.expected)} expected nodes alive"))
            if h.role == "master" and h.robot in robots_up and "robot_agent" not in nodes and not s.probe.get("error"):
                c.append(Check("link", "FAIL", f"robot {h.robot}'s nodes run but are not seen from {h.name}",
                               f"the Zenoh link from {h.name} to the robot: `zenav fleet logs {h.name}` (its "
                               "router's line says where it links to); the robot's address and port 7447"))
            for t, hz in sorted(s.probe.get("rates", {}).items()):
                if hz < MIN_RATE:
                    c.append(Check(f"topic {t}", "FAIL", f"{hz:.1f} Hz on zenav/{h.robot}/{t}",
                                   f"zenav fleet logs {h.name}; `zenav --robot {h.robot} topic info {t}` "
                                   "shows who should publish it"))
        if s.clock is not None:
            d = s.clock - ref
            detail = f"{d * 1e3:+.0f} ms vs the median clock (rtt {s.clock_rtt * 1e3:.0f} ms)"
            if abs(d) > MAX_OFFSET:
                c.append(Check("clock", "WARN", detail,
                               f"synchronise {h.name}'s clock: chrony on every host, robots using the master "
                               f"as server\n(`server <master-ip> iburst` in /etc/chrony/chrony.conf, then "
                               "`chronyc tracking`); TF and costmaps reject stale stamps"))
            else:
                c.append(Check("clock", "PASS", detail))


def _cell(s: HostStatus, ref: float) -> list[str]:
    h = s.host
    nodes = set(s.probe.get("nodes", []))
    n_ok = sum(1 for n in s.expected if n in nodes)
    rates = " ".join(f"{t}:{hz:.0f}" for t, hz in sorted(s.probe.get("rates", {}).items())) or "-"
    clock = "-" if s.clock is None else f"{(s.clock - ref) * 1e3:+.0f}ms"
    return [h.name, h.role, h.robot or "-", s.service.get("state", "?"),
            f"{n_ok}/{len(s.expected)}" if s.expected else "-", rates, clock,
            "PROBLEM" if any(c.status not in OK_STATES for c in s.checks) else "ok"]


def table(statuses: list[HostStatus]) -> str:
    ref = reference_clock(statuses)
    head = ["HOST", "ROLE", "ROBOT", "SERVICE", "NODES", "RATES (Hz)", "CLOCK", "STATUS"]
    rows = [head, *(_cell(s, ref) for s in statuses)]
    widths = [max(len(r[i]) for r in rows) for i in range(len(head))]
    return "\n".join("  ".join(v.ljust(w) for v, w in zip(r, widths)).rstrip() for r in rows)


def report(statuses: list[HostStatus]) -> tuple[str, int]:
    """The text printed by ``zenav fleet status`` and the number of problems."""
    lines, bad = [table(statuses), ""], 0
    for s in statuses:
        problems = [c for c in s.checks if c.status not in OK_STATES]
        bad += len(problems)
        for c in problems:
            lines += [f"{s.host.name}: " + c.lines()[0].strip(), *c.lines()[1:]]
        for e in s.errors[-3:]:
            lines.append(f"{s.host.name}: last error: {e[:200]}")
    lines.append(f"zenav fleet status: {len(statuses)} host(s), "
                 + (f"{bad} problem(s)" if bad else "all fine"))
    return "\n".join(lines), bad


def status(inv: Inventory, hosts: list[Host], seconds: float = 2.0) -> tuple[list[HostStatus], str, int]:
    with ThreadPoolExecutor(max_workers=min(8, len(hosts) or 1)) as ex:
        statuses = list(ex.map(lambda h: gather(h, seconds), hosts))
    evaluate(statuses)
    text, bad = report(statuses)
    return statuses, text, bad
