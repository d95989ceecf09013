"""The Zenoh topology of a secured fleet (``security: {cmd_vel_acl: true}``): a router per host.

Every robot and master host runs a Zenoh router inside its service (``deploy.fleet.host_router``, in
front of the agent); every zenav process on the host (the agent, its nodes, ``zenav goal``, the status
probe) is a *client* of that router on the loopback address. The routers are linked from the inventory:
each master's router opens the link to its robot's router(s) and nothing else — no multicast, no gossip,
no link between two robots' groups. usrpwd everywhere: a router's ``users.txt`` names who may connect
(a robot: its own master(s) + itself; a master: itself), and the robot's router drops ``zenav/*/cmd_vel``
unless it came in over a link opened with one of its masters' names (the access control).

Why not peers: with gossip, which process opens which link is not fixed, and usrpwd identifies only the
side that opens it (a robot node opening the link to a master node is refused by the master's users
file); some joins stayed unlinked (docs/fleet.md). Here every link is configured, opened by the side
whose identity counts, and the cmd_vel check happens at one place per robot.
"""

from __future__ import annotations

from deploy import zenohconf
from deploy.fleet.inventory import Host, Inventory

PORT = 7447
RETRY = {"period_init_ms": 250, "period_max_ms": 2000, "period_increase_factor": 2}  # link back quickly


def enabled(inv: Inventory, h: Host) -> bool:
    return inv.security.cmd_vel_acl and h.role in ("robot", "master")


def router_listen(h: Host) -> list[str]:
    return list(h.zenoh.listen) or [f"tcp/0.0.0.0:{PORT}"]


def local_endpoint(h: Host) -> str:
    """Where the host's own processes reach its router (the first listen endpoint, on loopback)."""
    ep = router_listen(h)[0].split("#", 1)[0]
    return ep.replace("0.0.0.0", "127.0.0.1").replace("[::]", "[::1]")


def reach(h: Host) -> list[str]:
    """Where other hosts reach ``h``'s router (wildcards replaced by its address)."""
    return [ep.replace("0.0.0.0", h.address).replace("[::]", h.address) for ep in router_listen(h)]


def router_connect(inv: Inventory, h: Host) -> list[str]:
    out = list(h.zenoh.connect)
    if h.role == "master":  # the master opens the link: usrpwd names the side that opens it
        out += [ep for r in inv.hosts if r.role == "robot" and r.robot == h.robot for ep in reach(r)]
    return list(dict.fromkeys(out))


def router_conf(inv: Inventory, h: Host, user: str, password: str, users_file: str) -> dict:
    """The host router's Zenoh config (usrpwd both ways; the cmd_vel access control on robots)."""
    z = h.zenoh
    masters = [m.name for m in inv.masters_of(h.robot)] if h.role == "robot" else []
    conf = zenohconf.build(zenohconf.Options(
        role="router", listen=router_listen(h), connect=router_connect(inv, h), multicast=False,
        lease_ms=z.lease_ms, user=user, password=password, users_file=users_file,
        acl_cmd_vel_only=masters[0] if masters else "", tls_ca=z.tls_ca, tls_cert=z.tls_cert, tls_key=z.tls_key,
        mtls=z.mtls, shared_memory=z.shared_memory))
    if len(masters) > 1:  # several masters for one robot: all of them may drive it
        conf["access_control"]["subjects"][1]["usernames"] = masters
    conf.setdefault("connect", {})["retry"] = dict(RETRY)
    return conf


def client_conf(h: Host, user: str, password: str) -> dict:
    """The config of every zenav process on the host: a client of the host's router."""
    z = h.zenoh
    return zenohconf.build(zenohconf.Options(
        role="client", connect=[local_endpoint(h)], multicast=False, lease_ms=z.lease_ms, user=user,
        password=password, tls_ca=z.tls_ca, shared_memory=z.shared_memory))


def env_lines(h: Host, zenoh_file: str, router_file: str) -> list[str]:
    return ["ZENAV_MODE=client", "ZENAV_MULTICAST=0", f"ZENAV_LEASE_MS={h.zenoh.lease_ms}",
            f"ZENAV_CONNECT={local_endpoint(h)}", f"ZENAV_ZENOH_CONFIG={zenoh_file}",
            f"# this host's Zenoh router (zenav fleet: security.cmd_vel_acl): {router_file}"]
