"""``zenav tf tree`` (like view_frames / tf_monitor) and ``zenav tf echo TARGET SOURCE`` (like tf_echo).

    zenav tf tree --robot pioneer1 --duration 3 --dot frames.dot   # then: dot -Tpdf frames.dot -o frames.pdf
    zenav tf echo map base_link --robot pioneer1
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from typing import TYPE_CHECKING

from common.argtypes import nonneg_int, positive

if TYPE_CHECKING:  # numpy comes with it: not for `zenav --help`
    from common.tf_buffer import EdgeInfo


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "tf", help="transform tree tools: tree (view_frames), echo (tf_echo)",
        description="Inspect the transforms on zenav/<robot>/tf and tf_static.")
    sp = p.add_subparsers(dest="tf_command", metavar="ACTION", required=True)
    t = sp.add_parser(
        "tree", help="listen a few seconds, print the frame tree and write a Graphviz .dot file",
        description="Like view_frames / tf_monitor: every edge with its publishing node, average rate, "
                    "latest stamp, age and whether it is static.")
    t.add_argument("--dot", default="frames.dot", metavar="FILE",
                   help="Graphviz file to write (default frames.dot; '' = none). Render: dot -Tpdf FILE")
    t.add_argument("--duration", type=positive, default=3.0, metavar="S", help="seconds to listen (default 3)")
    t.set_defaults(func=run_tree)
    e = sp.add_parser("echo", help="print the transform TARGET <- SOURCE periodically (like tf_echo)",
                      description="Print the latest transform that maps SOURCE coordinates into TARGET: "
                                  "translation, quaternion and roll/pitch/yaw.")
    e.add_argument("target", help="target frame (e.g. map)")
    e.add_argument("source", help="source frame (e.g. base_link)")
    e.add_argument("--rate", type=positive, default=1.0, help="prints per second (default 1)")
    e.add_argument("-n", "--count", type=nonneg_int, default=0, help="stop after N prints (default: until Ctrl-C)")
    e.set_defaults(func=run_echo)
    return p


# -- formatting (pure) ---------------------------------------------------------------------------

def _edge_label(e: EdgeInfo) -> str:
    who = e.publisher or "unknown publisher"
    if e.static:
        return f"{who}, static"
    return (f"{who}, {e.rate_hz:.1f} Hz, latest {e.latest_stamp:.3f}, age {e.age:.3f} s, "
            f"buffer {e.latest_stamp - e.oldest_stamp:.2f} s")


def format_tree(edges: list[EdgeInfo]) -> str:
    """The frames as an indented tree, one edge label per child frame."""
    children: dict[str, list[EdgeInfo]] = {}
    childs = {e.child for e in edges}
    for e in edges:
        children.setdefault(e.parent, []).append(e)
    roots = sorted({e.parent for e in edges} - childs)
    lines: list[str] = []
    seen: set[str] = set()

    def walk(frame: str, prefix: str) -> None:
        kids = sorted(children.get(frame, []), key=lambda i: i.child)
        for k, e in enumerate(kids):
            last = k == len(kids) - 1
            lines.append(f"{prefix}{'└── ' if last else '├── '}{e.child}   [{_edge_label(e)}]")
            if e.child not in seen:
                seen.add(e.child)
                walk(e.child, prefix + ("    " if last else "│   "))

    for r in roots:
        lines.append(r)
        seen.add(r)
        walk(r, "")
    for e in edges:  # frames on a cycle have no root: list them flat
        if e.child not in seen:
            lines.append(f"(cycle) {e.parent} -> {e.child}   [{_edge_label(e)}]")
    return "\n".join(lines)


def to_dot(edges: list[EdgeInfo], title: str = "") -> str:
    """A Graphviz digraph in the style of view_frames' frames.gv."""
    def q(s: str) -> str:
        return '"' + s.replace("\\", "\\\\").replace('"', '\\"') + '"'

    out = ["digraph G {"]
    for e in edges:
        rate = "static" if e.static else f"{e.rate_hz:.3f} Hz"
        lines = [f"Broadcaster: {e.publisher or 'unknown'}", f"Average rate: {rate}"]
        if not e.static:
            lines += [f"Most recent transform: {e.latest_stamp:.3f} ({e.age:.3f} sec old)",
                      f"Buffer length: {e.latest_stamp - e.oldest_stamp:.3f} sec"]
        label = "\\n".join(q(x)[1:-1] for x in lines)  # Graphviz line breaks inside one label
        out.append(f'{q(e.parent)} -> {q(e.child)}[label="{label}"];')
    if title:
        out.append(f'label={q(title)}; labelloc="t";')
    out.append("}")
    return "\n".join(out) + "\n"


