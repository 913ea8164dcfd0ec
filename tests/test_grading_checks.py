"""Checks: registration rules, probe/judge split, every failure listed, delegation, time limits, score."""

from __future__ import annotations

import functools
import threading

import pytest

from robocourse.grading import CheckFailed, Failures, checks, probes


@pytest.fixture(autouse=True)
def clean():
    checks.reset()
    yield
    checks.reset()
    for name in [n for n in checks._REGISTRY if n.startswith("test.")]:
        del checks._REGISTRY[name]


def _call_probe(inputs, f):
    return probes.call(f, *inputs)


def _register(name, judge, probe=_call_probe, inputs=lambda rng: [2], uses=("f",), **kw):
    checks.register(name, uses=uses, probe=probe, inputs=inputs, **kw)(judge)
    return checks._REGISTRY[name]


def _doubles(inputs, out):
    """f doubles its argument."""
    if out.get("value") != 2 * inputs[0]:
        raise CheckFailed(f"f({inputs[0]}) returned {out.get('value', out.get('raised'))!r}, expected {2 * inputs[0]}")
    return "f doubles"


def test_pass_fail_and_messages():
    _register("test.double", _doubles, weight=2)
    ok = checks.check("test.double", lambda x: 2 * x, quiet=True)
    bad = checks.check("test.double", lambda x: x + 1, quiet=True)
    assert (ok.passed, ok.points, ok.message) == (True, 2.0, "f doubles")
    assert (bad.passed, bad.points, bad.message) == (False, 0.0, "f(2) returned 3, expected 4")
    assert checks._REGISTRY["test.double"].description == "f doubles its argument."


def test_every_failure_is_listed_not_only_the_first():
    def judge(inputs, out):
        f = Failures()
        f.expect(out["a"] == 1, "a should be 1")
        f.expect(out["b"] == 2, "b should be 2")
        f.expect(out["c"] == 3, "c should be 3")
        return f.done("all three")

    _register("test.three", judge, probe=lambda inputs, f: f(), inputs=None)
    r = checks.check("test.three", lambda: {"a": 0, "b": 2, "c": 0}, quiet=True)
    assert r.message.splitlines() == ["a should be 1", "c should be 3"]
    assert r.line().splitlines() == ["[FAIL] test.three (0/1): 2 problems", "    - a should be 1", "    - c should be 3"]


def test_check_cell_shows_feedback_once_and_no_raw_result(capsys):
    _register("test.double", _doubles)
    r = checks.check("test.double", lambda x: 2 * x, seed=7)
    assert capsys.readouterr().out == "[PASS] test.double (1/1) [seed 7]: f doubles\n"
    assert r._ipython_display_() is None  # IPython shows nothing more for the returned Result
    assert "Result(" not in str(r)


def test_student_exceptions_become_messages():
    _register("test.calls", lambda i, o: "ok", probe=lambda inputs, f: f(), inputs=None)

    def not_done():
        raise NotImplementedError()

    r = checks.check("test.calls", not_done, quiet=True)
    assert "not implemented yet" in r.message and r.reason == "not_implemented"

    def broken():
        return 1 / 0

    r = checks.check("test.calls", broken, quiet=True)
    assert r.message.startswith("your code raised ZeroDivisionError") and "in broken" in r.message
    assert r.reason == "raised" and r.points == 0


def test_time_limit_stops_an_endless_loop():
    def forever():
        while True:
            pass

    _register("test.slow", lambda i, o: "ok", probe=lambda inputs, f: f(), inputs=None, time_limit=0.3)
    r = checks.check("test.slow", forever, quiet=True)   # it returns at all: the alarm interrupted the loop
    assert not r.passed and "0.3 s time limit" in r.message and r.reason == "timeout"


def _reference_double(x):
    return 2 * x


def test_delegating_to_the_reference_earns_nothing_passed_wrapped_or_partial():
    ref = f"{__name__}:_reference_double"
    _register("test.ref", _doubles, references=(ref,))
    assert checks.check("test.ref", lambda x: x * 2, quiet=True).passed
    for attempt in (_reference_double, lambda x: _reference_double(x), functools.partial(_reference_double)):
        r = checks.check("test.ref", attempt, quiet=True)
        assert (r.passed, r.points, r.reason) == (False, 0.0, "delegated")
        assert "write it yourself" in r.message and "_reference_double" in r.message


def test_judge_error_in_hidden_check_is_the_instructors_not_the_students():
    def buggy(inputs, out):
        return 1 / 0

    _register("test.hidden_bug", buggy, in_notebook=False)
    r = checks.check("test.hidden_bug", lambda x: 2 * x, quiet=True)
    assert r.reason == "check_error" and r.points == 0
    assert "your instructor has been told" in r.message and "ZeroDivisionError" not in r.message
    assert "ZeroDivisionError" in r.extra["instructor"]


