"""The files ``zenav fleet install`` writes on a host (pure: text from the inventory, nothing runs).

Layout on a host (``D`` = install_dir): ``D/src`` the checkout, ``D/venv`` its virtual environment,
``D/etc`` zenav.env, zenoh.json5 / router.json5 / users.txt, service.json (the supervisor's
definition), ``D/run`` pid and state files, ``D/log`` service logs (supervisor). systemd units and the
udev rule go to ``<sysroot>/etc/...`` (sysroot is ``/`` except in tests).

Zenoh: mode, endpoints, multicast, lease and shared memory become ``ZENAV_*`` lines of zenav.env (the
agents pass them to their nodes; listen ports are rewritten per child); authentication and TLS go into
zenoh.json5 (``ZENAV_ZENOH_CONFIG``). With ``security.cmd_vel_acl`` robots and masters get a router of
their own (router.json5, run by ``deploy.fleet.host_router`` in front of the agent; the cmd_vel access
control is in the robot's) and their processes are its clients: ``deploy.fleet.secured``.
"""

from __future__ import annotations

import json
import secrets
from pathlib import Path

from deploy import zenohconf
from deploy.fleet import secured
from deploy.fleet.inventory import Host, Inventory

HOSTS_DIR = Path(__file__).resolve().parents[1] / "hosts"
ZENOH_PORT = 7447


def paths(h: Host) -> dict[str, str]:
    d = h.install_dir
    return {"src": f"{d}/src", "venv": f"{d}/venv", "etc": f"{d}/etc", "run": f"{d}/run", "log": f"{d}/log",
            "env": f"{d}/etc/zenav.env", "zenoh": f"{d}/etc/zenoh.json5", "users": f"{d}/etc/users.txt",
            "router": f"{d}/etc/router.json5", "kernels": f"{d}/cache/numba",
            "spec": f"{d}/etc/service.json", "zenav": f"{d}/venv/bin/zenav",
            "python": f"{d}/venv/bin/python", "unit": h.sys_path(f"/etc/systemd/system/{h.service}.service"),
            "udev": h.sys_path("/etc/udev/rules.d/99-pioneer.rules")}


def password(inv: Inventory, user: str, dry_run: bool = False) -> str:
    """The generated password of ``user`` (kept in security.secrets_dir: re-installs keep it)."""
    f = Path(inv.security.secrets_dir) / f"{user}.password"
    if f.is_file():
        return f.read_text().strip()
    pw = secrets.token_urlsafe(18)
    if not dry_run:
        f.parent.mkdir(parents=True, exist_ok=True, mode=0o700)
        f.write_text(pw + "\n")
        f.chmod(0o600)
    return pw


def _connect(inv: Inventory, h: Host) -> list[str]:
    out = list(h.zenoh.connect)
    if h.zenoh.router:
        out.append(f"tcp/{inv.host(h.zenoh.router).address}:{ZENOH_PORT}")
    return list(dict.fromkeys(out))


def _listen(h: Host) -> list[str]:
    return list(h.zenoh.listen) or ([f"tcp/0.0.0.0:{ZENOH_PORT}"] if h.role == "router" else [])


def zenoh_options(inv: Inventory, h: Host, dry_run: bool = False) -> zenohconf.Options | None:
    """Options for zenoh.json5 when the host needs one (auth, TLS, router), else None (not for the
    secured topology: ``secured``)."""
    z = h.zenoh
    pw = ""
    if z.password_file:
        pw = zenohconf.read_password(z.password_file) if not dry_run else "(from password_file)"
    if not (z.user or z.users_file or z.tls_ca or h.role == "router"):
        return None
    return zenohconf.Options(
        role=h.zenoh.mode, listen=_listen(h) if h.role == "router" else [],
        connect=_connect(inv, h) if h.role == "router" else [], multicast=_multicast(h),
        lease_ms=z.lease_ms, user=z.user, password=pw, users_file=z.users_file,
        tls_ca=z.tls_ca, tls_cert=z.tls_cert, tls_key=z.tls_key, mtls=z.mtls, shared_memory=z.shared_memory)


def _multicast(h: Host) -> bool:
    return h.zenoh.multicast if h.zenoh.multicast is not None else h.zenoh.mode != "client"


def _secured_identity(inv: Inventory, h: Host, dry_run: bool) -> tuple[str, str]:
    return h.name, password(inv, h.name, dry_run)


def zenoh_json(inv: Inventory, h: Host, dry_run: bool = False) -> str | None:
    """zenoh.json5: the Zenoh config of the host's processes (router.json5 on router hosts)."""
    note = [f"(zenav fleet: host {h.name} of {inv.path})"]
    if secured.enabled(inv, h):
        return zenohconf.render(secured.client_conf(h, *_secured_identity(inv, h, dry_run)), note)
    o = zenoh_options(inv, h, dry_run)
    return None if o is None else zenohconf.render(zenohconf.build(o), note)


