"""Checks of a fleet inventory that involve several hosts (run by ``inventory.load``)."""

from __future__ import annotations

from common.config_errors import Problems, suggest
from deploy.fleet import secured
from deploy.fleet.inventory import Inventory


def cross_checks(inv: Inventory, p: Problems) -> None:
    """Checks between hosts (each problem added to ``p``)."""
    names = inv.names()
    for h in inv.hosts:
        z = h.zenoh
        if z.router and (z.router not in names or inv.host(z.router).role != "router"):
            p.add(inv.path, f"hosts.{h.name}.zenoh.router", f"{z.router!r} is not a host with role: router"
                  + suggest(z.router, [x.name for x in inv.hosts if x.role == "router"]))
        if h.role == "router" and z.mode != "router":
            p.add(inv.path, f"hosts.{h.name}.zenoh.mode", "a router host runs Zenoh in mode: router")
    seen: dict[tuple[str, str], str] = {}
    for h in inv.hosts:  # two hosts on one machine must not share a directory
        key = (h.address, h.install_dir)
        if key in seen:
            p.add(inv.path, f"hosts.{h.name}.install_dir", f"same address and install_dir as {seen[key]}")
        seen[key] = h.name
    if inv.security.cmd_vel_acl:
        _secured_checks(inv, p)


def _secured_checks(inv: Inventory, p: Problems) -> None:
    """security.cmd_vel_acl: every robot and master runs its own router (deploy.fleet.secured)."""
    routers: dict[tuple[str, str], str] = {}
    for h in inv.hosts:
        if h.role == "robot" and not inv.masters_of(h.robot):
            p.add(inv.path, f"hosts.{h.name}", f"security.cmd_vel_acl: no master host serves robot {h.robot!r}")
        if h.role not in ("robot", "master"):
            continue
        z = h.zenoh
        if z.mode != "peer" or z.router:
            p.add(inv.path, f"hosts.{h.name}.zenoh.{'router' if z.router else 'mode'}",
                  "with security.cmd_vel_acl every robot and master runs its own Zenoh router and the master's "
                  "links to its robot's (a shared router would pass any master's cmd_vel): remove mode / router")
        for ep in secured.router_listen(h):
            key = (h.address, ep.rsplit(":", 1)[-1])
            if key in routers:
                p.add(inv.path, f"hosts.{h.name}.zenoh.listen", f"{h.address} port {key[1]} is the router port of "
                      f"{routers[key]} too: give one of them zenoh.listen: [tcp/0.0.0.0:<another port>]")
            routers[key] = h.name
