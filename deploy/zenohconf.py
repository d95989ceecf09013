"""Generate the Zenoh config files of the three topologies (pure: builds a dict, writes json5).

    peer    robot and master PCs on one LAN, multicast scouting (the default), optionally usrpwd
            authentication and — on the robot — access control: only the ``master`` user may
            publish ``zenav/*/cmd_vel`` (enforced on the robot itself: peers that connect directly
            bypass any router, see ../shared/notes/zenoh-security-and-liveliness.md)
    client  a machine that reaches the others through a router (--connect tcp/<router>:7447)
    router  ``zenav zenoh router --config F``: the hub for clients (no multicast needed)

The result is used with ``ZENAV_ZENOH_CONFIG=<file>``. ``BusConfig.to_zenoh`` applies ZENAV_MODE /
ZENAV_MULTICAST / ZENAV_LEASE_MS on top of the file, so ``env_lines`` gives the matching variables.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field

from common.zenoh_config import TX_QUEUE_BATCHES

ROLES = ("peer", "client", "router")
CMD_VEL_KEY = "zenav/*/cmd_vel"


class ZenohConfError(ValueError):
    pass


@dataclass
class Options:
    role: str = "peer"
    listen: list[str] = field(default_factory=list)
    connect: list[str] = field(default_factory=list)
    multicast: bool | None = None  # None: on for peer/router, off for client
    lease_ms: int = 1000
    user: str = ""  # usrpwd: this side's user (when it connects to others)
    password: str = ""
    users_file: str = ""  # usrpwd: dictionary_file 'user:password' lines (when others connect here)
    acl_cmd_vel_only: str = ""  # user name allowed to publish cmd_vel (others are dropped)
    tls_ca: str = ""
    tls_cert: str = ""  # this side's certificate (listen and/or connect)
    tls_key: str = ""
    mtls: bool = False
    shared_memory: bool | None = None


def _check(o: Options) -> None:
    if o.role not in ROLES:
        raise ZenohConfError(f"role must be one of {', '.join(ROLES)}, not {o.role!r}")
    if o.role == "client" and not o.connect:
        raise ZenohConfError("a client needs --connect tcp/<router>:7447")
    if o.lease_ms < 100:
        raise ZenohConfError("--lease-ms must be >= 100")
    if bool(o.user) != bool(o.password):
        raise ZenohConfError("--user and --password-file go together")
    if o.acl_cmd_vel_only and not (o.users_file or o.mtls):
        raise ZenohConfError("--acl-cmd-vel-only needs --users-file (usrpwd user names) or --mtls "
                             "(certificate common names): the rule matches an authenticated identity")
    if o.acl_cmd_vel_only and o.role == "client":
        raise ZenohConfError("access control belongs on the robot (peer) or the router, not on a client")
    for ep in (*o.listen, *o.connect):
        if "/" not in ep:
            raise ZenohConfError(f"endpoint {ep!r} must look like tcp/<host>:<port> or tls/<host>:<port>")
    tls = [*o.listen, *o.connect]
    if any(ep.startswith("tls/") for ep in tls) and not o.tls_ca:
        raise ZenohConfError("tls/ endpoints need --tls-ca (and --tls-cert/--tls-key on the listening side)")
    if o.mtls and not (o.tls_cert and o.tls_key):
        raise ZenohConfError("--mtls needs --tls-cert and --tls-key on both sides")


def acl_cmd_vel_only(user: str, usrpwd: bool = True, cert: bool = False) -> dict:
    """Access control: everything allowed, except ingress put/delete on cmd_vel unless from ``user``
    (the usrpwd user name and/or the TLS certificate common name)."""
    allowed = []  # separate subjects: within one subject the properties must ALL match
    if usrpwd:
        allowed.append({"id": "cmd_vel_user", "usernames": [user]})
    if cert:
        allowed.append({"id": "cmd_vel_cert", "cert_common_names": [user]})
    rule = {"flows": ["ingress"], "messages": ["put", "delete"], "key_exprs": [CMD_VEL_KEY]}
    return {
        "enabled": True,
        "default_permission": "allow",
        "rules": [
            {"id": "deny_cmd_vel", "permission": "deny", **rule},
            {"id": "allow_cmd_vel", "permission": "allow", **rule},
        ],
        "subjects": [{"id": "anyone"}, *allowed],
        "policies": [
            {"rules": ["deny_cmd_vel"], "subjects": ["anyone"]},
            {"rules": ["allow_cmd_vel"], "subjects": [a["id"] for a in allowed]},
        ],
    }


def build(o: Options) -> dict:
    """The Zenoh config dict for ``o`` (raises ZenohConfError with the option to fix)."""
    _check(o)
    multicast = o.multicast if o.multicast is not None else o.role != "client"
    conf: dict = {"mode": o.role}
    if o.listen:
        conf["listen"] = {"endpoints": list(o.listen)}
    if o.connect:
        conf["connect"] = {"endpoints": list(o.connect)}
    conf["scouting"] = {"multicast": {"enabled": multicast}}
    transport: dict = {"link": {"tx": {"lease": o.lease_ms, "keep_alive": 4,
                                       "queue": {"size": {"data": TX_QUEUE_BATCHES}}}}}
    usrpwd: dict[str, str] = {}
    if o.user:
        usrpwd.update(user=o.user, password=o.password)
    if o.users_file:
        usrpwd["dictionary_file"] = o.users_file
    if usrpwd:
        transport["auth"] = {"usrpwd": usrpwd}
    if o.tls_ca:
        tls: dict = {"root_ca_certificate": o.tls_ca}
        if o.tls_cert:
            if o.listen:
                tls.update(listen_certificate=o.tls_cert, listen_private_key=o.tls_key)
            if o.mtls:
                tls.update(connect_certificate=o.tls_cert, connect_private_key=o.tls_key)
        if o.mtls:
            tls["enable_mtls"] = True
        transport["link"]["tls"] = tls
    if o.shared_memory is not None:
        transport["shared_memory"] = {"enabled": o.shared_memory}
    conf["transport"] = transport
    if o.acl_cmd_vel_only:
        conf["access_control"] = acl_cmd_vel_only(o.acl_cmd_vel_only, bool(o.users_file), o.mtls)
    return conf


def render(conf: dict, argv: list[str] | None = None) -> str:
    """json5 text (plain JSON plus a header comment saying how it was made and how to use it)."""
    head = ["// Zenoh config generated by zenav (do not edit by hand: re-generate)"]
    if argv:
        head.append("//   zenav zenoh config " + " ".join(argv))
    acl = conf.get("access_control")
    if acl and not any("cert_common_names" in x for x in acl["subjects"]):
        head += ["// NOTE usrpwd names only the side that OPENS a connection: the master must connect to the",
                 "//   robot (master: --connect tcp/<robot>:7447). A connection the robot opens (e.g. by",
                 "//   multicast when the master was up first) drops the master's cmd_vel (fail-safe).",
                 "//   --mtls (certificate common names) identifies both directions."]
    head.append("// use: ZENAV_ZENOH_CONFIG=<this file>  with  " + " ".join(env_lines(conf)))
    return "\n".join(head) + "\n" + json.dumps(conf, indent=2) + "\n"


def env_lines(conf: dict) -> list[str]:
    """ZENAV_* settings that agree with ``conf`` (BusConfig applies them on top of the file)."""
    mc = conf.get("scouting", {}).get("multicast", {}).get("enabled", True)
    lease = conf.get("transport", {}).get("link", {}).get("tx", {}).get("lease", 1000)
    return [f"ZENAV_MODE={conf['mode']}", f"ZENAV_MULTICAST={1 if mc else 0}", f"ZENAV_LEASE_MS={lease}"]


def read_password(path: str) -> str:
    with open(path, encoding="utf-8") as f:
        pw = f.read().strip()
    if not pw or "\n" in pw:
        raise ZenohConfError(f"{path}: must hold one non-empty line (the password)")
    return pw
