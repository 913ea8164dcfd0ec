"""The ch01 checks in the student's own kernel (instant feedback): what the bank cannot show.

The wrong-answer bank (tests/banks/ch01.py, graded through the sandbox by test_banks.py) holds
the plausible mistakes with their partial scores; here: several mistakes at once are all listed,
a malformed return fails with the form it needed, not-implemented is said so, the same seed
draws the same inputs, and the knob menu the notebook prints covers the key.
"""

import numpy as np
import pytest

from robocourse.grading.checks import get, run_check
from robocourse.rt.probes import KNOBS, TAILS


def rttest_statistics(lat, minor, major):
    lat = np.asarray(lat)
    return dict(min_latency=int(lat.min()), max_latency=int(lat.max()), mean_latency=float(lat.mean()),
                latency_stddev=float(lat.std()), minor_pagefaults=int(np.sum(minor)),
                major_pagefaults=int(np.sum(major)))


def not_implemented(*args):
    raise NotImplementedError()


def test_several_mistakes_are_all_listed_each_in_its_sub_test():
    def bad(lat, minor, major):
        d = rttest_statistics(lat, minor, major)
        d["latency_stddev"] = float(np.std(lat, ddof=1)) if len(lat) > 1 else 0.0
        d["minor_pagefaults"] = int(np.max(minor))
        return d

    r = run_check(get("ch01.rttest_stats"), bad, seed=1)
    assert r.points == 1.0 and r.weight == 2.0
    failed = {s["name"]: s["message"] for s in r.subtests if not s["passed"]}
    assert set(failed) == {"the population standard deviation (divide by n)",
                           "the total page faults (sum of the deltas)"}
    assert "*sample* standard deviation" in r.message and "rttest sums them" in r.message


def test_a_return_value_of_the_wrong_form_names_the_form():
    r = run_check(get("ch01.rttest_stats"), lambda *a: [1, 2], seed=2)
    assert r.points == 0 and r.reason == "malformed"
    assert "your function returned list [1, 2]" in r.message and "expected a dict" in r.message
    assert r.line().count("your function returned list") == 4  # once per case, not again per sub-test


@pytest.mark.parametrize("name, objects", [("ch01.which_knob", (not_implemented,)),
                                           ("ch01.rttest_stats", (not_implemented,)),
                                           ("ch01.drift_free_loop", (not_implemented,))])
def test_not_implemented_is_said_so(name, objects):
    r = run_check(get(name), *objects, seed=3)
    assert r.points == 0 and r.reason == "not_implemented" and "not implemented yet" in r.line()


def test_the_same_seed_draws_the_same_inputs_and_the_result_shows_it():
    chk = get("ch01.drift_free_loop")
    a, b = (chk.make_inputs(np.random.default_rng(11)) for _ in range(2))
    assert a == b and a != chk.make_inputs(np.random.default_rng(12))
    r = run_check(get("ch01.relative_drift"), lambda w, s, p: np.asarray(w) - (s + np.arange(1, len(w) + 1) * p),
                  seed=11)
    assert r.seed == 11 and "[seed 11]" in r.line() and r.points == 1.0


def test_knob_menu_covers_every_tail_of_the_key():
    from robocourse.rt.checks import _RIGHT_KNOB

    assert set(TAILS) == set(_RIGHT_KNOB) and all(k <= set(KNOBS) for k in _RIGHT_KNOB.values())
