"""`zenav demo` ended by SIGTERM (`timeout`, `kill`, a closed terminal) stops its robot and master agents
and their nodes, as Ctrl-C does; before, they ran on with nobody left to stop them."""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
from pathlib import Path

from tests.support import wait_until

REPO = Path(__file__).resolve().parents[2]


def processes_in(work: Path) -> dict[int, str]:
    """pid -> command line of the processes running in ``work`` (the demo starts its agents there and
    their nodes inherit it)."""
    out = {}
    for d in Path("/proc").iterdir():
        if d.name.isdigit() and int(d.name) != os.getpid():
            try:
                if Path(os.readlink(d / "cwd")) == work:
                    out[int(d.name)] = (d / "cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
            except OSError:
                continue
    return out


def test_sigterm_stops_the_demo_and_every_agent_it_started(tmp_path):
    work = (tmp_path / "work").resolve()
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    demo = subprocess.Popen([sys.executable, "-m", "deploy.cli", "demo", "--world", "room", "--goals", "1",
                             "--no-monitor", "--workdir", str(work)],
                            cwd=REPO, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        def agents_up() -> bool:
            cmds = processes_in(work).values()
            return sum(" deploy.cli robot " in c or " deploy.cli master " in c for c in cmds) >= 2
        wait_until(lambda: agents_up() or demo.poll() is not None, 120, "the demo's robot and master agents")
        assert demo.poll() is None, demo.communicate()[0]
        demo.send_signal(signal.SIGTERM)
        out = demo.communicate(timeout=60)[0]
        assert demo.returncode == 1, out
        assert "interrupted (SIGTERM)" in out, out
        try:
            wait_until(lambda: not processes_in(work), 30, "every process of the demo to end")
        except AssertionError:
            raise AssertionError(f"left running: {list(processes_in(work).values())}") from None
    finally:
        if demo.poll() is None:
            demo.kill()
        for pid in processes_in(work):  # a failed run leaves nothing behind for the next tests
            with contextlib.suppress(ProcessLookupError):
                os.kill(pid, signal.SIGKILL)
