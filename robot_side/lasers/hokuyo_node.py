"""hokuyo bus node: a Hokuyo SCIP 2.0 laser (URG-04LX on USB serial, UST-10LX/20LX on TCP) publishing
LaserScan exactly as the simulator's laser does (robot_side/sim/laser.py), so nothing downstream can
tell them apart.

    python -m robot_side.lasers.hokuyo_node --config FILE [--section KEY]

Parameters: ``robot_side.lasers.hokuyo.HokuyoParams`` (urg_node names: ``ip_address`` / ``ip_port`` or
``serial_port`` / ``serial_baud``, ``frame_id``, ``angle_min`` / ``angle_max``, ``cluster``, ``skip``,
``intensity``, ``publish_intensity``, ``time_offset``, ``calibrate_time``; plus ``topic``,
``encoding_chars``, ``error_limit``, timeouts).

Published: ``topic`` (default ``scan``) LaserScan in ``frame_id``, one per (skip + 1) rotations; ranges
float32 in m, +inf for no return (error codes, outside [DMIN, DMAX]); intensities with ``intensity``.
Stamps: the sensor clock mapped to the node's clock (TM0/TM1/TM2 calibration), else receipt time.
A lost port / socket, a silent sensor or ``error_limit`` bad scans in a row end the process with exit
status 1 (``finished`` / ``exit_code``) so the agent's respawn reconnects.
"""

from __future__ import annotations

import logging

from common.config import ConfigError, load_params
from robot_side.device_node import DeviceNode, start_or_exit
from robot_side.lasers.hokuyo import HokuyoDriver, HokuyoError, HokuyoParams, open_transport, port_name

log = logging.getLogger("zenav.hokuyo")


def load(cfg: dict | None, source: str) -> HokuyoParams:
    p = load_params(HokuyoParams, cfg, source)
    if p.angle_max <= p.angle_min:
        raise ConfigError(source, "angle_max", f"must be > angle_min ({p.angle_min:g})")
    if p.intensity and p.encoding_chars != 3:
        raise ConfigError(source, "encoding_chars", "intensity (ME) data is 3-character encoded: use 3")
    if not p.topic.strip("/") or any(c in p.topic for c in "*$#? "):
        raise ConfigError(source, "topic", f"{p.topic!r} is not a topic name")
    return p


def check(cfg: dict, source: str) -> list[str]:
    load(cfg, source)
    return []


class HokuyoNode(DeviceNode):
    def __init__(self, node, p: HokuyoParams, port=None) -> None:
        super().__init__(node)
        self.p = p
        self.pub = node.publisher(p.topic)
        self.driver = HokuyoDriver(port if port is not None else open_transport(p), p,
                                   on_scan=self.pub.publish, clock=node.clock.now)
        try:
            info = self.driver.connect()
            self.driver.start()
        except Exception:
            self.driver.close()
            raise
        s, v = info.sensor, info.version
        node.log.info("hokuyo: %s (%s, serial %s, firmware %s) on %s: steps %d..%d of %d, cluster %d, skip %d, "
                      "%s, %.0f Hz, %s on %s in frame %s", v.get("PROD", s.model), s.model, v.get("SERI", "?"),
                      v.get("FIRM", "?"), port_name(p), info.start_step, info.end_step, s.ares, p.cluster, p.skip,
                      "range + intensity" if p.intensity else f"{p.encoding_chars}-char ranges",
                      1.0 / (s.scan_period * (p.skip + 1)),
                      f"clock offset {self.driver.sync.offset:.3f} s" if p.calibrate_time else "receipt stamps",
                      p.topic, p.frame_id)
        self.watch(0.2, self._check)

    def _check(self) -> None:
        d = self.driver
        if d.error is not None:
            st = d.stats
            self.device_lost("hokuyo: %s (%d scans, %d checksum errors, %d error statuses); exiting so the "
                             "agent can reconnect", d.error, st.scans, st.bad_checksum, st.error_status)

    def close(self) -> None:
        self.unwatch()
        self.driver.close()  # QT: laser off


def start(node, cfg: dict, source: str) -> HokuyoNode:
    p = load(cfg, source)
    return start_or_exit("hokuyo", lambda: HokuyoNode(node, p), HokuyoError)


if __name__ == "__main__":
    from common.runner import node_main

    raise SystemExit(node_main("hokuyo", start))
