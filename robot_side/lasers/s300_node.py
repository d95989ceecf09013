"""s300 bus node: a real SICK S300 (continuous data output over RS-422) publishing the LaserScan the
simulated laser publishes (robot_side/sim/laser.py), so the master side cannot tell them apart.

    python -m robot_side.lasers.s300_node --config FILE [--section KEY]

Parameters: ``robot_side.lasers.s300.S300Params`` (cob_sick_s300 names: ``port`` - a device or a pyserial
URL -, ``baud`` (500000), ``scan_id``, ``inverted``, ``frame_id``, ``scan_duration``, ``scan_cycle_time``,
``debug``, ``communication_timeout``, ``fields: {N: {scale, start_angle, stop_angle}}``; plus ``topic``,
``range_min``, ``range_max`` and the cut ``angle_min`` / ``angle_max``).

Published::

    scan (topic)   LaserScan   every telegram (~25 Hz), wall-clock stamp = reception - scan_duration

A lost port (USB adapter unplugged) ends the process with exit status 1 so the agent's respawn reopens
it; a silent scanner (no telegram for ``communication_timeout``) is reported and waited for.
"""

from __future__ import annotations

import logging

from common.messages import LaserScan
from robot_side.device_node import DeviceNode, start_or_exit
from robot_side.lasers.s300 import S300Params, load
from robot_side.lasers.s300_driver import S300ConnectionError, S300Driver, open_port

log = logging.getLogger("zenav.s300")
__all__ = ["S300Node", "start", "check", "load"]


class S300Node(DeviceNode):
    def __init__(self, node, p: S300Params, port=None) -> None:
        super().__init__(node)
        self.p = p
        self.pub = node.publisher(p.topic)
        self._silent = False
        self._reported_crc = 0
        self.driver = S300Driver(port if port is not None else open_port(p.port, p.baud), p,
                                 on_scan=self._on_scan, clock=node.clock.now)
        fields = ", ".join(f"{n}: scale {f.scale:g} m, {f.start_angle:.4f}..{f.stop_angle:.4f} rad"
                           for n, f in sorted(p.fields.items()))
        node.log.info("s300: %s at %d baud, scan_id %d, frame '%s' on %s, range %g..%g m, fields {%s}%s",
                      p.port, p.baud, p.scan_id, p.frame_id, p.topic, p.range_min, p.range_max, fields,
                      ", inverted" if p.inverted else "")
        self.driver.start()
        self.watch(0.25, self._check)

    def _on_scan(self, scan: LaserScan) -> None:
        self.pub.publish(scan)

    def _check(self) -> None:
        d, p = self.driver, self.p
        if d.error is not None:
            self.device_lost("s300: serial I/O on %s failed (%s) after %s; exiting so the agent can reopen the "
                             "port", p.port, d.error, _counts(d.stats()))
            return
        silent = d.silent_for()
        if silent > p.communication_timeout and not self._silent:
            self._silent = True
            self.node.log.warning("s300: no telegram from scanner %d on %s for %.1f s (%s); check power, "
                                  "cable, baud (%d) and continuous data output", p.scan_id, p.port, silent,
                                  _counts(d.stats()), p.baud)
        elif silent <= p.communication_timeout and self._silent:
            self._silent = False
            self.node.log.info("s300: telegrams again on %s", p.port)
        if d.crc_errors >= 2 * max(self._reported_crc, 5):
            self._reported_crc = d.crc_errors
            self.node.log.warning("s300: %s", _counts(d.stats()))

    def close(self) -> None:
        self.unwatch()
        self.driver.close()
        if self.driver.error is None:
            log.info("s300: %s", _counts(self.driver.stats()))


def _counts(stats: dict[str, int]) -> str:
    return ", ".join(f"{k.replace('_', ' ')} {v}" for k, v in stats.items())


def check(cfg: dict, source: str) -> list[str]:
    """The node's parameters checked as ``start`` loads them (ConfigError lists every problem)."""
    load(cfg, source)
    return []


def start(node, cfg: dict, source: str) -> S300Node:
    p = load(cfg, source)
    return start_or_exit("s300", lambda: S300Node(node, p), S300ConnectionError)


if __name__ == "__main__":
    from common.runner import node_main

    raise SystemExit(node_main("s300", start))
