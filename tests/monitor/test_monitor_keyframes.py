"""Long runs with ``--serve-web``: Rerun's gRPC server keeps a bounded history for viewers that connect
later and drops its oldest temporal messages beyond its memory limit. The latched map, logged once, would
go with them; keyframes log it again while unchanged so a late viewer still gets it."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess

import numpy as np
import pytest
import rerun as rr
from monhelp import asymmetric_grid, read_rrd

from deploy.monitor.keyframes import Keyframes
from deploy.monitor.monitor import Monitor
from tests.support import free_port, wait_until


def test_keyframes_repeat_only_entities_left_unchanged_for_their_period():
    t = [0.0]
    k = Keyframes(10.0, clock=lambda: t[0])
    k.note("world/map", "OccupancyGrid", 1.0, "map-v1")
    k.note("world/scan", "LaserScan", 1.0, "scan")  # not a keyframe kind
    t[0] = 5.0
    k.note("world/amcl_pose", "PoseStamped", 5.0, "pose")
    assert k.due() == []
    t[0] = 10.0
    assert k.due() == [("world/map", (1.0, "map-v1"))]
    t[0] = 14.0
    k.note("world/amcl_pose", "PoseStamped", 14.0, "pose2")  # logged often: never repeated
    assert k.due() == []
    t[0] = 20.0
    assert k.due() == [("world/map", (1.0, "map-v1"))]
    assert Keyframes(0.0).due() == [] and Keyframes(0.0)._last == {}


def _late_viewer_entities(grpc: int, out) -> dict:
    """What a viewer connecting now receives: the Rerun CLI as a client of the server, saving to a file."""
    proc = subprocess.Popen([shutil.which("rerun"), f"rerun+http://127.0.0.1:{grpc}/proxy", "--save", str(out)],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    sizes = []
    try:
        def settled() -> bool:  # the history streamed in: the file stopped growing for a second
            sizes.append(os.path.getsize(out) if os.path.exists(out) else 0)
            return sizes[-1] > 1_000_000 and len(sizes) > 10 and sizes[-10] == sizes[-1]
        wait_until(settled, 60.0, "the late viewer's copy of the history", period=0.1)
    finally:
        proc.send_signal(signal.SIGINT)
        proc.wait(20)
    return read_rrd(out)


@pytest.mark.skipif(shutil.which("rerun") is None, reason="the rerun CLI (rerun-sdk) is not on PATH")
@pytest.mark.filterwarnings("ignore:RRD file has no footer")  # the late viewer is stopped, not closed
def test_a_viewer_connecting_after_the_server_dropped_old_data_still_gets_the_map(tmp_path):
    """Without keyframes the map is usually gone for this late viewer (seen by hand; not asserted: at this
    small scale Rerun's history GC sometimes keeps it)."""
    grpc = free_port()
    rec = rr.RecordingStream("zenav_test_keyframes")
    rec.serve_grpc(grpc_port=grpc, server_memory_limit="4MiB")
    mon = Monitor(None, "r1", rec, subscribe=False)
    t = [0.0]
    mon.keyframes = Keyframes(8.0, clock=lambda: t[0])
    grid, _ = asymmetric_grid()
    mon.handle("map", grid)  # latched: published (and logged) once
    rng = np.random.default_rng(0)
    for i in range(100):  # then 100 x 300 kB of depth images, one a "second": the server keeps the last ~4 MB
        t[0] = float(i)
        rec.set_time("stamp", duration=1.0 + i)
        rec.log("camera/depth", rr.DepthImage(rng.random((240, 320), dtype=np.float32)))
        mon.flush_pending()
    rec.flush()
    try:
        got = _late_viewer_entities(grpc, tmp_path / "late.rrd")
    finally:
        rec.disconnect()
    assert len(got["/camera/depth"]) < 30  # the server did drop its oldest data
    assert "/world/map" in got, sorted(got)


class _Calls:
    """A stand-in recording stream: the entity of every ``log`` call, in order."""

    def __init__(self) -> None:
        self.logged: list[str] = []

    def log(self, path: str, *args, **kwargs) -> None:
        self.logged.append(path)

    def reset_time(self) -> None:
        pass

    def set_time(self, *args, **kwargs) -> None:
        pass


def test_the_monitor_logs_an_unchanged_map_again_each_keyframe_period_and_only_then():
    grid, _ = asymmetric_grid()
    for period, expected in ((10.0, 4), (0.0, 1)):  # 0: no keyframes (a file or a viewer keeps everything)
        rec, t = _Calls(), [0.0]
        mon = Monitor(None, "r1", rec, subscribe=False)
        mon.keyframes = Keyframes(period, clock=lambda t=t: t[0])
        mon.handle("map", grid)
        for i in range(1, 40):
            t[0] = float(i)
            mon.flush_pending()
        assert rec.logged.count("world/map") == expected, (period, rec.logged)
