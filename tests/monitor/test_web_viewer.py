"""The web viewer served by `zenav monitor --serve-web` renders in headless Chromium.

The check itself is deploy/check_web_viewer.py (also runnable by hand; it keeps the screenshot).
"""

from __future__ import annotations

import pytest

from deploy.check_web_viewer import check, find_chromium


@pytest.mark.slow
@pytest.mark.skipif(find_chromium() is None,
                    reason="chromium not installed (Debian: apt-get install chromium; "
                           "deploy/install.sh --test installs it)")
def test_web_viewer_renders_the_monitor(tmp_path):
    shot = tmp_path / "web_viewer.png"
    verdict = check(shot, timeout=180.0, settle=5.0)
    assert verdict.ok, f"{verdict.why}; screenshot kept at {shot}"
    assert shot.stat().st_size > 10_000