def test_judge_reads_forged_or_malformed_probe_data_without_crashing():
    chk = _register("test.double", _doubles, weight=3)
    for data in (None, "5/5", {"outputs": "junk"}, {"outputs": {"value": 4}, "seconds": "x"}, [1, 2]):
        r = checks.judge(chk, [2], data)
        assert r.points in (0.0, 3.0) and r.points <= r.weight
    assert checks.judge(chk, [2], {"outputs": {"value": 4}}).points == 3.0  # capped at the weight, decided here


def test_score_prefix_counts_unrun_checks_as_zero(capsys):
    _register("test.a", _doubles, weight=1, in_notebook=True)
    _register("test.b", _doubles, weight=3, in_notebook=True)
    checks.check("test.a", lambda x: 2 * x, quiet=True)
    assert checks.score("test") == (1.0, 4.0)
    out = capsys.readouterr().out
    assert out.startswith("Score: 1/4")
    assert "[FAIL] test.b (0/3): not run yet" in out


@pytest.mark.parametrize("name", ["nodot", "ch01.", "ch01.bad name", "1ch.x", 5])
def test_bad_check_names_are_refused(name):
    with pytest.raises(ValueError, match="ch01.jitter_stats"):
        checks.register(name, uses=("f",), probe=_call_probe)


def test_bad_registration_arguments_are_refused():
    with pytest.raises(ValueError, match="weight must be a positive number"):
        checks.register("test.w", uses=("f",), probe=_call_probe, weight=0)
    with pytest.raises(ValueError, match="time_limit must be positive"):
        checks.register("test.t", uses=("f",), probe=_call_probe, time_limit=-1)
    with pytest.raises(ValueError, match="uses must name the notebook globals"):
        checks.register("test.u", uses=(), probe=_call_probe)
    with pytest.raises(ValueError, match="probe must be a function"):
        checks.register("test.p", uses=("f",), probe=None)


def test_wrong_number_of_objects_names_the_expected_ones():
    _register("test.two", _doubles, uses=("f", "g"))
    with pytest.raises(TypeError, match="takes 2 object"):
        checks.check("test.two", lambda x: x)


def test_unknown_check_names_its_neighbours():
    _register("test.known", _doubles)
    with pytest.raises(KeyError, match="test.known"):
        checks.get("test.unknown")


def test_missing_extra_checks_dir_is_clear(tmp_path):
    with pytest.raises(checks.CheckDirError, match="does not exist"):
        checks.load_check_dir(tmp_path / "nope")


def test_syntax_error_in_a_check_file_is_one_line_with_file_and_line(tmp_path):
    (tmp_path / "broken.py").write_text("from robocourse.grading import register\n\ndef judge(:\n    pass\n")
    with pytest.raises(checks.CheckDirError) as err:
        checks.load_check_dir(tmp_path)
    text = str(err.value)
    assert "\n" not in text and f"{tmp_path / 'broken.py'}:3: SyntaxError" in text


def test_plain_turns_numpy_and_objects_into_data():
    import numpy as np

    assert probes.plain({"a": np.int64(3), "b": np.array([1.5, np.nan]), 2: (True,)}) == \
        {"a": 3, "b": [1.5, "nan"], "2": [True]}
    assert probes.plain(object())["type"] == "object"
    assert probes.number("inf") == float("inf")
    with pytest.raises(TypeError):
        probes.number(True)


def test_grading_package_imports_no_chapter_by_name(root):
    """grading is a foundation: chapter checks reach it as entry points, never by name or pattern;
    every checks.py in the library is declared (none silently missing)."""
    import ast

    chapters = {"rt", "pendulum", "mycar", "setup_check", "control", "ethercat", "drivers", "rl"}
    for path in (root / "lib/robocourse/grading").glob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            names = []
            if isinstance(node, ast.ImportFrom):
                names = [node.module or ""] + [a.name for a in node.names]
            elif isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            for n in names:
                parts = set(n.split("."))
                assert not parts & chapters, f"{path.name} imports {n}"
            if isinstance(node, ast.Call) and getattr(node.func, "attr", "") == "import_module":
                assert not isinstance(node.args[0], ast.JoinedStr), f"{path.name} imports by pattern"
    found = {c.module for c in checks.discover().values() if c.module.startswith("robocourse.")}
    lib = root / "lib"
    on_disk = {".".join(p.relative_to(lib).with_suffix("").parts) for p in (lib / "robocourse").glob("**/*checks.py")
               if p.parent.name != "grading"}
    assert on_disk == found
    assert found >= {"robocourse.setup_check.checks", "robocourse.rt.checks",
                     "robocourse.pendulum.checks", "robocourse.mycar.checks", "robocourse.rl.checks",
                     "robocourse.bus.zenoh.checks"}


