"""A cheap test node (no bus) whose module defines ``check``: cfg ``unused: [keys]`` come back as
no-effect notes, ``bad: [keys]`` as problems; run as a process it is tests.agent.plain_node."""

from __future__ import annotations

import sys

from common.config import ConfigError, Note


def check(cfg: dict, source: str) -> list[str]:
    bad = list(cfg.get("bad", ()))
    if bad:
        raise ConfigError.of([(source, k, "not a good value") for k in bad])
    return [Note(source, k, "no effect (not implemented in zenav)") for k in cfg.get("unused", ())]


if __name__ == "__main__":
    from tests.agent.plain_node import main

    sys.exit(main())
