"""The web viewer served by `zenav monitor --serve-web` renders in headless Chromium.

The check itself is deploy/check_web_viewer.py (also runnable by hand; it keeps the screenshot).
"""

from __future__ import annotations

import io

import numpy as np
import pytest
from PIL import Image

from deploy.check_web_viewer import check, find_chromium, judge


@pytest.mark.slow
@pytest.mark.skipif(find_chromium() is None,
                    reason="chromium not installed (Debian: apt-get install chromium; "
                           "deploy/install.sh --test installs it)")
def test_web_viewer_renders_the_monitor(tmp_path):
    shot = tmp_path / "web_viewer.png"
    verdict = check(shot, timeout=180.0, settle=5.0)
    assert verdict.ok, f"{verdict.why}; screenshot kept at {shot}"
    assert shot.stat().st_size > 10_000


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
