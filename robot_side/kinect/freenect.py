"""Kinect (v1) depth through libfreenect's C sync wrapper (ctypes), and the pure conversion of its frames
to the ``DepthImage`` / ``CameraInfo`` the simulated depth camera publishes (robot_side/sim/depth_camera.py).

C API used (OpenKinect/libfreenect ``wrappers/c_sync/libfreenect_sync.h``; see docs/kinect.md)::

    int  freenect_sync_get_depth(void **depth, uint32_t *timestamp, int index, freenect_depth_format fmt);
    void freenect_sync_stop(void);

``freenect_sync_get_depth`` blocks until the next frame (30 Hz), returns non-zero when device ``index``
cannot be opened, and hands out a library-owned 640x480 uint16 buffer that is valid only until the next
call: the conversion below copies it. FREENECT_DEPTH_MM / FREENECT_DEPTH_REGISTERED frames are
millimetres with 0 = no reading; the published depth is float32 metres, 0 = invalid (as the simulator).
"""

from __future__ import annotations

import ctypes
from dataclasses import dataclass

import numpy as np

from common.config import load_params, param
from common.messages import CameraInfo, DepthImage, Header

__all__ = ["KinectParams", "FreenectSync", "FreenectError", "LibraryUnavailable", "load_kinect_params",
           "decimation", "intrinsics", "camera_info", "depth_image", "mm_to_metres"]

# include/libfreenect.h: freenect_depth_format / freenect_resolution
FREENECT_DEPTH_11BIT, FREENECT_DEPTH_10BIT = 0, 1
FREENECT_DEPTH_REGISTERED, FREENECT_DEPTH_MM = 4, 5
FREENECT_RESOLUTION_MEDIUM = 1            # VGA 640x480, the only depth resolution of the Kinect v1
WIDTH, HEIGHT, RATE_HZ = 640, 480, 30.0
# Depth (IR) camera focal length at VGA from the device's zero-plane data as libfreenect uses it
# (src/registration.c: reference_distance 120 mm / (2 * reference_pixel_size 0.1042 mm)) = 575.8 px.
DEPTH_FOCAL_VGA = 120.0 / (2 * 0.1042)
# Registered depth is aligned to the RGB camera: openni_camera's rgb_focal_length_VGA = 525 px.
RGB_FOCAL_VGA = 525.0
# openni depth_mode -> decimation of the VGA frame (openni_camera subsamples: every step-th pixel)
DEPTH_MODES = {2: 1, 5: 2, 8: 4}
DEBIAN_PACKAGE = "libfreenect0.5"


@dataclass(frozen=True)
class KinectParams:
    library: str = param("libfreenect_sync.so.0.5", doc="libfreenect_sync: a file path or a name for dlopen")
    device_id: int = param(0, lo=0, hi=63, doc="libfreenect device index (0 = first Kinect; openni's '#1')")
    depth_registration: bool = param(False, doc="depth aligned to the RGB camera (FREENECT_DEPTH_REGISTERED, "
                                                "rgb_frame_id, RGB intrinsics) instead of FREENECT_DEPTH_MM")
    depth_mode: int = param(2, choices=tuple(DEPTH_MODES), doc="openni depth mode: 2 VGA, 5 QVGA, 8 QQVGA "
                                                               "(30 Hz; QVGA/QQVGA by decimation)")
    data_skip: int = param(0, lo=0, hi=1000, doc="frames dropped for each one published (openni driver)")
    depth_frame_id: str = param("camera_depth_optical_frame", doc="optical frame of the depth image")
    rgb_frame_id: str = param("camera_rgb_optical_frame", doc="optical frame of registered depth")
    publish_tf: bool = param(True, doc="static TF depth_link_frame_id -> depth_frame_id (and the rgb frames "
                                       "with depth_registration), as openni.launch's publish_tf")
    depth_link_frame_id: str = param("camera_depth_frame", doc="x-forward frame of the depth camera")
    rgb_link_frame_id: str = param("camera_rgb_frame", doc="x-forward frame of the RGB camera")
    topic_prefix: str = param("camera/depth", doc="publishes <prefix>/image and <prefix>/camera_info")
    frame_timeout: float = param(2.0, lo=0.1, hi=60.0, unit="s",
                                 doc="no frame for this long: the Kinect is gone, the node exits (respawn)")
    open_timeout: float = param(10.0, lo=0.5, hi=120.0, unit="s", doc="wait for the first frame at start")

    @property
    def step(self) -> int:
        return DEPTH_MODES[self.depth_mode]

    @property
    def frame_id(self) -> str:
        return self.rgb_frame_id if self.depth_registration else self.depth_frame_id

    @property
    def depth_format(self) -> int:
        return FREENECT_DEPTH_REGISTERED if self.depth_registration else FREENECT_DEPTH_MM

    @property
    def publish_rate(self) -> float:
        return RATE_HZ / (self.data_skip + 1)


