"""`zenav demo --explore ENV`: an environment that is not an MRPB building is refused in one line, exit 2,
before anything starts (the run itself: bench/explore.py, README "Exploration")."""

from __future__ import annotations

import subprocess
import sys


def test_an_unknown_building_is_refused_naming_the_known_ones():
    r = subprocess.run([sys.executable, "-m", "deploy.cli", "demo", "--explore", "nowhere"], capture_output=True,
                       text=True, timeout=120)
    assert r.returncode == 2, r.stdout + r.stderr
    assert "--explore nowhere: not an MRPB building" in r.stderr and "office02" in r.stderr, r.stderr
    assert "shopping_mall_partially_unknown" not in r.stderr  # a partially unknown map is no building to explore
