"""Checks: registration rules, outcomes turned into student messages, time limits, score."""

from __future__ import annotations

import time

import pytest

from robocourse.grading import CheckFailed, checks


@pytest.fixture(autouse=True)
def clean():
    checks.reset()
    yield
    checks.reset()
    for name in [n for n in checks._REGISTRY if n.startswith("test.")]:
        del checks._REGISTRY[name]


def _register(name, func, **kw):
    checks.register(name, **kw)(func)
    return checks._REGISTRY[name]


def test_pass_fail_and_messages():
    def positive(f):
        """f returns a positive number."""
        if f() <= 0:
            raise CheckFailed(f"f() returned {f()}, expected > 0")
        return "f is positive"

    _register("test.positive", positive, weight=2)
    ok = checks.check("test.positive", lambda: 3, quiet=True)
    bad = checks.check("test.positive", lambda: -1, quiet=True)
    assert (ok.passed, ok.points, ok.message) == (True, 2.0, "f is positive")
    assert (bad.passed, bad.points, bad.message) == (False, 0.0, "f() returned -1, expected > 0")
    assert checks._REGISTRY["test.positive"].description == "f returns a positive number."


def test_student_exceptions_become_messages():
    _register("test.calls", lambda f: f())

    def not_done():
        raise NotImplementedError()

    assert "not implemented yet" in checks.check("test.calls", not_done, quiet=True).message

    def broken():
        return 1 / 0

    msg = checks.check("test.calls", broken, quiet=True).message
    assert msg.startswith("your code raised ZeroDivisionError") and "in broken" in msg


def test_time_limit_stops_an_endless_loop():
    def forever(_):
        while True:
            pass

    _register("test.slow", forever, time_limit=0.3)
    start = time.monotonic()
    r = checks.check("test.slow", None, quiet=True)
    assert not r.passed and "0.3 s time limit" in r.message
    assert time.monotonic() - start < 10  # it returned at all: the alarm interrupted the loop


def test_score_prefix_counts_unrun_checks_as_zero(capsys):
    _register("test.a", lambda: None, weight=1)
    _register("test.b", lambda: None, weight=3)
    checks.check("test.a", quiet=True)
    assert checks.score("test") == (1.0, 4.0)
    out = capsys.readouterr().out
    assert out.startswith("Score: 1/4")
    assert "[FAIL] test.b (0/3): not run yet" in out


@pytest.mark.parametrize("name", ["nodot", "ch01.", "ch01.bad name", "1ch.x", 5])
def test_bad_check_names_are_refused(name):
    with pytest.raises(ValueError, match="ch01.jitter_stats"):
        checks.register(name)


def test_bad_weight_and_limit_are_refused():
    with pytest.raises(ValueError, match="weight must be a positive number"):
        checks.register("test.w", weight=0)
    with pytest.raises(ValueError, match="time_limit must be positive"):
        checks.register("test.t", time_limit=-1)


def test_unknown_check_names_its_neighbours():
    _register("test.known", lambda: None)
    with pytest.raises(KeyError, match="test.known"):
        checks.get("test.unknown")


def test_missing_extra_checks_dir_is_clear(tmp_path):
    with pytest.raises(FileNotFoundError, match="does not exist"):
        checks.load_check_dir(tmp_path / "nope")


def test_run_pending_reports_missing_globals():
    _register("test.hidden", lambda f: None, uses=("student_fn",))
    [r] = checks.run_pending({}, names=["test.hidden"])
    assert not r.passed and "defines no student_fn" in r.message
