"""Navigation end-to-end tests: per-goal measurements printed in the terminal summary.

The lines travel in each test's report (``user_properties``), so they reach the summary from xdist's
workers too; tests/conftest.py prints them."""

from __future__ import annotations

import pytest


@pytest.fixture(autouse=True)
def _goal_lines_to_report(request):
    from tests.nav_e2e.nav_e2e_checks import RESULTS

    before = len(RESULTS)
    yield
    request.node.user_properties.extend(("summary:nav_e2e: final pose errors against ground truth", line)
                                        for line in RESULTS[before:])
