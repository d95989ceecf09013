"""Decode cost per scan of the laser drivers: one raw reply / telegram -> LaserScan, checksums included.

Run: python bench/drivers.py   (single process; pin with taskset -c 0 for one core)
The raw bytes come from the protocol fakes (their own encoders, written from the specifications), so the
decoder sees exactly what a device sends: Hokuyo SCIP 2.0 MD (3-char ranges) and ME (ranges + intensities)
replies, SICK S300 continuous-output telegrams (541 values, CRC-16).
Ends with: scip_decode_ms=... s300_decode_ms=...  (medians of the sensors the tutorial / BARN use:
URG-04LX MD and the S300's standard telegram)
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from robot_side.lasers.fake_hokuyo import FakeHokuyo  # noqa: E402
from robot_side.lasers.fake_s300 import FakeS300  # noqa: E402
from robot_side.lasers.s300 import S300Params, telegram_to_scan  # noqa: E402
from robot_side.lasers.scip import SensorParams, decode_scan  # noqa: E402

# PP values of the two Hokuyo families (URG-04LX: the SensorParams default; UST-10LX: 0.25 deg, 270 deg)
URG = SensorParams()
UST = SensorParams("UST-10LX", 20, 30000, 1440, 0, 1080, 540, 2400)


def timeit(fn, n: int) -> np.ndarray:
    fn()  # warm-up
    out = np.empty(n)
    for i in range(n):
        t0 = time.perf_counter()
        fn()
        out[i] = time.perf_counter() - t0
    return out * 1e3


def scip_reply(model: str, sym: str, sensor: SensorParams) -> bytes:
    """One capture reply of the fake, for the whole measurable range, no clustering."""
    fake = FakeHokuyo(model)
    echo = f"{sym}{sensor.amin:04d}{sensor.amax:04d}01001"
    return fake._scan_block(sym, echo, "99", sensor.amin, sensor.amax, 1)  # noqa: SLF001 - bench input


def main() -> None:
    argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter).parse_args()
    rows: list[tuple[str, int, int, np.ndarray]] = []
    for label, model, sym, sensor in (("Hokuyo URG-04LX MD (3-char)", "URG-04LX", "MD", URG),
                                      ("Hokuyo URG-04LX ME (+intensity)", "URG-04LX", "ME", URG),
                                      ("Hokuyo UST-10LX MD (3-char)", "UST-10LX", "MD", UST),
                                      ("Hokuyo UST-10LX ME (+intensity)", "UST-10LX", "ME", UST)):
        raw = scip_reply(model, sym, sensor)
        beams = len(decode_scan(raw, sensor).ranges)
        rows.append((label, beams, len(raw), timeit(lambda raw=raw, sensor=sensor: decode_scan(raw, sensor), 2000)))
    telegram = FakeS300(-1).telegram(1)
    p = S300Params()
    beams = len(telegram_to_scan(telegram, p).ranges)
    t = timeit(lambda: telegram_to_scan(telegram, p), 2000)
    rows.append(("SICK S300 telegram (CRC-16)", beams, len(telegram), t))

    print(f"{'decode one scan':34s} {'beams':>6s} {'bytes':>6s} {'p50 ms':>8s} {'p99 ms':>8s}")
    for label, beams, nbytes, t in rows:
        print(f"{label:34s} {beams:6d} {nbytes:6d} {np.median(t):8.3f} {np.percentile(t, 99):8.3f}")
    scip = float(np.median(rows[0][3]))
    s300 = float(np.median(rows[-1][3]))
    ust = float(np.median(rows[3][3]))
    print(f"scip_decode_ms={scip:.3f} scip_ust10_me_decode_ms={ust:.3f} s300_decode_ms={s300:.3f}")


if __name__ == "__main__":
    main()
