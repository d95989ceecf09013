"""The code base stays clean under the project's ruff rules and its type checker (pyproject.toml)."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]


def test_ruff_finds_nothing():
    ruff = shutil.which("ruff")
    if ruff is None:
        pytest.fail("ruff is not installed (deploy/install.sh --test installs it)")
    proc = subprocess.run([ruff, "check", "--no-cache", str(REPO)], capture_output=True, text=True, cwd=REPO)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-1000:]


def test_mypy_finds_no_type_error_in_common_master_side_robot_side_and_deploy():
    """The plugin contracts (move_base/contracts.py, LocalPlannerPlugin, CostmapPlugin) and every annotation
    of the four packages hold; mypy's settings are [tool.mypy] in pyproject.toml."""
    proc = subprocess.run([sys.executable, "-m", "mypy", "common", "master_side", "robot_side", "deploy"],
                          capture_output=True, text=True, cwd=REPO)
    if "No module named mypy" in proc.stderr:
        pytest.fail("mypy is not installed (deploy/install.sh --test installs it)")
    assert proc.returncode == 0, proc.stdout[-4000:] + proc.stderr[-1000:]


def test_algorithm_modules_never_import_zenoh_or_rerun():
    """Algorithms are pure: only node adapters (node.py, *_node.py, agents, CLI) touch the bus or the viewer."""
    offenders = []
    for pkg in ("robot_side", "master_side"):
        for f in (REPO / pkg).rglob("*.py"):
            adapters = ("node.py", "agent.py", "fake_localization.py", "map_saver.py")
            if f.name in adapters or f.name.endswith("_node.py"):
                continue
            text = f.read_text()
            if any(s in text for s in ("import zenoh", "import rerun", "from common.bus", "from common.tf import")):
                offenders.append(str(f.relative_to(REPO)))
    assert not offenders, offenders
    assert sys.version_info >= (3, 11)


def test_layers_never_import_upward():
    """common <- robot_side, master_side <- deploy; the two sides never import each other."""
    forbidden = {"common": ("robot_side", "master_side", "deploy"), "robot_side": ("master_side", "deploy"),
                 "master_side": ("robot_side", "deploy")}
    offenders = []
    for pkg, bad in forbidden.items():
        for f in (REPO / pkg).rglob("*.py"):
            for line in f.read_text().splitlines():
                s = line.strip()
                if s.startswith(("import ", "from ")) and any(s.split()[1].split(".")[0] == b for b in bad):
                    offenders.append(f"{f.relative_to(REPO)}: {s}")
    assert not offenders, offenders
