"""The simulator's contacts in a run over the bus, each kept with what the planner knew just before it.

Both benches that drive a whole stack (an MRPB case, ``deploy.mrpb.bus``; an exploration run,
``deploy.mrpb.exploration``) watch the ``collision`` topic with this. For every new contact it keeps the
touched point, how far the nearest mark of the local costmap was from it just before (``BEFORE_CONTACT_S``),
and writes ``<dir>/contact_<n>.npz``: the local costmaps of the last 3 s and the odometry and true poses of
the last 4 s. ``python bench/contacts.py RUN_DIR --master FILE`` (the master file the run used) reads those
files and says which part of the robot touched and why (never marked, marked until the contact, erased by
footprint clearing, cleared). Each goal move_base aborts is kept the same way (``abort_<n>.npz``, the robot's
true position as its point, with move_base's reason): what the local costmap held where the robot gave up."""

from __future__ import annotations

import threading
from collections import deque
from collections.abc import Callable
from pathlib import Path

import numpy as np

from common.bus import Node
from common.messages import Collision, Costmap, GoalStatus, MoveBaseStatus, Odometry
from master_side.costmap.cost_values import LETHAL

BEFORE_CONTACT_S = 0.3  # a contact is diagnosed on the local costmap of this long before it (simulated s)


def nearest_mark(data: np.ndarray, origin: tuple[float, float], resolution: float, x: float, y: float) -> float:
    """The distance from (x, y) to the nearest LETHAL cell's centre of a costmap (``data`` rows = y,
    ``origin`` its lower-left corner, all in one frame); inf if it has none."""
    rows, cols = np.nonzero(np.asarray(data) == LETHAL)
    if len(rows) == 0:
        return float("inf")
    cx, cy = origin[0] + (cols + 0.5) * resolution, origin[1] + (rows + 0.5) * resolution
    return float(np.min(np.hypot(cx - x, cy - y)))


