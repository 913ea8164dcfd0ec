"""robocourse.notebook: the test-mode switch and fixed seeds."""

from __future__ import annotations

import numpy as np
import pytest

from robocourse import notebook


def test_running_as_test_follows_the_environment(monkeypatch):
    for var in notebook.TEST_ENV_VARS:
        monkeypatch.delenv(var, raising=False)
    monkeypatch.setenv("ROBOCOURSE_TEST", "0")
    assert notebook.running_as_test() is False and notebook.running_as_notebook() is True
    assert notebook.pick(10.0, 0.5) == 10.0
    monkeypatch.setenv("ROBOCOURSE_TEST", "1")
    assert notebook.running_as_test() is True and notebook.pick(10.0, 0.5) == 0.5
    monkeypatch.delenv("ROBOCOURSE_TEST")
    monkeypatch.setenv("CI", "true")
    assert notebook.running_as_test() is True


def test_seed_everything_is_reproducible():
    a = notebook.seed_everything(7).normal(size=5)
    g1 = np.random.rand(3)
    b = notebook.seed_everything(7).normal(size=5)
    g2 = np.random.rand(3)
    assert np.array_equal(a, b) and np.array_equal(g1, g2)
    assert not np.array_equal(a, notebook.seed_everything(8).normal(size=5))


@pytest.mark.parametrize("bad", [-1, 1.5, "3", True])
def test_bad_seed_is_refused(bad):
    with pytest.raises(ValueError, match="non-negative int"):
        notebook.seed_everything(bad)
