"""The Rerun web viewer's own files (re_viewer.js, re_viewer_bg.wasm, its index page), served by our page.

They ship inside the rerun-sdk wheel (compiled into its bindings; the SDK serves them with
``rr.serve_web_viewer``), so nothing is downloaded from the internet. That server listens on every
interface, so we never keep it running: a short-lived child process serves them on a free loopback
port, copies them into a cache folder (one per rerun version) and exits; our own server (bound where
the user asked) serves the copies.

    python -m deploy.monitor.web_assets DEST   # the child's entry point
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

from common.ports import free_port

FILES = ("re_viewer.js", "re_viewer_bg.wasm", "index.html")


def cache_dir() -> Path:
    import rerun

    base = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    return base / "zenav" / f"rerun-web-{rerun.__version__}"


def ensure_assets(timeout: float = 120.0) -> Path:
    """The cache folder holding FILES, filled on first use (a few seconds)."""
    dest = cache_dir()
    if all((dest / f).is_file() and (dest / f).stat().st_size > 0 for f in FILES):
        return dest
    dest.mkdir(parents=True, exist_ok=True)
    r = subprocess.run([sys.executable, "-m", "deploy.monitor.web_assets", str(dest)], capture_output=True,
                       text=True, timeout=timeout, cwd=str(Path(__file__).resolve().parents[2]))
    if r.returncode != 0:
        raise RuntimeError(f"could not extract the Rerun web viewer from the rerun-sdk wheel: {r.stderr[-800:]}")
    return dest


def _extract(dest: Path) -> None:
    import rerun as rr

    port = free_port()
    rr.serve_web_viewer(web_port=port, open_browser=False)
    end = time.monotonic() + 60
    for name in FILES:
        while True:
            try:
                with urllib.request.urlopen(f"http://127.0.0.1:{port}/{'' if name == 'index.html' else name}",
                                            timeout=30) as r:
                    data = r.read()
                break
            except OSError:
                if time.monotonic() > end:
                    raise
                time.sleep(0.2)
        tmp = dest / f".{name}.{os.getpid()}"
        tmp.write_bytes(data)
        tmp.replace(dest / name)  # atomic: a concurrent reader never sees half a file


if __name__ == "__main__":
    _extract(Path(sys.argv[1]))
    os._exit(0)  # the viewer server's threads would keep the process alive
