"""Pure parts of ``zenav doctor``: the result type, clock skew estimation, serial port check, the
costmaps' sensor checks and the effective-config summary (no zenoh session here)."""

from __future__ import annotations

import json
import os
import stat
from dataclasses import dataclass
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # imported where used: every `zenav` command imports this module
    from common.messages import CostmapSensors, ObservationSourceStatus

OK_STATES = ("PASS", "SKIP")


@dataclass
class Check:
    name: str
    status: str  # PASS | FAIL | WARN | SKIP  (only PASS and SKIP count as passed)
    detail: str = ""
    fix: str = ""

    def lines(self) -> list[str]:
        out = [f"{self.status:<4}  {self.name}" + (f": {self.detail}" if self.detail else "")]
        if self.fix and self.status not in OK_STATES:
            fix = self.fix.splitlines()
            out += [f"      fix: {fix[0]}", *(f"           {line}" for line in fix[1:])]
        return out


def _json(conf, key: str):
    try:
        raw = conf.get_json(key)
    except Exception:  # noqa: BLE001 - unknown key in this zenoh version
        return None
    return None if raw is None else json.loads(raw)


def describe_config(conf) -> dict:
    """Mode, endpoints, multicast and lease of a zenoh.Config as plain values."""
    mode = _json(conf, "mode") or "peer"

    def endpoints(kind: str) -> list[str]:
        v = _json(conf, f"{kind}/endpoints")
        if isinstance(v, dict):  # per-mode defaults
            v = v.get(mode) or []
        return list(v or [])

    mc = _json(conf, "scouting/multicast/enabled")
    return {
        "mode": mode,
        "listen": endpoints("listen"),
        "connect": endpoints("connect"),
        "multicast": True if mc is None else bool(mc),
        "multicast_address": _json(conf, "scouting/multicast/address") or "224.0.0.224:7446",
        "lease_ms": _json(conf, "transport/link/tx/lease") or 10000,
        "usrpwd_user": (_json(conf, "transport/auth/usrpwd/user") or ""),
        "access_control": bool(_json(conf, "access_control/enabled")),
    }


def skew_check(offsets: list[float], max_skew: float, sim_time: bool) -> Check:
    """``offsets`` = local receive wall time − header stamp, per message. Network latency only adds,
    so the smallest offset bounds the clock offset: > 0 robot behind, < 0 robot ahead."""
    name = "clock skew (robot stamps vs this machine)"
    if sim_time:
        return Check(name, "SKIP", "the robot publishes 'clock' (simulated time): stamps are not wall time")
    if not offsets:
        return Check(name, "SKIP", "no stamped messages received")
    est = min(offsets)
    side = "behind" if est > 0 else "ahead of"
    detail = (f"robot clock ≈ {abs(est) * 1e3:.0f} ms {side} this machine (min over {len(offsets)} "
              f"stamps of receive time − stamp; includes network latency)")
    if abs(est) <= max_skew:
        return Check(name, "PASS", detail)
    return Check(name, "WARN", detail + f" > {max_skew * 1e3:.0f} ms",
                 "synchronise the clocks: install chrony on both PCs and make the robot use the master "
                 "as its server\n(`server <master-ip> iburst` in /etc/chrony/chrony.conf; check `chronyc "
                 "tracking`). With this offset TF lookups\nextrapolate or fail (transform_tolerance) and "
                 "costmaps drop scans as too old.")


def serial_check(path: str) -> Check:
    name = f"serial port {path}"
    if not os.path.exists(path):
        return Check(name, "FAIL", "does not exist",
                     "plug in the Pioneer's USB-serial adapter; `ls -l /dev/serial/by-id/` and `lsusb` "
                     "show it;\ninstall the udev rule (deploy/hosts/install-robot.sh installs "
                     "99-pioneer.rules; match your adapter's\n"
                     "idVendor/idProduct from `udevadm info -a -n /dev/ttyUSB0`)")
    st = os.stat(path)
    real = os.path.realpath(path)
    if not stat.S_ISCHR(st.st_mode):
        return Check(name, "FAIL", f"{real} is not a character device",
                     "point --serial (and the base driver's port) at the tty, e.g. /dev/pioneer or "
                     "/dev/ttyUSB0")
    if not os.access(path, os.R_OK | os.W_OK):
        import grp

        try:
            group = grp.getgrgid(st.st_gid).gr_name
        except KeyError:
            group = str(st.st_gid)
        return Check(name, "FAIL", f"{real} (group {group}, mode {stat.filemode(st.st_mode)}) is not "
                     "readable and writable by this user",
                     f"add the user to group {group}: `sudo usermod -aG {group} $USER` (log in again); the "
                     "zenav service\nuser is in dialout (install-robot.sh)")
    return Check(name, "PASS", f"{real} character device, read/write ok")


def _look_alikes(topic: str, source: str, published: dict[str, set[str]]) -> list[str]:
    """Published topics that may be the one meant: same last name segment, or named like the source."""
    last = topic.rsplit("/", 1)[-1]
    return sorted(t for t in published if t != topic and t.rsplit("/", 1)[-1] in (last, source))


def _sensor_fix(s: ObservationSourceStatus, published: dict[str, set[str]]) -> str:
    from master_side.costmap.health import LATE, publisher_hint

    if s.state == LATE:
        return (f"'{s.topic}' arrives less often than expected_update_rate {s.expected_update_rate:g} s: check "
                f"the sensor node\n(`zenav topic hz {s.topic}`), or raise expected_update_rate in the costmap's "
                "observation source")
    if s.messages:
        return (f"messages arrive on '{s.topic}' but the costmap cannot use them: check TF from the sensor's "
                "frame to the costmap's\nglobal frame (`zenav tf tree`) and the source's sensor_frame / data_type")
    who = sorted(published.get(s.topic, ()))
    if who:
        return (f"'{s.topic}' is announced by {', '.join(who)} but nothing reached the costmap: is it publishing "
                f"(`zenav topic hz {s.topic}`)?\nis its type {s.data_type} (data_type)?")
    fix = publisher_hint(s.topic)
    alike = _look_alikes(s.topic, s.source, published)
    if alike:
        fix += "\npublished topics with a similar name: " + ", ".join(
            f"{t} ({', '.join(sorted(published[t]))})" for t in alike[:5])
    return fix


def sensor_checks(robot: str, statuses: dict[str, CostmapSensors], published: dict[str, set[str]]) -> list[Check]:
    """One check per costmap whose sources are all fine, one FAIL per late or silent source.

    ``statuses``: costmap name -> its latest ``<costmap>/sensors``; ``published``: topic -> publishing
    nodes (liveliness) of this robot, for the fix."""
    from master_side.costmap.health import summary

    if not statuses:
        return [Check(f"[{robot}] costmap sensors", "SKIP",
                      "no <costmap>/sensors status received (no costmap running, or an older zenav)")]
    out = []
    for name, msg in sorted(statuses.items()):
        bad = msg.problems()
        if not bad:
            out.append(Check(f"[{robot}] {name} sensors", "PASS", summary(msg)))
        for s in bad:
            out.append(Check(f"[{robot}] {name} source '{s.source}' on '{s.topic}' {s.state}", "FAIL",
                             s.detail, _sensor_fix(s, published)))
    return out
