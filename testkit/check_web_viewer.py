"""Check that the web viewer served by ``zenav monitor --serve-web`` renders, in headless Chromium.

    python -m testkit.check_web_viewer --out shot.png

Starts a synthetic robot (``testkit.synthetic_monitor``) and ``zenav monitor --serve-web`` on free
loopback ports (multicast off), opens the viewer in headless Chromium driven over the DevTools
protocol, waits for the wasm app to load (~25-30 s on 2 cores) and for data to arrive, saves a
screenshot and checks it is neither blank nor the loading screen. Exit status 0 when it renders.
"""

from __future__ import annotations

import argparse
import io
import shutil
import subprocess
import sys
import tempfile
import time
import urllib.parse
import urllib.request
import uuid
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from common.ports import free_port
from deploy.stack.process_group import checkout_env
from testkit.cdp import CDP

REPO = Path(__file__).resolve().parents[1]
CHROMIUM_NAMES = ("chromium", "chromium-browser", "google-chrome")


def find_chromium() -> str | None:
    return next((p for p in map(shutil.which, CHROMIUM_NAMES) if p), None)



def _rgb(png: bytes) -> np.ndarray:
    from PIL import Image  # pillow comes with rerun-sdk

    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=np.float32)


def scene_fraction(rgb: np.ndarray) -> float:
    """Fraction of pixels in the colours only the monitor's scene draws: the costmap's yellow
    inflation band and the map's grey-green unknown area (the loading screen has neither)."""
    r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    yellow = (r > 200) & (g > 200) & (b < 120)
    unknown = (np.abs(r - 110) < 15) & (np.abs(g - 126) < 15) & (np.abs(b - 124) < 15)
    return float((yellow | unknown).mean())


@dataclass
class Verdict:
    ok: bool
    std: float  # grey-level standard deviation of the final screenshot
    diff: float  # mean absolute grey difference to the early screenshot (information only)
    text: str  # visible page text (the loading screen says "Loading")
    why: str = ""
    scene: float = 0.0  # fraction of scene-coloured pixels


def judge(early: bytes, final: bytes, page_text: str, min_std: float = 12.0,
          min_scene: float = 0.005) -> Verdict:
    """Loaded = not uniform, the scene's colours are on screen, and no loading text.

    (The early screenshot is only reported: on a fast machine it is already the loaded app.)"""
    a, b = _rgb(early).mean(axis=2), _rgb(final)
    grey = b.mean(axis=2)
    std = float(grey.std())
    diff = float(np.abs(a - grey).mean()) if a.shape == grey.shape else 255.0
    scene = scene_fraction(b)
    why = []
    if std < min_std:
        why.append(f"screenshot is nearly uniform (grey std {std:.1f} < {min_std})")
    if scene < min_scene:
        why.append(f"no map / costmap on screen ({100 * scene:.2f} % scene pixels < {100 * min_scene:.1f} %)")
    if "loading" in page_text.lower():
        why.append(f"page still says {page_text.strip()[:80]!r}")
    return Verdict(not why, std, diff, page_text, "; ".join(why), scene)


class Procs:
    """Child processes in their own session groups, all stopped by ``stop()``."""

    def __init__(self, logdir: Path) -> None:
        self.logdir, self.procs = logdir, []

    def start(self, name: str, argv: list[str], env: dict[str, str] | None = None) -> subprocess.Popen:
        log = open(self.logdir / f"{name}.log", "w")  # noqa: SIM115 - closed with the process
        p = subprocess.Popen(argv, env=env, stdout=log, stderr=subprocess.STDOUT, cwd=str(REPO),
                             start_new_session=True)
        self.procs.append((name, p, log))
        return p

    def check_alive(self) -> None:
        for name, p, _ in self.procs:
            if p.poll() is not None:
                tail = (self.logdir / f"{name}.log").read_text()[-2000:]
                raise RuntimeError(f"{name} exited with {p.returncode}:\n{tail}")

    def stop(self) -> None:
        for _name, p, log in reversed(self.procs):
            if p.poll() is None:
                p.terminate()
                try:
                    p.wait(10)
                except subprocess.TimeoutExpired:
                    p.kill()
                    p.wait(5)
            log.close()


