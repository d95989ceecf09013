"""`zenav master`: the same supervisor for the master's nodes; wait_for timeouts."""

from __future__ import annotations

import signal

import yaml

from common.node_spec import FAILED, NodeSpec
from common.supervisor import Supervisor
from common.zenoh_config import BusConfig
from tests.agent.conftest import first, read_events, wait_until
from tests.agent.test_robot_agent import States, alive

PLAIN = "tests.agent.plain_node"


def test_master_agent_runs_its_nodes_in_order_and_stops_on_sigterm(bus, agents, robot_name, tmp_path):
    node, env = bus
    states = States(node, agent="master")
    log = tmp_path / "ev.log"
    cfg = {"nodes": {
        "move_base": {"module": PLAIN, "after": ["map_server"], "params": {"log": str(log)}},
        "map_server": {"module": PLAIN, "params": {"log": str(log)}}}}
    agent = agents(cfg, robot_name, env, kind="master")
    # each node's own "start" line, logged once its SIGTERM handler is set: RUNNING (which `after` waits for)
    # means the process is spawned, and a map_server still importing on a loaded machine died of the SIGTERM
    # without its "term" line (ci179)
    for n in ("map_server", "move_base"):
        wait_until(lambda n=n: first(read_events(log), "start", n), 60, f"{n} started")
    for n in ("map_server", "move_base"):
        wait_until(lambda n=n: states.find(node=n, state="RUNNING"), 20, f"{n} RUNNING state")
    pids = set(p.pid for p in agent.children())
    agent.proc.send_signal(signal.SIGTERM)
    assert agent.wait(60) == 0
    assert not any(alive(p) for p in pids)
    ev = read_events(log)
    assert first(ev, "term", "move_base") <= first(ev, "term", "map_server")   # reverse start order
    assert "[map_server] map_server started" in agent.stdout()


def test_wait_for_a_silent_topic_fails_the_node_with_the_reason(bus, tmp_path):
    node, _ = bus
    cfg = tmp_path / "n.yaml"
    cfg.write_text(yaml.safe_dump({"log": str(tmp_path / "ev.log")}))
    spec = NodeSpec(name="merger", module=PLAIN, config=str(cfg), wait_for=("virtual_scans/0",),
                    wait_timeout=0.5, required=True)
    sup = Supervisor([spec], BusConfig(robot=node.robot, multicast=False), node=node, agent="master").start()
    assert sup.wait(30)
    st = sup.nodes["merger"]
    assert st.state == FAILED
    assert "virtual_scans/0" in st.detail
    assert sup.failed
    assert st.pids == []