def test_score_cell_shows_only_the_table():
    _register("test.a", _doubles, weight=1, in_notebook=True)
    s = checks.score("test", quiet=True)
    assert s == (0.0, 1.0) and s._ipython_display_() is None


def test_inside_the_grading_sandbox_check_cells_defer_to_the_grader(monkeypatch, capsys):
    _register("test.double", _doubles)
    monkeypatch.setenv(checks.GRADING_ENV, "1")
    r = checks.check("test.double", lambda x: 2 * x)
    assert (r.passed, r.points, r.reason) == (False, 0.0, "deferred") and capsys.readouterr().out == ""


# -- issue 26: schemas, sub-tests with weights, budgets, seeds, delegation on every thread ------

from robocourse.grading import SubTest  # noqa: E402
from robocourse.grading.schema import Call, Dict, Int, List  # noqa: E402


def _two_part_probe(inputs, f):
    return {"double": [probes.call(f, x) for x in inputs["xs"]], "negative": probes.call(f, -1)}


def _doubles_all(inputs, out):
    for x, got in zip(inputs["xs"], out["double"], strict=True):
        if got.get("value") != 2 * x:
            raise CheckFailed(f"f({x}) returned {got.get('value', got.get('raised'))!r}, expected {2 * x}")
    return ""


def _refuses_negative(inputs, out):
    if "raised" not in out["negative"]:
        raise CheckFailed(f"f(-1) returned {out['negative']['value']!r}; raise ValueError for a negative input")
    return ""


def _two_part(name="test.parts", **kw):
    return checks.register(name, uses=("f",), probe=_two_part_probe,
                           inputs=lambda rng: {"xs": [int(x) for x in rng.integers(1, 100, 3)]},
                           schema=Dict(double=List(Call(Int()), length="xs"), negative=Call(Int())),
                           subtests=[SubTest("doubles its input", 2, _doubles_all, reads="double"),
                                     SubTest("refuses a negative input", 1, _refuses_negative, reads="negative")],
                           **kw)


def _strict_double(x):
    if x < 0:
        raise ValueError("negative")
    return 2 * x


def test_sub_tests_score_their_own_weight_and_the_feedback_lists_each():
    chk = _two_part()
    assert chk.weight == 3.0
    full = checks.run_check(chk, _strict_double, seed=4)
    half = checks.run_check(chk, lambda x: 2 * x, seed=4)
    assert (full.points, half.points) == (3.0, 2.0)
    lines = half.line().splitlines()
    assert lines[0] == "[FAIL] test.parts (2/3) [seed 4]: 1 of 2 sub-tests failed"
    assert lines[1] == "    [PASS] doubles its input (2/2)"
    assert lines[2].startswith("    [FAIL] refuses a negative input (0/1): f(-1) returned -2")


def test_a_malformed_part_fails_only_the_sub_tests_reading_it():
    chk = _two_part()
    r = checks.run_check(chk, lambda x: (2 * x) if x > 0 else "no", seed=5)  # a str for -1
    assert r.points == 2.0
    bad = next(s for s in r.subtests if not s["passed"])
    assert bad["reason"] == "malformed" and "your function returned str 'no': expected an int" in bad["message"]


def test_forged_records_of_the_wrong_kind_or_shape_earn_nothing():
    chk = _two_part()
    inputs = {"xs": [1, 2, 3]}
    for outputs in ({"double": [], "negative": {"value": -2, "type": "int"}},
                    {"double": [{"value": "nan", "type": "float"}] * 3, "negative": {"value": 1, "type": "int"}},
                    {"double": [{"value": 2.0, "type": "float"}, {"value": 4, "type": "int"}, {"value": 6}],
                     "negative": {"value": True, "type": "bool"}}, "5/5", None, [1]):
        r = checks.judge(chk, inputs, {"outputs": outputs})
        assert r.points == 0.0 and r.reason in ("malformed", ""), (outputs, r.message)


def test_a_record_over_its_size_budget_is_not_judged():
    chk = _two_part(max_bytes=1000)
    judged = []
    big = {"double": [{"value": 2, "type": "int"}] * 3, "negative": {"raised": "V", "message": "x" * 5000,
                                                                      "bases": ["V"]}}
    r = checks.judge(chk, {"xs": [1, 1, 1]}, {"outputs": big})
    assert r.reason == "oversize" and r.points == 0 and "reads at most 1000" in r.message and not judged


