"""Shared test fixtures and the per-notebook time budget."""

from __future__ import annotations

from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOK_BUDGET_S = 60  # a notebook that needs more than this headless is a bug (issue 2)


@pytest.fixture
def root() -> Path:
    return ROOT


def pytest_collection_modifyitems(config, items):
    """Give every notebook executed by nbmake a hard 60 s limit (nbmake's own is per cell)."""
    for item in items:
        if str(getattr(item, "path", "")).endswith(".ipynb"):
            item.add_marker(pytest.mark.timeout(NOTEBOOK_BUDGET_S))
