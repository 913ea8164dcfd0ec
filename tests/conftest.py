"""Shared test fixtures and the per-notebook safety-net timeout."""

from __future__ import annotations

from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
#: A notebook executed by nbmake is stopped after this long. A safety net, not the budget: the goal
#: is 60 s headless on a quiet machine, measured by benchmarks/notebook_times.py (issue 25: a
#: loaded machine made a 60 s test timeout fail a clean clone's CI for no fault of the course).
NOTEBOOK_TIMEOUT_S = 240


@pytest.fixture
def root() -> Path:
    return ROOT


def pytest_collection_modifyitems(config, items):
    """Give every notebook executed by nbmake the safety-net limit (nbmake's own is per cell)."""
    for item in items:
        if str(getattr(item, "path", "")).endswith(".ipynb"):
            item.add_marker(pytest.mark.timeout(NOTEBOOK_TIMEOUT_S))
