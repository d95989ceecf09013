"""Nodes forked from the fork server (common.fork_server) look and end as `python -m` nodes do: their own
command line, session, environment and output lines; exit codes and signals reported; a module that
starts a thread at import makes the supervisor fall back to `python -m`."""

from __future__ import annotations

import io
import os
import signal
from pathlib import Path

import psutil
import pytest
import yaml

from common.node_spec import FAILED, RUNNING, NodeSpec
from common.supervisor import Supervisor
from common.zenoh_config import BusConfig
from tests.agent.conftest import wait_until

PLAIN = "tests.agent.plain_node"
REPO = Path(__file__).resolve().parents[2]


@pytest.fixture
def launch_dir(tmp_path, monkeypatch):
    monkeypatch.setenv("PYTHONPATH", f"{REPO}{os.pathsep}{tmp_path}")
    return tmp_path


def spec(tmp_path: Path, name: str, module: str = PLAIN, **cfg) -> NodeSpec:
    path = tmp_path / f"{name}.yaml"
    path.write_text(yaml.safe_dump({"log": str(tmp_path / "events.log"), **cfg}))
    return NodeSpec(name=name, module=module, config=str(path))


def make(specs, out=None, status=None) -> Supervisor:
    return Supervisor(specs, BusConfig(robot="tfork", multicast=False), out=out or io.StringIO(),
                      status=status, fork_server=True, extra_env={"FORK_TEST": "yes"})


def test_a_forked_node_has_its_own_command_line_session_environment_and_output(launch_dir):
    out = io.StringIO()
    sup = make([spec(launch_dir, "alpha")], out=out).start()
    try:
        st = sup.nodes["alpha"]
        wait_until(lambda: st.state == RUNNING and "[alpha] alpha started" in out.getvalue(), 60, "alpha up")
        proc = psutil.Process(st.pid)
        assert proc.parent().pid != os.getpid(), "expected a fork of the fork server, not a child of ours"
        assert "common.fork_server" in " ".join(proc.parent().cmdline())
        argv = [a for a in proc.cmdline() if a]
        assert argv[1:5] == ["-m", PLAIN, "--name", "alpha"], argv
        assert os.getsid(st.pid) == st.pid
        env = proc.environ()
        assert env["FORK_TEST"] == "yes" and env["ZENAV_PARENT_PID"] == str(os.getpid())
        assert proc.cwd() == os.getcwd()
    finally:
        sup.stop()
        assert sup.wait(30)
    assert sup.nodes["alpha"].exit_code == 0


def test_exit_codes_and_signals_of_forked_nodes_are_reported(launch_dir):
    sup = make([spec(launch_dir, "crasher", crash_after=0.2, exit_code=7), spec(launch_dir, "victim")]).start()
    try:
        crasher, victim = sup.nodes["crasher"], sup.nodes["victim"]
        wait_until(lambda: crasher.state == FAILED, 60, "the crasher's exit")
        assert crasher.detail.startswith("exit code 7"), crasher.detail
        wait_until(lambda: victim.state == RUNNING and victim.pid, 60, "victim running")
        os.kill(victim.pid, signal.SIGKILL)
        wait_until(lambda: victim.state == FAILED, 30, "the victim's death")
        assert victim.detail.startswith("killed by signal 9"), victim.detail
    finally:
        sup.stop()
        assert sup.wait(30)


def test_a_module_that_starts_a_thread_at_import_makes_nodes_start_with_python_m(launch_dir):
    (launch_dir / "threaded_node.py").write_text(
        "import sys, threading, time\n"
        "threading.Thread(target=time.sleep, args=(600,), daemon=True).start()\n"
        "if __name__ == '__main__':\n"
        "    print('threaded up', flush=True)\n"
        "    time.sleep(600)\n")
    status = io.StringIO()
    sup = make([spec(launch_dir, "threaded", module="threaded_node")], out=io.StringIO(), status=status).start()
    try:
        st = sup.nodes["threaded"]
        wait_until(lambda: st.state == RUNNING and st.pid, 60, "the node running")
        assert psutil.Process(st.pid).parent().pid == os.getpid()
        assert "nodes start with python -m (a module started threads" in status.getvalue()
    finally:
        sup.stop()
        assert sup.wait(30)


def test_a_modules_warm_before_fork_runs_once_in_the_server_and_every_fork_has_what_it_loaded(launch_dir):
    """``warm_before_fork()`` (common.fork_server.WARM_HOOK) runs in the server after the import: two forked
    nodes find what it loaded into another module (as numba's kernels live in theirs), loaded in the
    server's process, not in their own. (The node's module itself runs afresh as __main__.)"""
    (launch_dir / "warm_state.py").write_text("WARMED = []\n")  # like the module holding a node's kernels
    (launch_dir / "warm_node.py").write_text(
        "import os, time\n"
        "import warm_state\n"
        "def warm_before_fork():\n"
        "    warm_state.WARMED.append(os.getpid())\n"
        "if __name__ == '__main__':\n"
        "    print(f'warmed by {warm_state.WARMED} in {os.getpid()}', flush=True)\n"
        "    time.sleep(600)\n")
    out = io.StringIO()
    sup = make([spec(launch_dir, n, module="warm_node") for n in ("one", "two")], out=out).start()
    try:
        wait_until(lambda: out.getvalue().count("warmed by") == 2, 60, "both nodes up")
        parents = {psutil.Process(sup.nodes[n].pid).parent().pid for n in ("one", "two")}
        assert len(parents) == 1 and parents != {os.getpid()}, parents
        server = parents.pop()
        for n in ("one", "two"):
            assert f"[{n}] warmed by [{server}] in {sup.nodes[n].pid}" in out.getvalue(), out.getvalue()
    finally:
        sup.stop()
        assert sup.wait(30)
