"""robocourse.rt.stats: rttest's statistics checked against numpy, and its exact print format."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from robocourse.rt.stats import RunningStats, compute_stats, format_rttest, histogram

latencies = st.lists(st.integers(min_value=-10**6, max_value=10**8), min_size=1, max_size=500)


@settings(max_examples=200, deadline=None)
@given(latencies)
def test_stats_match_numpy(values):
    lat = np.array(values, dtype=np.int64)
    s = compute_stats(lat)
    assert s.iterations == len(values)
    assert s.min_latency == int(lat.min()) and isinstance(s.min_latency, int)
    assert s.max_latency == int(lat.max()) and isinstance(s.max_latency, int)
    assert s.mean_latency == pytest.approx(float(np.mean(lat)), rel=1e-12, abs=1e-6)
    assert s.latency_stddev == pytest.approx(float(np.std(lat, ddof=0)), rel=1e-9, abs=1e-6)
    p = np.percentile(lat, [50, 90, 99, 99.9])
    assert [s.p50, s.p90, s.p99, s.p999] == pytest.approx(list(p))


def test_stddev_is_population_not_sample():
    s = compute_stats([0, 2])
    assert s.latency_stddev == 1.0  # sample stddev (n-1) would be sqrt(2)


def test_pagefaults_are_summed_per_iteration_deltas():
    s = compute_stats([5, 6, 7], minor_pagefaults=[3, 0, 1], major_pagefaults=[0, 2, 0])
    assert (s.minor_pagefaults, s.major_pagefaults) == (4, 2)


def test_empty_and_bad_input_raise_clear_errors():
    with pytest.raises(ValueError, match="empty"):
        compute_stats([])
    with pytest.raises(ValueError, match="1-D"):
        compute_stats([[1, 2], [3, 4]])


def test_format_is_rttest_block_exactly():
    s = compute_stats([2414, 45949, 8712], [1, 0, 0], [0, 0, 0])
    text = format_rttest(s, extended=False)
    assert text == (
        "rttest statistics:\n"
        "  - Minor pagefaults: 1\n"
        "  - Major pagefaults: 0\n"
        "  Latency (time after deadline was missed):\n"
        "    - Min: 2414 ns\n"
        "    - Max: 45949 ns\n"
        f"    - Mean: {s.mean_latency:.6f} ns\n"
        f"    - Standard deviation: {s.latency_stddev:.6f}\n"
    )
    assert format_rttest(s, name="run.txt", extended=False).startswith("rttest statistics for run.txt:\n")
    assert "p99.9" in format_rttest(s)


@settings(max_examples=50, deadline=None)
@given(latencies, st.lists(st.integers(0, 50), min_size=1, max_size=500))
def test_running_stats_equal_buffered_stats(values, faults):
    faults = (faults * len(values))[: len(values)]
    r = RunningStats()
    for v, f in zip(values, faults):
        r.add(v, f, 0)
    s = compute_stats(values, faults, [0] * len(values))
    assert (r.n, r.min, r.max, r.minor) == (s.iterations, s.min_latency, s.max_latency, s.minor_pagefaults)
    assert r.mean == pytest.approx(s.mean_latency, rel=1e-9, abs=1e-6)
    assert r.stddev == pytest.approx(s.latency_stddev, rel=1e-6, abs=1e-3)


def test_histogram_counts_every_sample():
    lat = np.arange(1000)
    counts, edges = histogram(lat, bins=100)
    assert counts.sum() == 1000 and len(edges) == 101 and (counts == 10).all()
    with pytest.raises(ValueError, match="bins"):
        histogram(lat, bins=0)


@pytest.mark.parametrize("bad,fragment", [
    ([1.5, 2.7], r"latency_ns\[0\] is 1.5: rttest's samples are whole ns and would be truncated"),
    ([100.0, float("nan"), 3.0], r"latency_ns\[1\] is nan: rttest's samples are whole, finite ns"),
    ([1, 2, float("inf")], r"latency_ns\[2\] is inf"),
    ([True, False], "whole numbers"),
])
def test_non_integer_or_nan_latencies_are_refused_not_truncated(bad, fragment):
    with pytest.raises(ValueError, match=fragment):
        compute_stats(bad)


def test_whole_valued_floats_are_accepted_exactly():
    s = compute_stats([1000.0, 3000.0])
    assert (s.min_latency, s.max_latency, s.mean_latency) == (1000, 3000, 2000.0)
