"""A test node on the bus: publishes Text on ``topic`` every ``period`` s after ``delay`` s and logs
its life (start, first publish, SIGTERM, close) to the file ``log``; with ``listen``, it logs ``heard``
for each message on that topic."""

from __future__ import annotations

import signal
import threading

from common.messages import Text
from tests.agent.plain_node import log_event


class BusTestNode:
    def __init__(self, node, cfg: dict) -> None:
        self.node, self.log, self.name = node, cfg.get("log", ""), node.name
        self.topic = cfg.get("topic", "")
        self.stop = threading.Event()
        prev = signal.getsignal(signal.SIGTERM)

        def on_term(signum, frame):
            log_event(self.log, "term", self.name)
            if callable(prev):
                prev(signum, frame)

        signal.signal(signal.SIGTERM, on_term)
        log_event(self.log, "start", self.name)
        if cfg.get("listen"):
            node.subscribe(cfg["listen"], Text, callback=lambda _m: log_event(self.log, "heard", self.name),
                           mode="queue")
        if self.topic:
            self.pub = node.publisher(self.topic)
            timing = (float(cfg.get("delay", 0.0)), float(cfg.get("period", 0.1)))
            threading.Thread(target=self._run, args=timing,
                             daemon=True).start()

    def _run(self, delay: float, period: float) -> None:
        if self.stop.wait(delay):
            return
        first = True
        while not self.stop.is_set():
            self.pub.publish(Text(data="hi"))
            if first:
                log_event(self.log, "publish", self.name)
                first = False
            self.stop.wait(period)

    def close(self) -> None:
        self.stop.set()
        log_event(self.log, "exit", self.name)


def start(node, cfg: dict, source: str) -> BusTestNode:
    return BusTestNode(node, cfg)


if __name__ == "__main__":
    from common.runner import run_main

    run_main("bus_test_node", start)
