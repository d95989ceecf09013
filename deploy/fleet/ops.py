"""``zenav fleet up | down | restart | logs | upgrade``.

up starts routers first, then robots, then masters (down: the reverse, so a robot never runs without
the master's commands being stopped first ... and its own cmd_vel timeout stops the base anyway).
upgrade is rolling: one host at a time — upload + install, restart, wait until every node the host's
config names is alive again (``deploy.fleet.probe``) — and stops at the first host that fails, saying
which hosts were upgraded and which were not.
"""

from __future__ import annotations

import json
import time

from deploy.fleet import FleetError, services
from deploy.fleet.install import install_host
from deploy.fleet.inventory import Host, Inventory
from deploy.fleet.ssh import Remote
from deploy.fleet.status import expected_nodes, probe_command


def _each(hosts: list[Host], action, dry_run: bool, echo) -> int:
    failed = 0
    for h in hosts:
        try:
            action(Remote(h, dry_run))
            if not dry_run:
                echo(f"[{h.name}] {action.__name__}: ok ({h.service})")
        except FleetError as e:
            failed += 1
            echo(f"[{h.name}] {action.__name__} FAILED: {e}")
    return failed


def up(inv: Inventory, hosts: list[Host], dry_run: bool = False, echo=print) -> int:
    return _each(hosts, services.start, dry_run, echo)


def down(inv: Inventory, hosts: list[Host], dry_run: bool = False, echo=print) -> int:
    return _each(list(reversed(hosts)), services.stop, dry_run, echo)


def restart(inv: Inventory, hosts: list[Host], dry_run: bool = False, echo=print) -> int:
    return _each(hosts, services.restart, dry_run, echo)


def alive_nodes(h: Host, seconds: float = 1.5) -> set[str]:
    out = Remote(h).text(probe_command(h, seconds), check=False, timeout=60, what="probe")
    try:
        return set(json.loads(out.strip().splitlines()[-1]).get("nodes", []))
    except (ValueError, IndexError):
        return set()


def wait_nodes(h: Host, timeout: float, echo=print) -> float:
    """Seconds until every expected node of ``h`` is alive (FleetError after ``timeout``)."""
    want = set(expected_nodes(h))
    t0 = time.monotonic()
    missing = want
    while want:
        st = services.state(Remote(h))
        if st.get("state") not in ("active", "activating"):
            raise FleetError(f"{h.name}: service {h.service} is {st.get('state')} (zenav fleet logs {h.name})")
        missing = want - alive_nodes(h)
        if not missing:
            break
        if time.monotonic() - t0 > timeout:
            raise FleetError(f"{h.name}: nodes not back within {timeout:.0f} s: {', '.join(sorted(missing))} "
                             f"(zenav fleet logs {h.name} {sorted(missing)[0]})")
        time.sleep(0.5)
    return time.monotonic() - t0


def upgrade(inv: Inventory, hosts: list[Host], timeout: float = 90.0, dry_run: bool = False, echo=print) -> int:
    done: list[str] = []
    for i, h in enumerate(hosts):
        r = Remote(h, dry_run)
        t0 = time.monotonic()
        try:
            install_host(inv, r, echo=lambda *_: None)
            was = services.state(r).get("state") if not dry_run else "active"
            if was in ("active", "activating", "failed"):
                services.restart(r)
            else:
                services.start(r)
            back = wait_nodes(h, timeout, echo) if not dry_run else 0.0
        except FleetError as e:
            rest = [x.name for x in hosts[i + 1:]]
            echo(f"zenav fleet upgrade: STOPPED at {h.name}: {e}")
            echo(f"  upgraded: {', '.join(done) or 'none'}; not upgraded: {', '.join(rest) or 'none'}"
                 f"; {h.name} may be half-way: fix it, then `zenav fleet upgrade {h.name} {' '.join(rest)}`")
            return 1
        done.append(h.name)
        if not dry_run:
            echo(f"[{h.name}] upgraded: nodes back {back:.1f} s after the restart ({time.monotonic() - t0:.1f} s "
                 "in all)")
    echo(f"zenav fleet upgrade: {len(done)} host(s) upgraded, one at a time")
    return 0


def logs(h: Host, node: str = "", lines: int = 100, follow: bool = False, dry_run: bool = False) -> int:
    r = Remote(h, dry_run)
    return r.stream(services.log_command(r, node, lines, follow))
