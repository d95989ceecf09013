"""The monitor's event log: text entities logged only when what they say changes (move_base state, node
states, costmap sensor health, ...). A mixin of ``Monitor`` (it needs ``rec``, ``_emit`` and ``_last_text``)."""

from __future__ import annotations

import re
from collections.abc import Callable

import rerun as rr

from common import messages as m
from deploy.monitor import loggers as L
from master_side.costmap.health import summary as sensors_summary

STATUS_NAMES = {0: "PENDING", 1: "ACTIVE", 2: "PREEMPTED", 3: "SUCCEEDED", 4: "ABORTED", 5: "REJECTED",
                8: "RECALLED"}
NODE_LEVELS = {"FAILED": "ERROR", "RESTARTING": "WARN", "EXITED": "WARN"}


class TextEvents:
    rec: rr.RecordingStream | L.Prefixed
    _last_text: dict[str, str]
    _emit: Callable[[str, float | None, Callable[[], None]], None]

    def _move_base_status(self, topic: str, msg: m.MoveBaseStatus) -> None:
        """One event per change of goal / status / state / recovery / reason (numbers in it ignored)."""
        status = STATUS_NAMES.get(msg.status, str(msg.status))
        text = f"{msg.state or '-'} [{status}] goal {msg.goal_id or '-'}"
        if msg.reason:
            text += f": {msg.reason}"
        if msg.recovery_count:
            text += f" (recoveries {msg.recovery_count})"
        level = ("ERROR" if status in ("ABORTED", "REJECTED")
                 else "WARN" if msg.state.upper().startswith(("CLEAR", "RECOVER")) or msg.reason else "INFO")
        key = re.sub(r"-?\d+(\.\d+)?", "#", msg.reason)
        self._text_on_change(f"log/{topic.rsplit('/', 1)[0]}", msg.header.stamp, text, level,
                             change=f"{msg.goal_id}|{msg.status}|{msg.state}|{msg.recovery_count}|{key}")

    def _node_state(self, topic: str, msg: m.NodeState) -> None:
        """``agent/<name>/state`` -> one event per node state change at ``log/agent/<name>``."""
        parts = topic.split("/")
        entity = f"log/agent/{parts[1]}" if len(parts) == 3 and parts[0] == "agent" else f"log/{topic}"
        text = f"{msg.node}: {msg.state}"
        if msg.restarts:
            text += f" (restarts {msg.restarts})"
        if msg.detail:
            text += f" {msg.detail}"
        self._text_on_change(entity, msg.header.stamp, text, NODE_LEVELS.get(msg.state, "INFO"),
                             key=f"{entity}|{msg.node}", change=f"{msg.state}|{msg.restarts}|{msg.detail}")

    def _sensors(self, topic: str, msg: m.CostmapSensors) -> None:
        """``<costmap>/sensors`` -> one event per change of a source's state at ``log/<costmap>/sensors``
        (WARN while a source is late or silent)."""
        change = "|".join(f"{s.layer}/{s.source}/{s.topic}:{s.state}" for s in msg.sources)
        level = "WARN" if msg.problems() else "INFO"
        self._text_on_change(f"log/{topic}", msg.header.stamp, sensors_summary(msg), level, change=change)

    def _text_on_change(self, entity: str, stamp: float | None, text: str, level: str = "INFO",
                        key: str | None = None, change: str | None = None) -> None:
        """Log ``text`` when it differs from the last one under ``key`` (default: the entity)."""
        key = key or entity
        change = text if change is None else change
        if self._last_text.get(key) != change:
            self._last_text[key] = change
            self._emit(entity, stamp, lambda: L.log_text(self.rec, entity, text, level))
