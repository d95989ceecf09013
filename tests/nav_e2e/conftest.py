"""Navigation end-to-end tests: per-goal measurements printed in the terminal summary."""

from __future__ import annotations


def pytest_terminal_summary(terminalreporter):
    from tests.nav_e2e.nav_e2e_checks import RESULTS

    if RESULTS:
        terminalreporter.section("nav_e2e: final pose errors against ground truth")
        for line in RESULTS:
            terminalreporter.write_line(line)