def test_a_judge_past_its_time_budget_is_the_checks_fault_not_the_students():
    release, finished = threading.Event(), threading.Event()

    def slow(inputs, out):
        release.wait(60)        # never set before judge() returns: the budget alone can end it
        finished.set()
        return ""

    checks.register("test.slow_judge", uses=("f",), probe=_call_probe, inputs=lambda rng: [2],
                    schema=Call(Int()), subtests=[SubTest("slow", 1, slow)], judge_time_limit=0.3)
    try:
        r = checks.judge(checks.get("test.slow_judge"), [2], {"outputs": {"value": 4, "type": "int"}})
        returned_first = not finished.is_set()   # judge() came back while the sub-test still ran
    finally:
        release.set()
    assert returned_first
    assert r.reason == "check_error" and "time budget" in r.message and "budget" in r.extra["instructor"]


def test_a_judge_crash_on_a_validated_record_is_a_check_error():
    def buggy(inputs, out):
        return out["missing"]

    checks.register("test.buggy", uses=("f",), probe=_call_probe, inputs=lambda rng: [2], schema=Call(Int()),
                    subtests=[SubTest("buggy", 1, buggy)])
    r = checks.run_check(checks.get("test.buggy"), lambda x: 2 * x, seed=1)
    assert r.reason == "check_error" and "your instructor has been told" in r.message
    assert "KeyError" in r.extra["instructor"]


def test_sub_test_registration_errors_are_clear():
    with pytest.raises(ValueError, match="sum to 3"):
        _two_part("test.w", weight=2)
    with pytest.raises(ValueError, match="must differ"):
        checks.register("test.d", uses=("f",), probe=_call_probe,
                        subtests=[SubTest("a", 1, _doubles), SubTest("a", 1, _doubles)])
    with pytest.raises(ValueError, match="positive number"):
        SubTest("a", 0, _doubles)

    def judge(inputs, out):
        return ""

    def probe(inputs, f):
        return f()

    judge.__module__ = probe.__module__ = "robocourse.fake.checks"
    with pytest.raises(ValueError, match="grading sandbox hides judge modules"):
        checks.register("test.same_module", uses=("f",), probe=probe, schema=Int(),
                        subtests=[SubTest("a", 1, judge)])


def test_draws_are_seeded_per_submission_content():
    assert checks.seed_for("ch00.to_ns", "abc") == checks.seed_for("ch00.to_ns", "abc")
    assert checks.seed_for("ch00.to_ns", "abc") != checks.seed_for("ch00.to_ns", "abd")
    assert checks.seed_for("ch00.to_ns", "abc") != checks.seed_for("ch00.budget", "abc")
    assert 0 <= checks.seed_for("x", "y") < 2**32


_POOL_RESULT = []


def test_delegation_is_seen_on_every_thread_not_only_the_callers():
    import _thread
    import concurrent.futures
    import threading

    ref = f"{__name__}:_reference_double"
    _register("test.ref_threads", _doubles, references=(ref,))
    pool = concurrent.futures.ThreadPoolExecutor(1)  # started before the probe, as in an earlier cell
    pool.submit(lambda: None).result()

    def via_pool(x):
        return pool.submit(_reference_double, x).result()

    def via_raw_thread(x):
        done = threading.Event()
        _thread.start_new_thread(lambda: (_POOL_RESULT.append(_reference_double(x)), done.set()), ())
        done.wait(5)
        return _POOL_RESULT[-1]

    try:
        for attempt in (via_pool, via_raw_thread):
            r = checks.check("test.ref_threads", attempt, quiet=True)
            assert (r.points, r.reason) == (0.0, "delegated"), attempt.__name__
        assert checks.check("test.ref_threads", lambda x: x + x, quiet=True).passed
        assert _reference_double(4) == 8 and _reference_double.__code__.co_name == "_reference_double"  # restored
    finally:
        pool.shutdown()


def test_two_records_under_one_name_are_tampering(tmp_path):
    from robocourse.grading.grader import _read_probes

    line = '{"name": "ch00.x", "outputs": {"value": 1}, "error": null, "delegated": []}'
    (tmp_path / "p.jsonl").write_text(line + "\n" + line + "\n" + '{"name": "ch00.big", "outputs": "' + "x" * 20_000
                                      + '"}\n')
    got = _read_probes(tmp_path / "p.jsonl", {"ch00.x": 10_000, "ch00.big": 1000, "ch00.none": 1000})
    assert "tampered" in got["ch00.x"][0] and got["ch00.big"][0] == {"oversize": got["ch00.big"][1]}
    assert "ch00.none" not in got
