"""`make lint` (ruff, configured in pyproject.toml) finds nothing: the chapters, solutions, library
and tests stay clean as they change, so a student who runs a linter on what they copied sees no
noise from ours."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def test_ruff_finds_nothing():
    ruff = Path(sys.executable).with_name("ruff")
    if not ruff.exists():
        pytest.skip(f"ruff is not installed beside {sys.executable} (requirements.txt installs it)")
    out = subprocess.run([str(ruff), "check", "--output-format", "concise", "--no-cache", "."],
                         cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, (f"ruff found problems (fix them, or `ruff check --fix .` for the "
                                 f"safe ones):\n{out.stdout}{out.stderr}")
