"""The exploration and MRPB benches keep, for each contact, what the planner knew just before it: the local
costmaps of the last seconds and the odometry and true poses, in ``contacts/contact_<n>.npz`` of the run
(``deploy.mrpb.contacts.ContactWatch``)."""

from __future__ import annotations

import numpy as np
import pytest

from bench.contacts import MASTER, boxed_in, diagnose, local_footprint
from common.bus import Node
from common.geometry import Pose2D
from common.messages import Collision, Costmap, GoalStatus, Header, MoveBaseStatus, Odometry
from common.zenoh_config import BusConfig
from deploy.mrpb.contacts import ContactWatch
from master_side.costmap.footprint import pad_footprint
from tests.support import free_port, wait_until


def test_a_contact_leaves_a_snapshot_of_the_local_costmap_and_the_poses(tmp_path, robot_name):
    node = Node("watch_test", config=BusConfig(robot=robot_name, multicast=False,
                                               listen=(f"tcp/127.0.0.1:{free_port()}",)), use_sim_time=False)
    try:
        watch = ContactWatch(node, tmp_path / "contacts")
        costmaps, odom, truth = node.publisher("local_costmap/costmap"), node.publisher("odom"), \
            node.publisher("ground_truth")
        wall = np.zeros((40, 40), np.uint8)
        wall[:, 30] = 254  # a wall 0.75 m from the window's left edge
        for k in range(5):
            t = 100.0 + 0.1 * k
            costmaps.publish(Costmap(Header(t, "odom"), 0.025, Pose2D(-0.5, -0.5, 0.0), wall))
            odom.publish(Odometry(Header(t, "odom"), "base_link", Pose2D(0.01 * k, 0.0, 0.0).to_transform()))
            truth.publish(Odometry(Header(t, "map"), "base_link", Pose2D(0.01 * k, 0.0, 0.0).to_transform()))
        wait_until(lambda: len(watch.locals) == 5 and len(watch.truths) == 5 and len(watch.odoms) == 5, 10.0,
                   "the costmaps and poses")
        node.publisher("collision", latched=True).publish(Collision(Header(101.0, "map"), 1, 0.27, 0.1))
        path = tmp_path / "contacts" / "contact_1.npz"
        wait_until(path.exists, 10.0, "the snapshot")  # renamed into place once whole
        assert watch.snapshot_path(1) == path
        snap = np.load(path)
        assert snap["maps"].shape == (5, 40, 40) and (snap["maps"][-1] == wall).all()
        assert snap["point"].tolist() == [0.27, 0.1] and snap["resolution"] == 0.025
        assert snap["odom"].shape == (5, 4) and snap["truth"][-1, 1] == 0.04
        assert watch.count == 1 and watch.contacts == [(101.0, 0.27, 0.1)]
        assert watch.marks[0] < 0.025  # the touched point lies within a cell of the wall (x 0.25-0.275)
        # and bench/contacts.py reads it: the wall was in every map, up to the contact
        padded, padding = local_footprint(MASTER)
        assert diagnose(snap, padded, padding)[0] == "marked"
        # a goal move_base aborts is kept the same way, at the robot's true position, with the reason; one
        # reached or cancelled is not
        results = node.publisher("move_base/result")
        results.publish(MoveBaseStatus(Header(101.5, "map"), "g1", GoalStatus.SUCCEEDED))
        results.publish(MoveBaseStatus(Header(101.6, "map"), "g2", GoalStatus.PREEMPTED))
        results.publish(MoveBaseStatus(Header(102.0, "map"), "g3", GoalStatus.ABORTED, reason="boxed in"))
        abort = tmp_path / "contacts" / "abort_1.npz"
        wait_until(abort.exists, 10.0, "the abort's snapshot")
        snap = np.load(abort)
        assert snap["point"].tolist() == [0.04, 0.0] and str(snap["reason"]) == "boxed in"
        assert snap["maps"].shape == (5, 40, 40) and watch.aborts == 1
        assert sorted(p.name for p in (tmp_path / "contacts").iterdir()) == ["abort_1.npz", "contact_1.npz"]
        # bench/contacts.py says what boxed the robot in: on these poses, a wall 0.09 m beyond the nose
        ahead = np.zeros((40, 40), np.uint8)
        ahead[:, 38] = 254  # x 0.4625 m, the robot at 0.04 m, its nose 0.3302 m ahead of it
        near = boxed_in({**snap, "maps": np.array([ahead])}, pad_footprint(padded, -padding))
        assert list(near)[0] == "front" and near["front"] == pytest.approx(0.092, abs=0.002), near
        assert "rear" not in near and "left flank" not in near, near
    finally:
        node.close()