class ContactWatch:
    """Contacts as the simulator reports them (its ``collision`` count going up), each with a snapshot in
    ``contact_dir`` (None: none written). ``when(m)`` is the time recorded for a contact (default: its stamp).
    It subscribes to ``ground_truth`` (its last 4 s kept); ``on_truth`` gets each message too, so a bench that
    also follows the ground truth needs no second subscription."""

    def __init__(self, node: Node, contact_dir: Path | None, when: Callable[[Collision], float] | None = None,
                 on_truth: Callable[[Odometry], None] | None = None):
        self.node, self.contact_dir, self.lock = node, contact_dir, threading.Lock()
        self.when = when or (lambda m: m.header.stamp)
        self.on_truth = on_truth
        self.count = 0  # the simulator's count
        self.contacts: list[tuple[float, float, float]] = []  # (when, x, y in the world) of each new contact
        # per contact: the distance from the touched point to the nearest mark of the local costmap just before
        # it (None: no costmap yet); a mark within a cell or two: the planner knew of the obstacle
        self.marks: list[float | None] = []
        self.locals: deque[Costmap] = deque(maxlen=30)  # the last 3 s of local costmaps (10 Hz)
        self.odoms: deque[Odometry] = deque(maxlen=200)
        self.truths: deque[Odometry] = deque(maxlen=200)
        node.subscribe("local_costmap/costmap", Costmap, callback=self.locals.append, mode="queue")
        node.subscribe("odom", Odometry, callback=self.odoms.append, mode="queue")
        node.subscribe("ground_truth", Odometry, callback=self._truth, mode="queue")
        node.subscribe("collision", Collision, mode="queue", callback=self._contact)
        self.aborts = 0
        node.subscribe("move_base/result", MoveBaseStatus, mode="queue", callback=self._result)

    def _contact(self, m: Collision) -> None:
        with self.lock:
            new = m.count > self.count
            if new:
                self.count = m.count
                self.contacts.append((self.when(m), m.x, m.y))
                self.marks.append(self._mark_near(m.x, m.y, m.header.stamp - BEFORE_CONTACT_S))
        if new:  # the file written outside the lock; closing the node waits for this callback to end
            self._write(f"contact_{m.count}", (m.x, m.y), m.header.stamp)

    def _result(self, m: MoveBaseStatus) -> None:
        """A goal move_base aborted: ``abort_<n>.npz`` as a contact's, at the robot's true position."""
        truth = self.truth()
        if m.status != GoalStatus.ABORTED or truth is None:
            return
        with self.lock:
            self.aborts += 1
            n = self.aborts
        self._write(f"abort_{n}", (truth.pose2d.x, truth.pose2d.y), m.header.stamp, reason=m.reason)

    def _truth(self, m: Odometry) -> None:
        self.truths.append(m)
        if self.on_truth is not None:
            self.on_truth(m)

    def truth(self) -> Odometry | None:
        """The newest ground truth (None before the first)."""
        held = self.truths
        return held[-1] if held else None

    def snapshot_path(self, n: int) -> Path | None:
        """Contact ``n``'s snapshot, if one was written."""
        path = self.contact_dir / f"contact_{n}.npz" if self.contact_dir is not None else None
        return path if path is not None and path.exists() else None

    def _write(self, name: str, point: tuple[float, float], stamp: float, **more) -> None:
        """``<name>.npz``: the touched point (world) and the simulator's stamp, the local costmaps of the
        last 3 s (``maps`` (k, h, w) uint8, their ``map_stamps``, ``origins`` in the odometry frame,
        ``resolution``), and the odometry and true poses of the last 4 s (``odom``, ``truth``: rows of
        stamp, x, y, theta): what the planner knew and where the robot really was, to look at afterwards."""
        held = list(self.locals)  # the deques fill from other threads
        maps = [c for c in held if c.data.shape == held[-1].data.shape] if held else []
        if self.contact_dir is None or not maps:
            return

        def poses(msgs) -> np.ndarray:
            return np.array([(o.header.stamp, *o.pose2d.as_array()) for o in msgs]).reshape(-1, 4)

        out = self.contact_dir / f"{name}.npz"
        part = out.with_name(f".{out.name}.part")  # renamed when whole: a reader never opens half a file
        try:
            self.contact_dir.mkdir(parents=True, exist_ok=True)
            with open(part, "wb") as f:
                np.savez_compressed(f, point=np.array(point), stamp=stamp, **more,
                                    maps=np.stack([c.data for c in maps]),
                                    map_stamps=np.array([c.header.stamp for c in maps]),
                                    origins=np.array([(c.origin.x, c.origin.y) for c in maps]),
                                    resolution=maps[0].resolution, odom=poses(list(self.odoms)),
                                    truth=poses(list(self.truths)))
            part.replace(out)
        except OSError as e:  # a full disk must not end the run being measured
            self.node.log.warning("%s: snapshot not saved: %s", name, e)

    def _mark_near(self, x: float, y: float, before: float) -> float | None:
        """The distance from the world point (x, y) to the nearest lethal cell of the last local costmap
        stamped by ``before`` (in the odometry frame: placed by the odometry and ground-truth poses nearest
        that map's stamp); not a later one, which may hold what the contact itself showed (a bumper, a sonar)."""
        cm = next((c for c in reversed(list(self.locals)) if c.header.stamp <= before), None)
        if cm is None or not self.odoms or not self.truths:
            return None
        t = cm.header.stamp
        odom = min(list(self.odoms), key=lambda o: abs(o.header.stamp - t)).pose2d
        true = min(list(self.truths), key=lambda o: abs(o.header.stamp - t)).pose2d
        px, py = odom.compose(true.inverse()).apply(np.array([[x, y]]))[0]
        return nearest_mark(cm.data, (cm.origin.x, cm.origin.y), cm.resolution, px, py)
