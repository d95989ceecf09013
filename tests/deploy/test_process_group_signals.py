"""terminate_as_interrupt(once=True): the first Ctrl-C / SIGTERM interrupts, a second one during the stop that
follows is noted and changes nothing (bench/explore.py printed a traceback and no table)."""

from __future__ import annotations

import signal
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

SCRIPT = """
import os, signal, sys, time
from deploy.stack.process_group import terminate_as_interrupt
with terminate_as_interrupt(once={once}):
    try:
        print("ready", flush=True)
        time.sleep(120)
    except KeyboardInterrupt as e:
        print("stopping after", e, flush=True)
        os.kill(os.getpid(), signal.SIGTERM)  # a second signal while the run is being stopped
        for _ in range(1000):  # the handler runs between these bytecodes
            pass
        print("stopped in order", flush=True)
"""


@pytest.mark.parametrize("once", [True, False])
def test_a_second_signal_does_not_cut_short_the_stop_with_once(once):
    p = subprocess.Popen([sys.executable, "-c", SCRIPT.format(once=once)], cwd=ROOT, text=True,
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    assert p.stdout.readline().strip() == "ready"
    p.send_signal(signal.SIGINT)
    out, err = p.communicate(timeout=60)
    assert "stopping after SIGINT" in out
    if once:
        assert p.returncode == 0 and "stopped in order" in out, err
        assert "SIGTERM: already stopping" in err
    else:
        assert p.returncode != 0 and "stopped in order" not in out
        assert "KeyboardInterrupt: SIGTERM" in err
