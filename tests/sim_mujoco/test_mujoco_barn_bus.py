"""A BARN world over the bus with the MuJoCo engine: `zenav robot --engine mujoco` (the Jackal on physics),
`zenav master` with zenav's best configuration and `zenav goal`, judged from ground truth by BARN's rule."""

from __future__ import annotations

from pathlib import Path

import pytest

from deploy.barn.bus import run_world_bus

REPO = Path(__file__).resolve().parents[2]
pytest.importorskip("mujoco", reason="deploy/install.sh installs it")


@pytest.mark.slow
def test_the_jackal_on_mujoco_crosses_a_barn_world_over_the_bus(tmp_path):
    out = run_world_bus(23, tmp_path, master_config=REPO / "master_side" / "config" / "jackal_barn_zenav.yaml",
                        engine="mujoco")
    run = out["run"]
    logs = "\n".join(f"--- {p.name}\n{p.read_text()[-3000:]}" for p in sorted((tmp_path / "world_23").glob("*.log")))
    assert "engine mujoco" in logs or "MuJoCo" in logs, logs  # the simulator said which engine it runs
    assert run.success, f"{run} {out['note']}\n{logs}"
    assert not run.collision
    assert len(out["cycle_ms"]) > 20
