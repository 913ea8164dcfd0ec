"""The ch01 checks: right answers pass, the usual mistakes fail with a message that names them."""

import numpy as np
import pytest

from robocourse.grading.checks import get, run_check
from robocourse.rt.checks import KNOBS, TAILS
from robocourse.rt.stats import compute_stats


def rttest_statistics(lat, minor, major):
    lat = np.asarray(lat)
    return dict(min_latency=int(lat.min()), max_latency=int(lat.max()), mean_latency=float(lat.mean()),
                latency_stddev=float(lat.std()), minor_pagefaults=int(np.sum(minor)),
                major_pagefaults=int(np.sum(major)))


def sample_stddev(lat, minor, major):
    d = rttest_statistics(lat, minor, major)
    d["latency_stddev"] = float(np.std(lat, ddof=1)) if len(lat) > 1 else 0.0
    return d


def grid_loop(first_k):
    """A loop sleeping to start + (k + first_k) * period: first_k = 1 is right, 0 and 2 are off by one."""

    def loop(clock, period_ns, iterations, callback):
        start, out = clock.now_ns(), []
        for k in range(iterations):
            deadline = start + (k + first_k) * period_ns
            clock.sleep_until_ns(deadline)
            out.append(clock.now_ns() - deadline)
            callback(k)
        return out

    return loop


absolute_loop, off_by_one_grid, skips_a_period = grid_loop(1), grid_loop(0), grid_loop(2)


def sampled_after_callback(clock, period_ns, iterations, callback):
    start, out = clock.now_ns(), []
    for k in range(iterations):
        deadline = start + (k + 1) * period_ns
        clock.sleep_until_ns(deadline)
        callback(k)
        out.append(clock.now_ns() - deadline)
    return out


def now_plus_period(clock, period_ns, iterations, callback):
    out = []
    for k in range(iterations):
        t0 = clock.now_ns()
        clock.sleep_until_ns(t0 + period_ns)
        out.append(clock.now_ns() - t0 - period_ns)
        callback(k)
    return out


def delegates_to_compute_stats(lat, minor, major):
    s = compute_stats(lat, minor, major)
    return {k: getattr(s, k) for k in ("min_latency", "max_latency", "mean_latency", "latency_stddev",
                                       "minor_pagefaults", "major_pagefaults")}


def relative_sleep(clock, period_ns, iterations, callback):
    for k in range(iterations):
        clock.sleep_ns(period_ns)
        callback(k)
    return [0] * iterations


def not_implemented(*args):
    raise NotImplementedError()


KNOB_FOR = {"timer slack oversleep": "hybrid wait", "page faults in the loop": "mlockall + prefault",
            "other processes on the same core": "SCHED_FIFO priority", "gc pause": "gc.freeze()"}


def budget(period, lat, q):
    return max(0.0, period - float(np.percentile(lat, q)))


def meets(lat, period):
    return np.max(lat) <= 0.05 * period


@pytest.mark.parametrize("name,args,passes,fragment", [
    ("ch01.rttest_stats", (rttest_statistics,), True, "matches rttest"),
    ("ch01.rttest_stats", (sample_stddev,), False, "*sample* standard deviation"),
    ("ch01.rttest_stats", (lambda *a: [1, 2],), False, "return a dict"),
    ("ch01.drift_free_loop", (absolute_loop,), True, "exactly start + (k + 1) * period"),
    ("ch01.drift_free_loop", (sampled_after_callback,), False, "*before* the callback"),
    ("ch01.drift_free_loop", (now_plus_period,), False, "away from the grid"),
    ("ch01.drift_free_loop", (relative_sleep,), False, "relative sleep"),
    ("ch01.drift_free_loop", (off_by_one_grid,), False, "off by one period"),
    ("ch01.drift_free_loop", (skips_a_period,), False, "two periods after the start"),
    ("ch01.drift_free_loop", (lambda c, p, n, cb: None,), False, "return the latencies"),
    ("ch01.rttest_stats", (delegates_to_compute_stats,), False, "write it yourself"),
    ("ch01.rttest_stats", (compute_stats,), False, "write it yourself"),
    ("ch01.relative_drift", (lambda w, s, p: np.asarray(w) - (s + np.arange(1, len(w) + 1) * p),), True, "drift"),
    ("ch01.relative_drift", (lambda w, s, p: np.asarray(w) - (s + np.arange(len(w)) * p),), False, "off by one"),
    ("ch01.budget", (budget, meets), True, "tail latency"),
    ("ch01.budget", (lambda p, lat, q: p - lat.mean(), meets), False, "*mean* latency"),
    ("ch01.budget", (lambda p, lat, q: p - float(np.percentile(lat, q)), meets), False, "return 0"),
    ("ch01.budget", (budget, lambda lat, p: np.mean(lat) <= 0.05 * p), False, "judged on the max"),
    ("ch01.which_knob", (KNOB_FOR,), True, "every tail"),
    ("ch01.which_knob", ({**KNOB_FOR, "gc pause": "more iterations"},), False, "gc.freeze() moves"),
    ("ch01.which_knob", ({**KNOB_FOR, "gc pause": "more iterations", "page faults in the loop": "hybrid wait"},),
     False, "2 problems"),
    ("ch01.which_knob", ({},), False, "missing"),
    ("ch01.which_knob", (lambda: KNOB_FOR,), True, "every tail"),
    ("ch01.which_knob", (not_implemented,), False, "not implemented yet"),
    ("ch01.rttest_stats", (not_implemented,), False, "not implemented yet"),
    ("ch01.drift_free_loop", (not_implemented,), False, "not implemented yet"),
])
@pytest.mark.parametrize("seed", [0, 7])
def test_checks(name, args, passes, fragment, seed):
    result = run_check(get(name), *args, rng=np.random.default_rng(seed))
    assert result.passed is passes, result.message
    assert fragment in result.line()
    assert result.points == (result.weight if passes else 0)


def test_knob_choices_cover_every_tail():
    assert set(TAILS) == set(KNOB_FOR) and set(KNOB_FOR.values()) <= set(KNOBS)


def test_off_by_one_grid_scored_zero_where_it_once_got_full_marks():
    """Issue 16: the grid start + k * period (k from 0) earned 3/3; it is a real bug in a loop."""
    r = run_check(get("ch01.drift_free_loop"), off_by_one_grid, rng=np.random.default_rng(3))
    assert (r.passed, r.points, r.weight) == (False, 0.0, 3.0)
    assert "k-th wake-up" in r.message


def test_every_wrong_answer_of_a_bad_stats_function_is_listed():
    def bad(lat, minor, major):
        d = sample_stddev(lat, minor, major)
        d["minor_pagefaults"] = int(np.max(minor))
        return d

    r = run_check(get("ch01.rttest_stats"), bad, rng=np.random.default_rng(1))
    assert "*sample* standard deviation" in r.message and "rttest sums them" in r.message
