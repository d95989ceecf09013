"""A test node without the bus (cheap to start): logs its life to a file, can crash, ignore SIGTERM
or leave a grandchild. Same command line as a zenav node: --config FILE --section KEY --name N.

cfg: log (file), crash_after (s), exit_code, ignore_term (bool), grandchild (bool), exit_delay (s)
"""

from __future__ import annotations

import argparse
import os
import signal
import subprocess
import sys
import threading
import time

from common.runner import node_config


def log_event(path: str, event: str, name: str) -> None:
    if path:
        with open(path, "a") as f:
            f.write(f"{event} {name} {os.getpid()} {time.time():.6f}\n")


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--config")
    ap.add_argument("--section")
    ap.add_argument("--name", default="plain")
    args = ap.parse_args()
    cfg, _ = node_config(args.config, args.section)
    log, name = cfg.get("log", ""), args.name
    stop = threading.Event()

    def on_term(*_):
        log_event(log, "term", name)
        if not cfg.get("ignore_term"):
            stop.set()

    signal.signal(signal.SIGTERM, on_term)
    signal.signal(signal.SIGINT, on_term)
    if cfg.get("grandchild"):
        gc = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(600)"])
        log_event(log, f"grandchild:{gc.pid}", name)
    log_event(log, "start", name)
    print(f"{name} started", flush=True)
    deadline = time.monotonic() + cfg["crash_after"] if "crash_after" in cfg else None
    while not stop.wait(0.02):
        if deadline is not None and time.monotonic() >= deadline:
            print(f"{name} crashing on purpose", flush=True)
            log_event(log, "crash", name)
            os._exit(int(cfg.get("exit_code", 3)))
    time.sleep(float(cfg.get("exit_delay", 0.0)))
    log_event(log, "exit", name)
    return 0


if __name__ == "__main__":
    sys.exit(main())