def router_json(inv: Inventory, h: Host, dry_run: bool = False) -> str | None:
    """router.json5 of a secured robot / master (its own router: usrpwd, links, cmd_vel access control)."""
    if not secured.enabled(inv, h):
        return None
    conf = secured.router_conf(inv, h, *_secured_identity(inv, h, dry_run), paths(h)["users"])
    return zenohconf.render(conf, [f"(zenav fleet: router of host {h.name} of {inv.path})"])


def users_txt(inv: Inventory, h: Host, dry_run: bool = False) -> str | None:
    if not (inv.security.cmd_vel_acl and h.role in ("robot", "master")):
        return None
    # a robot: its master(s) + its own processes (these not in the cmd_vel ACL); a master: itself only
    users = [*inv.masters_of(h.robot), h] if h.role == "robot" else [h]
    return "".join(f"{u.name}:{password(inv, u.name, dry_run)}\n" for u in users)


def env_file(inv: Inventory, h: Host, dry_run: bool = False) -> str:
    p, z = paths(h), h.zenoh
    lines = [f"# {p['env']} — written by `zenav fleet install` from {inv.path} (host {h.name}); "
             "re-install to change it", f"ZENAV_FLEET_HOST={h.name}"]
    if h.robot:
        lines.append(f"ZENAV_ROBOT={h.robot}")
    if secured.enabled(inv, h):
        lines += secured.env_lines(h, p["zenoh"], p["router"])
    else:
        lines += [f"ZENAV_MODE={z.mode}", f"ZENAV_MULTICAST={1 if _multicast(h) else 0}",
                  f"ZENAV_LEASE_MS={z.lease_ms}"]
    if h.role != "router" and not secured.enabled(inv, h):
        if listen := _listen(h):
            lines.append("ZENAV_LISTEN=" + ",".join(listen))
        if connect := _connect(inv, h):
            lines.append("ZENAV_CONNECT=" + ",".join(connect))
        if zenoh_options(inv, h, dry_run) is not None:
            lines.append(f"ZENAV_ZENOH_CONFIG={p['zenoh']}")
    if z.shared_memory is not None:
        lines.append(f"ZENAV_SHM={1 if z.shared_memory else 0}")
    if h.role == "master":  # compiled kernels (deploy.warm_kernels) outside src: upgrades keep them
        lines.append(f"NUMBA_CACHE_DIR={p['kernels']}")
    for k, v in h.labels:
        lines.append(f"# label {k}={v}")
    return "\n".join(lines) + "\n"


def agent_argv(h: Host, own_router: bool = False) -> list[str]:
    """The service's command; ``own_router`` (a secured robot / master): the host's Zenoh router first,
    the agent then its child (deploy.fleet.host_router)."""
    p = paths(h)
    if h.role == "router":
        return [p["zenav"], "zenoh", "router", "--config", p["router"]]
    agent = [p["zenav"], h.role, "--config", f"{p['src']}/{h.config}", *h.args]
    return [p["python"], "-m", "deploy.fleet.host_router", p["router"], "--", *agent] if own_router else agent


def unit(h: Host, own_router: bool = False) -> str:
    """The systemd unit of the host's role, from deploy/hosts/zenav-<role>.service."""
    p = paths(h)
    text = (HOSTS_DIR / f"{h.service}.service").read_text()
    exec_line = next(line for line in text.splitlines() if line.startswith("ExecStart="))
    text = text.replace(exec_line, "ExecStart=" + " ".join(agent_argv(h, own_router)))
    text = text.replace("/etc/zenav/zenav.env", p["env"]).replace("@REPO@", p["src"])
    text = text.replace("User=zenav", f"User={h.service_user}").replace("Group=zenav", f"Group={h.service_user}")
    for old in ("deploy/hosts/install-robot.sh", "install-robot.sh"):
        text = text.replace(old, "zenav fleet install")
    return text


def service_spec(h: Host, own_router: bool = False) -> str:
    """The supervisor's definition of the service (hosts without systemd)."""
    p = paths(h)
    return json.dumps({"name": h.service, "argv": agent_argv(h, own_router), "cwd": p["src"], "env_file": p["env"],
                       "log": f"{p['log']}/{h.service}.log", "run_dir": p["run"], "restart_sec": 2.0,
                       "stop_timeout": 15.0, "no_restart_exit": [2]}, indent=2) + "\n"


def udev_rules(h: Host) -> str:
    text = (HOSTS_DIR / "99-pioneer.rules").read_text()
    if h.udev_adapter == "all":
        return text
    out, keep = [], False
    for line in text.splitlines():
        parts = line.split()
        if line.startswith("# ") and len(parts) > 2 and parts[1].isalnum() and parts[1].islower():
            keep = parts[1] == h.udev_adapter
        if not line.startswith("SUBSYSTEM") or keep:
            out.append(line)
    return "\n".join(out) + "\n"