def load_kinect_params(mapping: dict | None, source: str = "<config>", section: str | None = None) -> KinectParams:
    return load_params(KinectParams, mapping, source, section)


# ----------------------------------------------------------------------------- pure conversion
def decimation(depth_mode: int) -> int:
    return DEPTH_MODES[depth_mode]


def intrinsics(registered: bool, step: int = 1) -> tuple[int, int, float, float, float, float]:
    """(width, height, fx, fy, cx, cy) of the published image: VGA values divided by the decimation
    step (pixel u' of the decimated image is pixel step * u' of the VGA frame)."""
    f = RGB_FOCAL_VGA if registered else DEPTH_FOCAL_VGA
    cx, cy = (WIDTH - 1) / 2, (HEIGHT - 1) / 2
    return WIDTH // step, HEIGHT // step, f / step, f / step, cx / step, cy / step


def camera_info(p: KinectParams, stamp: float = 0.0) -> CameraInfo:
    w, h, fx, fy, cx, cy = intrinsics(p.depth_registration, p.step)
    return CameraInfo(Header(stamp, p.frame_id), w, h, fx, fy, cx, cy)


def mm_to_metres(raw_mm: np.ndarray, step: int = 1) -> np.ndarray:
    """uint16 millimetres (0 = no reading) -> float32 metres (0 stays 0 = invalid), every step-th pixel.
    Always a new array (the library's buffer is reused by the next call)."""
    sub = raw_mm[::step, ::step] if step > 1 else raw_mm
    out = sub.astype(np.float32)
    out *= np.float32(0.001)
    return out


def depth_image(raw_mm: np.ndarray, p: KinectParams, stamp: float = 0.0) -> DepthImage:
    return DepthImage(Header(stamp, p.frame_id), mm_to_metres(raw_mm, p.step))


# ----------------------------------------------------------------------------- ctypes binding
class FreenectError(RuntimeError):
    """A libfreenect_sync call failed (no device at that index, or the device went away)."""


class LibraryUnavailable(FreenectError):
    """libfreenect_sync cannot be loaded (not installed) or lacks the sync API."""


class FreenectSync:
    """The few functions of libfreenect_sync zenav needs. Not thread-safe: one reader thread."""

    def __init__(self, library: str) -> None:
        self.library = library
        try:
            self._lib = ctypes.CDLL(library)
            get = self._lib.freenect_sync_get_depth
            stop = self._lib.freenect_sync_stop
        except (OSError, AttributeError) as e:
            raise LibraryUnavailable(str(e)) from None
        get.argtypes = [ctypes.POINTER(ctypes.c_void_p), ctypes.POINTER(ctypes.c_uint32), ctypes.c_int,
                        ctypes.c_int]
        get.restype = ctypes.c_int
        stop.argtypes, stop.restype = [], None
        self._get, self._stop = get, stop
        self._buf, self._ts = ctypes.c_void_p(), ctypes.c_uint32()

    def get_depth(self, index: int, fmt: int) -> tuple[np.ndarray, int]:
        """Blocks for the next frame: (uint16 (480, 640) view of the library's buffer, device timestamp).
        The view is valid only until the next call."""
        code = self._get(ctypes.byref(self._buf), ctypes.byref(self._ts), index, fmt)
        if code != 0 or not self._buf.value:
            raise FreenectError(f"freenect_sync_get_depth(index {index}, format {fmt}) returned {code}")
        ptr = ctypes.cast(self._buf, ctypes.POINTER(ctypes.c_uint16 * (WIDTH * HEIGHT)))
        # a ctypes array is a buffer (numpy's stubs do not say so)
        return np.frombuffer(ptr.contents, np.uint16).reshape(HEIGHT, WIDTH), int(self._ts.value)  # type: ignore[call-overload]

    def stop(self) -> None:
        """freenect_sync_stop: ends the library's USB thread and closes the device."""
        self._stop()
