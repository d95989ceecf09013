"""A Zenoh process with a fleet host's generated settings: ``python acl_proc.py ENV_FILE sub|pub KEY [TEXT]``.

sub prints each payload it receives on KEY; pub puts TEXT on KEY every 50 ms and prints its peer count
(peers and routers) once (and exits then if $ACL_PROC_EXIT_ON_PEERS is set). The bus config is the host's zenav.env
(ZENAV_* lines, ZENAV_ZENOH_CONFIG) as the agents read it; extra ZENAV_* variables of this process's
environment win (the test points a master elsewhere)."""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

import zenoh  # noqa: E402

from common.zenoh_config import BusConfig  # noqa: E402


def main() -> int:
    env_file, role, key = sys.argv[1:4]
    env = {}
    for line in Path(env_file).read_text().splitlines():
        if "=" in line and not line.startswith("#"):
            k, v = line.split("=", 1)
            env[k] = v
    env.update({k: v for k, v in os.environ.items() if k.startswith("ZENAV_")})
    session = zenoh.open(BusConfig.from_env(env).to_zenoh())
    if role == "sub":
        session.declare_subscriber(key, lambda s: print("GOT", s.payload.to_bytes().decode(), flush=True))
        print("READY", flush=True)
        time.sleep(600)
        return 0
    pub = session.declare_publisher(key)
    told = False
    for _ in range(12000):
        pub.put(sys.argv[4].encode())
        if not told:
            peers = list(session.info.peers_zid()) + list(session.info.routers_zid())
            if peers:
                print("PEERS", len(peers), flush=True)
                told = True
                if os.environ.get("ACL_PROC_EXIT_ON_PEERS"):
                    return 0
        time.sleep(0.05)
    return 0


if __name__ == "__main__":
    sys.exit(main())
