"""One BARN world the way a user runs it: `zenav robot` (simulated Jackal), `zenav master` and `zenav goal`
as separate processes over Zenoh, judged from the simulator's ground truth by BARN's rule."""

from __future__ import annotations

from pathlib import Path

import pytest

from deploy.barn_bus import run_world_bus

REPO = Path(__file__).resolve().parents[2]


@pytest.mark.slow
def test_the_jackal_crosses_a_barn_world_over_the_bus(tmp_path):
    out = run_world_bus(23, tmp_path, master_config=REPO / "master_side" / "config" / "jackal_barn_zenav.yaml")
    run = out["run"]
    logs = "\n".join(f"--- {p.name}\n{p.read_text()[-3000:]}" for p in sorted((tmp_path / "world_23").glob("*.log")))
    assert run.success, f"{run} {out['note']}\n{logs}"
    assert not run.collision
    assert len(out["cycle_ms"]) > 20  # move_base reported its control cycles
