"""A node that exits with status 2 (a configuration error) is FAILED with the error, never respawned."""

from __future__ import annotations

import io
import sys

import yaml

from common.node_spec import FAILED, NodeSpec
from common.supervisor import Supervisor
from common.zenoh_config import BusConfig
from tests.agent.conftest import REPO


def run(spec: NodeSpec, robot: str) -> tuple[Supervisor, str]:
    status = io.StringIO()
    sup = Supervisor([spec], BusConfig(robot=robot, multicast=False), out=io.StringIO(), status=status,
                     extra_env={"PYTHONPATH": str(REPO)}).start()
    assert sup.wait(60), "the launch did not end"
    return sup, status.getvalue()


def test_exit_status_2_is_failed_with_the_reason_and_not_respawned(robot_name):
    code = ("import sys; print('zenav cfgnode: config error: f.yaml: k: unknown key'); "
            "print('f.yaml: j: 7 is out of range'); sys.exit(2)")
    spec = NodeSpec(name="cfgnode", cmd=(sys.executable, "-c", code), respawn=True, respawn_delay=0.01)
    sup, status = run(spec, robot_name)
    st = sup.nodes["cfgnode"]
    assert st.state == FAILED
    assert (st.restarts, len(st.pids), st.exit_code) == (0, 1, 2)
    assert "configuration error" in st.detail
    assert "f.yaml: k: unknown key; f.yaml: j: 7 is out of range" in st.detail
    assert "node 'cfgnode' FAILED: configuration error" in status
    assert sup.failed


def test_a_real_node_with_a_bad_parameter_file_fails_once_naming_the_file(tmp_path, robot_name):
    cfg = tmp_path / "ms.yaml"
    cfg.write_text(yaml.safe_dump({"map": "no/such/map.yaml"}))
    spec = NodeSpec(name="map_server", module="master_side.mapping.map_server_node", config=str(cfg),
                    respawn=True, respawn_delay=0.01, required=True)
    sup, _ = run(spec, robot_name)
    st = sup.nodes["map_server"]
    assert st.state == FAILED and st.restarts == 0 and len(st.pids) == 1
    assert f"{cfg}: map: file not found" in st.detail
    assert "configuration error" in sup.reason
