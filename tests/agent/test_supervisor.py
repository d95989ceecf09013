"""The process supervisor in-process, with small nodes that do not use the bus (cheap to start)."""

from __future__ import annotations

import io
import os
import sys

import psutil
import pytest
import yaml

from common.child_process import child_bus_env
from common.node_spec import EXITED, FAILED, RUNNING, STOPPED, NodeSpec
from common.supervisor import Supervisor
from common.zenoh_config import BusConfig
from tests.agent.conftest import first, read_events, wait_until

PLAIN = "tests.agent.plain_node"


@pytest.fixture
def launch_dir(tmp_path, monkeypatch):
    monkeypatch.setenv("PYTHONPATH", str(__import__("pathlib").Path(__file__).resolve().parents[2]))
    return tmp_path


def plain(tmp_path, name: str, **cfg) -> NodeSpec:
    opts = {k: cfg.pop(k) for k in list(cfg) if k in NodeSpec.__dataclass_fields__}
    path = tmp_path / f"{name}.yaml"
    path.write_text(yaml.safe_dump({"log": str(tmp_path / "events.log"), **cfg}))
    return NodeSpec(name=name, module=PLAIN, config=str(path), **opts)


def make(specs, **kw) -> Supervisor:
    kw.setdefault("out", io.StringIO())
    return Supervisor(specs, BusConfig(robot="tsup", multicast=False), **kw)


def gone(pid: int) -> bool:
    try:
        return psutil.Process(pid).status() == psutil.STATUS_ZOMBIE
    except psutil.NoSuchProcess:
        return True


def test_after_starts_a_node_once_its_dependency_runs(launch_dir):
    specs = [plain(launch_dir, "merger", after=("virtualizer",)), plain(launch_dir, "virtualizer")]
    sup = make(specs).start()
    try:
        wait_until(lambda: all(st.state == RUNNING for st in sup.nodes.values()), 20, "both running")
        assert sup.start_order == ["virtualizer", "merger"]
    finally:
        sup.stop()
        assert sup.wait(20)


def test_child_output_lines_are_prefixed_with_the_node_name():
    out = io.StringIO()
    sup = make([NodeSpec(name="greeter", cmd=(sys.executable, "-c", "print('hello'); print('world')"))],
               out=out).start()
    assert sup.wait(20)
    assert "[greeter] hello\n[greeter] world\n" in out.getvalue()
    assert sup.nodes["greeter"].state == EXITED


def test_crash_loop_ends_in_failed_with_the_reason():
    code = "import sys; print('boom: bad port'); sys.exit(3)"
    sup = make([NodeSpec(name="crasher", cmd=(sys.executable, "-c", code), respawn=True, respawn_delay=0.01)],
               crash_loop=(3, 60.0)).start()
    st = sup.nodes["crasher"]
    wait_until(lambda: st.state == FAILED, 30, "crash loop detected")
    assert st.restarts == 3
    assert "crash loop" in st.detail
    assert "boom: bad port" in st.detail
    assert sup.wait(20)
    assert sup.failed


def test_required_node_ending_stops_the_launch(launch_dir):
    specs = [plain(launch_dir, "other"), plain(launch_dir, "base", required=True, crash_after=0.5)]
    sup = make(specs).start()
    assert sup.wait(30)
    assert sup.failed
    assert "base" in sup.reason
    assert sup.nodes["base"].state == FAILED
    assert sup.nodes["other"].state == STOPPED
    assert all(gone(p) for st in sup.nodes.values() for p in st.pids)


def test_shutdown_stops_stop_first_nodes_before_the_others(launch_dir):
    specs = [plain(launch_dir, "base", stop_first=True, exit_delay=0.3), plain(launch_dir, "laser"),
             plain(launch_dir, "camera")]
    sup = make(specs).start()
    log = launch_dir / "events.log"
    wait_until(lambda: all(first(read_events(log), "start", n) for n in ("base", "laser", "camera")), 20,
               "all started")
    sup.stop()
    assert sup.wait(20)
    ev = read_events(log)
    base_exit = first(ev, "exit", "base")
    assert base_exit is not None
    for n in ("laser", "camera"):
        assert first(ev, "term", n) >= base_exit, f"{n} was signalled before the base had stopped"
    # the others in reverse start order
    assert first(ev, "term", "camera") <= first(ev, "term", "laser")


def test_a_node_ignoring_sigterm_is_killed_after_the_grace_period(launch_dir):
    sup = make([plain(launch_dir, "stubborn", ignore_term=True, grandchild=True)], grace=0.5).start()
    log = launch_dir / "events.log"
    wait_until(lambda: first(read_events(log), "start", "stubborn"), 20, "started")
    gc = next(int(e.split(":")[1]) for e, *_ in read_events(log) if e.startswith("grandchild:"))
    sup.stop()
    assert sup.wait(20)
    st = sup.nodes["stubborn"]
    assert st.state == STOPPED
    assert "SIGKILL" in st.detail
    assert first(read_events(log), "term", "stubborn") is not None
    assert gone(st.pids[0])
    wait_until(lambda: gone(gc), 5, "grandchild killed with the process group")


def test_children_get_ephemeral_listen_ports_and_connect_to_the_agent():
    env = child_bus_env(BusConfig(robot="r", listen=("tcp/0.0.0.0:7447",), connect=("tcp/10.0.0.2:7447",)))
    assert env["ZENAV_LISTEN"] == "tcp/0.0.0.0:0"
    assert env["ZENAV_CONNECT"].split(",") == ["tcp/10.0.0.2:7447", "tcp/127.0.0.1:7447"]
    assert env["ZENAV_ROBOT"] == "r"


def test_children_know_the_agent_pid(launch_dir):
    out = io.StringIO()
    code = "import os; print(os.environ['ZENAV_PARENT_PID'], os.environ['ZENAV_ROBOT'])"
    sup = make([NodeSpec(name="env", cmd=(sys.executable, "-c", code))], out=out).start()
    assert sup.wait(20)
    assert f"[env] {os.getpid()} tsup" in out.getvalue()
