"""testkit/check_web_viewer.py's verdict on a screenshot (the tool is run by hand:
``python -m testkit.check_web_viewer --out shot.png``). The live render of the monitor's page and the
Rerun viewer in headless Chromium is tests/monitor/test_monitor_web_tools.py (one Chromium session for
the suite: ~20 s each)."""

from __future__ import annotations

import io

import numpy as np
from PIL import Image

from testkit.check_web_viewer import judge


def _png(rgb: np.ndarray) -> bytes:
    buf = io.BytesIO()
    Image.fromarray(rgb.astype(np.uint8)).save(buf, format="PNG")
    return buf.getvalue()


def test_judge_accepts_the_scene_and_refuses_blank_or_welcome_like_screens():
    rng = np.random.default_rng(0)
    page = np.full((200, 300, 3), 250.0)
    page[20:60, 20:280] = rng.uniform(0, 80, (40, 260, 1))  # text-like dark strokes, no scene colours
    scene = page.copy()
    scene[100:140, 40:200] = (110, 126, 124)  # the map's unknown area
    scene[120:126, 40:200] = (255, 240, 40)  # the costmap's inflation band
    assert judge(_png(page), _png(scene), "").ok
    assert not judge(_png(page), _png(page), "").ok  # no map on screen
    assert not judge(_png(page), _png(np.full((200, 300, 3), 250.0)), "").ok  # uniform
    assert not judge(_png(page), _png(scene), "Loading Application Bundle").ok
