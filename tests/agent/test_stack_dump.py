"""A node that is alive but silent can be asked where it is: SIGUSR1 writes every thread's stack to its
output (the agent's log of it), and the node goes on running (common/runner.py)."""

from __future__ import annotations

import signal
import subprocess
import sys

from common.zenoh_config import BusConfig
from deploy.stack.process_group import checkout_env
from tests.agent.conftest import REPO, wait_until
from tests.support import free_port


def test_sigusr1_dumps_every_threads_stack_and_the_node_goes_on(tmp_path, robot_name):
    cfg = tmp_path / "node.yaml"
    log = tmp_path / "events.log"
    cfg.write_text(f"log: {log}\ntopic: chatter\nperiod: 0.05\n")
    env = checkout_env(drop_zenav=True)
    env.update(BusConfig(robot=robot_name, multicast=False, listen=(f"tcp/127.0.0.1:{free_port()}",)).to_env())
    err = tmp_path / "stderr.txt"
    with open(err, "w") as f:
        proc = subprocess.Popen([sys.executable, "-m", "tests.agent.bus_node", "--config", str(cfg)], cwd=REPO,
                                env=env, stdout=subprocess.DEVNULL, stderr=f)
    try:
        wait_until(lambda: log.exists() and "publish" in log.read_text(), 60.0, "the node to publish")
        proc.send_signal(signal.SIGUSR1)
        wait_until(lambda: "most recent call first" in err.read_text(), 30.0, "the stack dump")
        dump = err.read_text()
        assert "runner.py" in dump  # the main thread, waiting in node_main
        assert dump.count("most recent call first") >= 3  # every thread, not only the one signalled
        assert proc.poll() is None, "the node ended on SIGUSR1"
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(60) == 0
        assert "exit" in log.read_text()
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
