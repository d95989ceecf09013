"""How a zenav process joins the Zenoh network.

Default: **peer mode with multicast scouting** — machines on one LAN find each other with no
address, no hosts file and no master (what replaces ROS_MASTER_URI). Explicit endpoints and client
mode (to a router) cover networks without multicast and fleets. Every field can come from the
environment so that agents pass the same settings to the processes they start:

    ZENAV_ROBOT=pioneer1  ZENAV_MODE=peer|client|router  ZENAV_CONNECT=tcp/10.0.0.2:7447,...
    ZENAV_LISTEN=tcp/0.0.0.0:7447  ZENAV_MULTICAST=1|0  ZENAV_LEASE_MS=1000  ZENAV_SHM=1|0
    ZENAV_AUTOCONNECT=greater-zid|always  ZENAV_CHILDREN=agent|mesh  ZENAV_GOSSIP=1|0
    ZENAV_ZENOH_CONFIG=/path/to/zenoh.json5   (a full Zenoh config file, e.g. with auth / TLS;
                                               the settings above are applied on top of it)
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, replace

DEFAULT_ROBOT = "robot"
# Zenoh queues 2 batches per priority toward each peer; our publishers are express (no batching), so
# that is 2 messages. When the CPU is busy and Zenoh's send thread is late by a millisecond, the third
# stream message is dropped: 1-1.5 % of a 4 x 200 Hz stream on loopback with the 2 cores saturated, none
# with 16 (a best-effort publisher still never blocks longer than Zenoh's wait_before_drop of 1 ms).
TX_QUEUE_BATCHES = 16
# 16 is also Zenoh's most (RBLEN in zenoh-transport's pipeline: a larger size panics as a link opens).


@dataclass(frozen=True)
class BusConfig:
    robot: str = DEFAULT_ROBOT
    mode: str = "peer"
    connect: tuple[str, ...] = ()
    listen: tuple[str, ...] = ()
    multicast: bool = True
    # Link lease: how long silence means a peer is gone. Zenoh's default is 10 s; 1 s makes a lost
    # machine visible (liveliness DELETE) in about a second.
    lease_ms: int = 1000
    shared_memory: bool | None = None  # None = Zenoh's default
    # Which of two scouted peers dials the other: "greater-zid" (only the peer with the greater Zenoh id;
    # routers always), as rmw_zenoh's default session config does, or "always" (Zenoh's default: both).
    # Two peers that dial each other can end up with a session that works one way only after a link loss
    # (Zenoh issue #2806 has this shape): bench/reconnect.py, 200 cut/heal cycles under load, lost 8 goals
    # and 9 latched maps with "always" (robot -> master puts and queries gone for minutes while master ->
    # robot data flowed) and none with "greater-zid".
    autoconnect: str = "greater-zid"
    # Gossip: peers tell each other of the peers they know, and a peer dials those it has no link to. Zenoh
    # does that when it hears of one, not again: a link found by gossip that closes (its lease expired
    # under load, a socket reset) is not dialled again while the peers' other links stand, so those two
    # processes hear nothing of each other for minutes, or for good. Seen: `zenav explore` got no clock
    # from the simulator for six minutes of an office run, every other process did (2026-12-01); three
    # loopback peers, one link reset, stayed apart for the 49 s watched. Multicast scouting finds a lost
    # peer again within 8 s; configured endpoints (connect) are dialled again until they answer. Off:
    # only those, for a layout where every process names every peer it needs (deploy/stack/process_group.py).
    gossip: bool = True
    zenoh_config_file: str = ""
    # How an agent's nodes join: "agent" (each node is a Zenoh client of its own agent over a loopback TCP
    # port; the agent is the one peer of its machine) or "mesh" (each node is a peer with links to every
    # other one). Zenoh peers route nothing for one another, so in a mesh a node whose link to one other
    # node does not re-form (after it was stopped past the lease, or under load) hears nothing from that
    # node while everything else flows: localization got no clock, odometry or ground truth from the
    # simulator for ~2 min after a SIGSTOP/SIGCONT, in 1 of ~20 cycles; a client re-dialled its one link
    # within ~0.05 s in 20 of 20.
    children: str = "agent"
    # Set in an agent's nodes (children="agent"): the agent's loopback endpoint, this process's one link. It
    # makes the process a client of that endpoint alone, with no scouting and no listener; access control
    # (a file's access_control) is left to the agent, which filters all that reaches the node.
    via_agent: str = ""
    # Extra listen endpoints added to whatever the file / mode gives (an agent's loopback endpoint).
    local_listen: tuple[str, ...] = ()
    # Settings given explicitly (environment / options): with a Zenoh config file, only these and the
    # ones that differ from the defaults are applied on top of the file, so the file's own mode,
    # scouting and lease win otherwise.
    explicit: tuple[str, ...] = ()

    def __post_init__(self):
        if self.mode not in ("peer", "client", "router"):
            raise ValueError(f"zenoh mode must be peer, client or router, not {self.mode!r}")
        if not self.robot or "/" in self.robot or "*" in self.robot:
            raise ValueError(f"robot name {self.robot!r} must be non-empty with no '/' or '*'")
        if self.lease_ms < 100:
            raise ValueError("lease_ms must be >= 100")
        if self.autoconnect not in ("greater-zid", "always"):
            raise ValueError(f"autoconnect must be greater-zid or always, not {self.autoconnect!r}")
        if self.children not in ("agent", "mesh"):
            raise ValueError(f"children must be agent or mesh, not {self.children!r}")

    @staticmethod
    def from_env(env: dict | None = None, **overrides) -> BusConfig:
        e = os.environ if env is None else env

        def split(v: str) -> tuple[str, ...]:
            return tuple(x.strip() for x in v.split(",") if x.strip())

        shm = e.get("ZENAV_SHM")
        names = {"ZENAV_MODE": "mode", "ZENAV_CONNECT": "connect", "ZENAV_LISTEN": "listen",
                 "ZENAV_MULTICAST": "multicast", "ZENAV_LEASE_MS": "lease_ms", "ZENAV_SHM": "shared_memory",
                 "ZENAV_AUTOCONNECT": "autoconnect", "ZENAV_CHILDREN": "children", "ZENAV_GOSSIP": "gossip"}
        explicit = tuple(f for k, f in names.items() if e.get(k, "") != "")
        cfg = BusConfig(
            robot=e.get("ZENAV_ROBOT", DEFAULT_ROBOT),
            mode=e.get("ZENAV_MODE", "peer"),
            connect=split(e.get("ZENAV_CONNECT", "")),
            listen=split(e.get("ZENAV_LISTEN", "")),
            multicast=e.get("ZENAV_MULTICAST", "1") not in ("0", "false", "no"),
            lease_ms=int(e.get("ZENAV_LEASE_MS", "1000")),
            shared_memory=None if shm is None else shm not in ("0", "false", "no"),
            zenoh_config_file=e.get("ZENAV_ZENOH_CONFIG", ""),
            autoconnect=e.get("ZENAV_AUTOCONNECT", "") or "greater-zid",
            gossip=e.get("ZENAV_GOSSIP", "1") not in ("0", "false", "no"),
            children=e.get("ZENAV_CHILDREN", "") or "agent",
            via_agent=e.get("ZENAV_VIA_AGENT", ""),
            explicit=explicit,
        )
        return replace(cfg, **overrides) if overrides else cfg

    def to_env(self) -> dict[str, str]:
        """Environment variables that reproduce this config in a child process."""
        env = {"ZENAV_ROBOT": self.robot, "ZENAV_CONNECT": ",".join(self.connect),
               "ZENAV_LISTEN": ",".join(self.listen), "ZENAV_ZENOH_CONFIG": self.zenoh_config_file}
        values = {"ZENAV_MODE": ("mode", self.mode), "ZENAV_MULTICAST": ("multicast", "1" if self.multicast else "0"),
                  "ZENAV_LEASE_MS": ("lease_ms", str(self.lease_ms)),
                  "ZENAV_AUTOCONNECT": ("autoconnect", self.autoconnect),
                  "ZENAV_GOSSIP": ("gossip", "1" if self.gossip else "0")}
        for var, (name, text) in values.items():
            if self._applies(name):
                env[var] = text
        if self.shared_memory is not None:
            env["ZENAV_SHM"] = "1" if self.shared_memory else "0"
        env["ZENAV_CHILDREN"] = self.children
        env["ZENAV_VIA_AGENT"] = self.via_agent
        return env

    def _applies(self, name: str) -> bool:
        """Whether a setting overrides the Zenoh config file (always, when there is no file)."""
        return (not self.zenoh_config_file or name in self.explicit
                or getattr(self, name) != getattr(BusConfig(), name))

    def to_zenoh(self):
        import zenoh

        conf = zenoh.Config.from_file(self.zenoh_config_file) if self.zenoh_config_file else zenoh.Config()
        if self.via_agent:
            return self._agent_node(conf)
        apply = self._applies
        if apply("mode"):
            conf.insert_json5("mode", json.dumps(self.mode))
        if self.connect:
            conf.insert_json5("connect/endpoints", json.dumps(list(self.connect)))
        if self.listen:
            conf.insert_json5("listen/endpoints", json.dumps(list(self.listen)))
        if self.local_listen:
            eps = json.loads(conf.get_json("listen/endpoints"))
            eps = eps.get(self.mode, []) if isinstance(eps, dict) else eps
            conf.insert_json5("listen/endpoints", json.dumps([*eps, *self.local_listen]))
        if apply("multicast"):
            conf.insert_json5("scouting/multicast/enabled", json.dumps(self.multicast))
        if apply("autoconnect"):
            strategy = json.dumps({"peer": {"to_router": "always", "to_peer": self.autoconnect}})
            conf.insert_json5("scouting/multicast/autoconnect_strategy", strategy)
            conf.insert_json5("scouting/gossip/autoconnect_strategy", strategy)
        if apply("gossip"):
            conf.insert_json5("scouting/gossip/enabled", json.dumps(self.gossip))
        return self._transport(conf)

    def _agent_node(self, conf):
        for key, value in (("mode", "client"), ("connect/endpoints", [self.via_agent]), ("listen/endpoints", []),
                           ("scouting/multicast/enabled", False), ("access_control/enabled", False)):
            conf.insert_json5(key, json.dumps(value))
        return self._transport(conf)

    def _transport(self, conf):
        """Link settings every session gets, an agent's node too: lease, shared memory, send queue."""
        if self._applies("lease_ms"):
            conf.insert_json5("transport/link/tx/lease", str(self.lease_ms))
            conf.insert_json5("transport/link/tx/keep_alive", "4")
        if self.shared_memory is not None:
            conf.insert_json5("transport/shared_memory/enabled", json.dumps(self.shared_memory))
        if json.loads(conf.get_json("transport/link/tx/queue/size/data")) == 2:  # a file's other value wins
            conf.insert_json5("transport/link/tx/queue/size/data", str(TX_QUEUE_BATCHES))
        return conf
