"""kinect bus node: a real Kinect v1 (libfreenect) publishing exactly what the simulated depth camera
publishes (robot_side/sim/node.py), so depth_to_scan and the master side cannot tell them apart.

    python -m robot_side.kinect.node --config FILE [--section KEY]

Parameters: ``robot_side.kinect.freenect.KinectParams`` (openni names: ``depth_registration``,
``depth_mode``, ``data_skip``, ``depth_frame_id``, ``rgb_frame_id``, ``publish_tf``, plus ``device_id``,
``library``, ``topic_prefix``, ``frame_timeout``, ``open_timeout``).

Published (wall-clock stamps)::

    <topic_prefix>/image        DepthImage   float32 metres, 0 = invalid; 30 Hz / (data_skip + 1)
    <topic_prefix>/camera_info  CameraInfo   with every image
    tf_static (latched)         TFMessage    depth_link_frame_id -> depth_frame_id (publish_tf), and
                                             -> rgb_link_frame_id -> rgb_frame_id with depth_registration

How it ends (the agent's view):

* libfreenect_sync not loadable, or no Kinect at ``device_id`` -> one ``config error`` line naming the
  library / the Debian package / the device, exit status 2 (``common.runner.EXIT_CONFIG``): the agent
  marks the node FAILED and does not respawn it (a setup problem, not a crash).
* the device stops delivering (``freenect_sync_get_depth`` non-zero, or no frame for ``frame_timeout``,
  e.g. unplugged) -> exit status 1 so the agent's respawn reconnects it.
"""

from __future__ import annotations

import logging
import threading
import time

from common.config import ConfigError
from common.geometry import OPTICAL_FROM_LINK, Transform
from common.messages import Header, TransformStamped
from common.tf import StaticTFBroadcaster
from robot_side.device_node import EXIT_DEVICE_LOST, DeviceNode  # noqa: F401 - EXIT_DEVICE_LOST re-exported
from robot_side.kinect.freenect import (
    DEBIAN_PACKAGE,
    FreenectError,
    FreenectSync,
    KinectParams,
    LibraryUnavailable,
    camera_info,
    depth_image,
    load_kinect_params,
)

log = logging.getLogger("zenav.kinect")


# rgbd_launch kinect_frames.launch: camera_link -> depth (0, -0.02, 0), -> rgb (0, -0.045, 0)
DEPTH_TO_RGB = Transform.from_xyz_rpy(0.0, -0.025, 0.0, 0.0, 0.0, 0.0)


def load(cfg: dict | None, source: str) -> KinectParams:
    return load_kinect_params(cfg, source)


def check(cfg: dict, source: str) -> list[str]:
    load(cfg, source)   # the library and the device are checked at start (a missing Kinect is not a typo)
    return []


def open_library(p: KinectParams, source: str) -> FreenectSync:
    try:
        return FreenectSync(p.library)
    except LibraryUnavailable as e:
        raise ConfigError(source, "library", f"cannot load {p.library} ({e}); libfreenect is not installed: "
                                             f"apt-get install {DEBIAN_PACKAGE}") from None


def static_transforms(p: KinectParams, stamp: float = 0.0) -> list[TransformStamped]:
    out = [TransformStamped(Header(stamp, p.depth_link_frame_id), p.depth_frame_id, OPTICAL_FROM_LINK)]
    if p.depth_registration:
        out.append(TransformStamped(Header(stamp, p.depth_link_frame_id), p.rgb_link_frame_id, DEPTH_TO_RGB))
        out.append(TransformStamped(Header(stamp, p.rgb_link_frame_id), p.rgb_frame_id, OPTICAL_FROM_LINK))
    return out


class KinectNode(DeviceNode):
    def __init__(self, node, p: KinectParams, source: str, lib: FreenectSync) -> None:
        super().__init__(node)
        self.p, self.lib = p, lib
        self.frames = 0
        self.error: str | None = None
        self._stop = threading.Event()
        self._first = threading.Event()
        self._last = time.monotonic()
        prefix = p.topic_prefix.rstrip("/")
        self.pub_image = node.publisher(f"{prefix}/image")
        self.pub_info = node.publisher(f"{prefix}/camera_info")
        self._thread = threading.Thread(target=self._run, daemon=True, name="kinect")
        self._thread.start()
        if not self._first.wait(p.open_timeout):
            raise SystemExit(f"zenav kinect: no depth frame from device {p.device_id} within {p.open_timeout:g} s "
                             f"({p.library}); is the Kinect powered (12 V adapter)?")
        if self.error is not None:
            self._stop.set()
            self._thread.join(1.0)
            raise ConfigError(source, "device_id", f"{p.library} loaded but no Kinect found at device_id "
                                                   f"{p.device_id}: none attached or not powered (or held by "
                                                   f"the gspca_kinect module: modprobe -r gspca_kinect)")
        self.tf = StaticTFBroadcaster(node) if p.publish_tf else None
        if self.tf is not None:
            self.tf.send(static_transforms(p, node.clock.now()))
        node.log.info("kinect: device %d via %s, %s depth %dx%d in %s, %g Hz (data_skip %d) on %s/image",
                      p.device_id, p.library, "registered" if p.depth_registration else "unregistered",
                      640 // p.step, 480 // p.step, p.frame_id, p.publish_rate, p.data_skip, prefix)
        self.watch(min(0.5, p.frame_timeout / 2), self._check)

    def _run(self) -> None:
        p, every = self.p, self.p.data_skip + 1
        n = 0
        while not self._stop.is_set():
            try:
                raw, _ts = self.lib.get_depth(p.device_id, p.depth_format)
            except FreenectError as e:
                self.error = str(e)
                self._first.set()
                return
            self._last = time.monotonic()
            n += 1
            if (n - 1) % every == 0 and not self._stop.is_set():
                stamp = self.node.clock.now()
                img = depth_image(raw, p, stamp)   # a copy: raw is reused by the next call
                self.pub_image.publish(img)
                self.pub_info.publish(camera_info(p, stamp))
                self.frames += 1
            self._first.set()

    def _check(self) -> None:
        if self.finished.is_set():
            return
        silent = time.monotonic() - self._last
        if self.error is not None:
            why = self.error
        elif silent > self.p.frame_timeout:
            why = f"no depth frame for {silent:.1f} s"
        else:
            return
        self.device_lost("kinect: device %d lost (%s; unplugged?); exiting so the agent can restart the driver",
                         self.p.device_id, why)

    def close(self) -> None:
        self._stop.set()
        self.unwatch()
        self._thread.join(1.0)
        if not self._thread.is_alive():   # a reader blocked in the library (device gone) must not race
            self.lib.stop()               # freenect_sync_stop freeing its buffers; the exit ends it
        if getattr(self, "tf", None) is not None:
            self.tf.close()


def start(node, cfg: dict, source: str) -> KinectNode:
    p = load(cfg, source)
    return KinectNode(node, p, source, open_library(p, source))


if __name__ == "__main__":
    from common.runner import node_main

    raise SystemExit(node_main("kinect", start))