def rpy(q) -> tuple[float, float, float]:
    """(roll, pitch, yaw), fixed axes, from the rotation matrix; at pitch ±pi/2 (gimbal lock) yaw is
    set to 0 and the rotation goes to roll, as tf's getRPY does."""
    m = q.as_matrix()
    pitch = math.asin(max(-1.0, min(1.0, -m[2, 0])))
    if abs(m[2, 0]) < 1.0 - 1e-9:
        return math.atan2(m[2, 1], m[2, 2]), pitch, math.atan2(m[1, 0], m[0, 0])
    sign = 1.0 if m[2, 0] < 0 else -1.0
    return math.atan2(sign * m[0, 1], m[1, 1]), pitch, 0.0


def format_transform(ts) -> str:
    t, r = ts.transform.translation, ts.transform.rotation
    roll, pitch, yaw = rpy(r)
    deg = [math.degrees(a) for a in (roll, pitch, yaw)]
    return (f"At time {ts.header.stamp:.3f}\n"
            f"- Translation: [{t.x:.3f}, {t.y:.3f}, {t.z:.3f}]\n"
            f"- Rotation: in Quaternion [{r.x:.3f}, {r.y:.3f}, {r.z:.3f}, {r.w:.3f}]\n"
            f"            in RPY (radian) [{roll:.3f}, {pitch:.3f}, {yaw:.3f}]\n"
            f"            in RPY (degree) [{deg[0]:.3f}, {deg[1]:.3f}, {deg[2]:.3f}]")


# -- commands ------------------------------------------------------------------------------------

def _open(args, what: str):
    from deploy.cli.session import one_robot

    robot = one_robot(args)
    from common.bus import Node
    from common.tf import TFListener

    node = Node(f"zenav-tf-{what}-{os.getpid()}", robot=robot or None)
    return node, TFListener(node)


def run_tree(args) -> int:
    node, tf = _open(args, "tree")
    try:
        time.sleep(max(0.0, args.duration))  # rates need a listening window: wall time by design
        edges = tf.buffer.edges()
        robot = node.robot
    finally:
        tf.close()
        node.close()
    if args.dot:
        with open(args.dot, "w") as f:
            f.write(to_dot(edges, f"zenav/{robot} TF tree"))
    if not edges:
        print(f"no transforms on zenav/{robot}/tf or tf_static within {args.duration:.1f} s", file=sys.stderr)
        return 1
    print(f"TF tree of robot '{robot}' ({len(edges)} edges, listened {args.duration:.1f} s):")
    print(format_tree(edges))
    if args.dot:
        print(f"wrote {args.dot} (render: dot -Tpdf {args.dot} -o frames.pdf)")
    return 0


def run_echo(args) -> int:
    if args.rate <= 0:
        raise ValueError("--rate must be > 0")
    from common.tf import TFError

    node, tf = _open(args, "echo")
    period, printed, ok = 1.0 / args.rate, 0, False
    try:
        while not args.count or printed < args.count:
            try:
                # The first lookup waits for the listener to fill; later ones print what is there.
                wait = max(period, 2.0) if not printed else 0.0
                ts = tf.buffer.lookup(args.target, args.source, 0.0, timeout=wait)
                print(format_transform(ts), flush=True)
                ok = True
            except TFError as e:
                print(f"Failure at {node.clock.now():.3f}: {e}", flush=True)
                ok = False
            printed += 1
            if not args.count or printed < args.count:
                node.clock.sleep(period)
    finally:
        tf.close()
        node.close()
    return 0 if ok else 1