def _wait_http(url: str, timeout: float, procs: Procs) -> None:
    end = time.monotonic() + timeout
    while True:
        try:
            with urllib.request.urlopen(url, timeout=2):
                return
        except OSError:
            procs.check_alive()
            if time.monotonic() > end:
                raise TimeoutError(f"{url} did not answer within {timeout:.0f} s") from None
            time.sleep(0.3)


def check(out: Path, timeout: float = 150.0, settle: float = 10.0, chromium: str | None = None,
          log=print) -> Verdict:
    chromium = chromium or find_chromium()
    if not chromium:
        raise FileNotFoundError("chromium not found (Debian: apt-get install chromium)")
    work = Path(tempfile.mkdtemp(prefix="zenav-webcheck-"))
    procs = Procs(work)
    zport, web, grpc, devtools = free_port(), free_port(), free_port(), free_port()
    env = checkout_env(drop_zenav=True)
    env.update(ZENAV_ROBOT="web" + uuid.uuid4().hex[:8], ZENAV_MULTICAST="0")
    try:
        procs.start("synthetic", [sys.executable, "-m", "testkit.synthetic_monitor"],
                    dict(env, ZENAV_LISTEN=f"tcp/127.0.0.1:{zport}"))
        procs.start("monitor", [sys.executable, "-m", "deploy.cli", "monitor", "--serve-web", str(web),
                                "--grpc-port", str(grpc)], dict(env, ZENAV_CONNECT=f"tcp/127.0.0.1:{zport}"))
        _wait_http(f"http://127.0.0.1:{web}/", 60, procs)
        log(f"web viewer up on port {web} (gRPC {grpc}); starting {chromium}")
        procs.start("chromium", [chromium, "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run",
                                 "--disable-dev-shm-usage", f"--remote-debugging-port={devtools}",
                                 "--window-size=1280,800", f"--user-data-dir={work / 'profile'}",
                                 "about:blank"])
        cdp = CDP.connect(devtools)
        proxy = urllib.parse.quote(f"rerun+http://127.0.0.1:{grpc}/proxy", safe="")
        t0 = time.monotonic()
        cdp.call("Page.navigate", url=f"http://127.0.0.1:{web}/?url={proxy}")
        time.sleep(3.0)  # the loading screen (a reference for "not loaded yet")
        early = cdp.screenshot()
        (work / "early.png").write_bytes(early)
        verdict = None
        while time.monotonic() - t0 < timeout:
            time.sleep(5.0)
            procs.check_alive()
            text = cdp.call("Runtime.evaluate", expression="document.body ? document.body.innerText : ''",
                            returnByValue=True).get("result", {}).get("value", "") or ""
            verdict = judge(early, cdp.screenshot(), text)
            log(f"  {time.monotonic() - t0:5.1f} s: std {verdict.std:.1f} scene {100 * verdict.scene:.2f} % "
                f"{'loaded' if verdict.ok else verdict.why}")
            if verdict.ok:
                break
        if verdict is not None and verdict.ok:
            time.sleep(settle)  # let the recording stream in and the views fit their contents
            shot = cdp.screenshot()
            verdict = judge(early, shot, verdict.text)
            out.write_bytes(shot)
            log(f"app loaded after {time.monotonic() - t0:.0f} s; screenshot: {out}")
        elif verdict is not None:
            out.write_bytes(cdp.screenshot())
        cdp.close()
        return verdict or Verdict(False, 0.0, 0.0, "", "no screenshot taken")
    finally:
        procs.stop()
        shutil.rmtree(work / "profile", ignore_errors=True)
        log(f"logs in {work}")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=Path, default=Path("web_viewer.png"), help="screenshot file (PNG)")
    ap.add_argument("--timeout", type=float, default=150.0, help="seconds to wait for the app to load")
    ap.add_argument("--settle", type=float, default=10.0, help="seconds to wait after load before the shot")
    ap.add_argument("--chromium", help="browser executable (default: chromium on PATH)")
    args = ap.parse_args(argv)
    v = check(args.out, args.timeout, args.settle, args.chromium)
    print(f"web_viewer_ok={int(v.ok)} grey_std={v.std:.1f} scene_pct={100 * v.scene:.2f}"
          + ("" if v.ok else f"  ({v.why})"))
    return 0 if v.ok else 1


if __name__ == "__main__":
    sys.exit(main())
