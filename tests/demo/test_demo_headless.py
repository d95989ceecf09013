"""Issue 8 acceptance: a short headless `zenav demo` succeeds and its recording carries the scene."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from rerun.chunk import RrdReader

REPO = Path(__file__).resolve().parents[2]


def entities_with_data(path: Path) -> dict[str, set[str]]:
    """entity path -> component columns that hold at least one value."""
    out: dict[str, set[str]] = {}
    for chunk in RrdReader(str(path)).stream().to_chunks():
        rb = chunk.to_record_batch()
        cols = {n for n in rb.schema.names if ":" in n and rb.column(n).null_count < len(rb.column(n))}
        out.setdefault(str(chunk.entity_path), set()).update(cols)
    return out


@pytest.mark.slow
def test_short_headless_demo_reaches_its_goal_and_records_the_scene(tmp_path):
    rrd = tmp_path / "demo.rrd"
    env = {k: v for k, v in __import__("os").environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    # the simulator at 2x (the master follows its clock, as in tests/nav_e2e): the same scene, sooner
    proc = subprocess.run([sys.executable, "-m", "deploy.cli", "demo", "--world", "room", "--goals", "1",
                           "--speed", "2", "--save", str(rrd), "--workdir", str(tmp_path / "work")],
                          cwd=tmp_path, env=env, capture_output=True, text=True, timeout=420)
    out = proc.stdout + proc.stderr
    assert proc.returncode == 0, out[-4000:]
    assert "all 1 goals reached" in out
    assert "rerun " in out  # tells how to open the recording
    ents = entities_with_data(rrd)
    grid_entities = [e for e, c in ents.items() if "GridMap:data" in c]
    assert any(e.endswith("/world/map") for e in grid_entities), sorted(ents)
    assert any("local_costmap" in e for e in grid_entities)
    assert any("global_costmap" in e for e in grid_entities)
    assert "Points3D:positions" in ents.get("/world/scan", set())
    assert "LineStrips3D:strips" in ents.get("/world/move_base/global_plan", set())
    assert "LineStrips3D:strips" in ents.get("/world/move_base/local_plan", set())
    assert any("footprint" in e and "LineStrips3D:strips" in c for e, c in ents.items())
    tf_children = {e.rsplit("/", 1)[-1] for e, c in ents.items()
                   if e.startswith("/tf/") and "Transform3D:child_frame" in c}
    assert {"odom", "base_link", "camera_link"} <= tf_children, tf_children
