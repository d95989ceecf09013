"""SimClock sleepers: woken at their deadline, by wake() and by close(); a sleeper on a paused clock holds
one entry, however long it waits (it used to add one every poll: 4 a second per sleeping thread)."""

from __future__ import annotations

import threading
import time

from common.clock import SimClock
from tests.support import wait_until


def _sleeper(clock: SimClock, until: float, cancel: threading.Event | None = None):
    done: dict[str, bool] = {}
    th = threading.Thread(target=lambda: done.update(ok=clock.sleep_until(until, cancel)), daemon=True)
    th.start()
    return th, done


def test_a_sleeper_on_a_paused_clock_holds_one_entry_and_wakes_at_its_deadline(monkeypatch):
    monkeypatch.setattr(SimClock, "POLL_S", 0.01)
    clock = SimClock()
    clock.update(1.0)
    th, done = _sleeper(clock, 2.0)
    wait_until(lambda: len(clock._sleepers) == 1, 10, "the sleeper queued")
    time.sleep(0.3)  # a paused clock for 30 polls: the fault under test, not a wait for a condition
    assert len(clock._sleepers) == 1
    clock.update(1.5)
    assert th.is_alive() and len(clock._sleepers) == 1
    clock.update(2.0)
    th.join(10)
    assert done == {"ok": True} and clock._sleepers == []


def test_wake_lets_a_cancelled_sleeper_return_and_a_plain_one_sleep_on():
    clock = SimClock()
    clock.update(1.0)
    cancel = threading.Event()
    cancelled, c_done = _sleeper(clock, 5.0, cancel)
    plain, p_done = _sleeper(clock, 5.0)
    wait_until(lambda: len(clock._sleepers) == 2, 10, "both sleepers queued")
    cancel.set()
    clock.wake()
    cancelled.join(10)
    assert c_done == {"ok": False}
    wait_until(lambda: len(clock._sleepers) == 1, 10, "the plain sleeper queued again")
    assert plain.is_alive()
    clock.close()
    plain.join(10)
    assert p_done == {"ok": False}
