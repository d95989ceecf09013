"""Every benchmark explains itself: ``python bench/X.py --help`` prints its usage and exits 0 from any
directory (an argparse help string with a bare ``%`` crashed bench/amcl_real.py's --help; five scripts
found the project's packages only through the editable install)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
SCRIPTS = sorted(p.name for p in (REPO / "bench").glob("*.py") if "__main__" in p.read_text())


def test_there_are_benchmarks():
    assert len(SCRIPTS) >= 20


@pytest.mark.parametrize("script", SCRIPTS)
def test_help_prints_usage(script, tmp_path):
    proc = subprocess.run([sys.executable, str(REPO / "bench" / script), "--help"], capture_output=True,
                          text=True, cwd=tmp_path, timeout=120)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert proc.stdout.lower().startswith("usage"), proc.stdout[:500]
