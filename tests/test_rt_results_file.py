"""robocourse.rt.results_file: rttest's exact results format, written and read back."""

import numpy as np
import pytest
from robocourse.rt.results_file import HEADER, format_results, read_results, write_results


def test_exact_format_with_nominal_timestamps():
    text = format_results([120, -5, 3000], [2, 0, 1], [0, 0, 1], 1_000_000)
    assert text == (f"{HEADER}\n"
                    "0 0 120 2 0\n"
                    "1 1000000 -5 0 0\n"
                    "2 2000000 3000 1 1\n")
    assert HEADER == "iteration timestamp latency minor_pagefaults major_pagefaults"


def test_round_trip(tmp_path):
    rng = np.random.default_rng(0)
    lat = rng.integers(-1000, 10**7, 5000)
    minor = rng.integers(0, 5, 5000)
    major = rng.integers(0, 2, 5000)
    path = write_results(tmp_path / "r.txt", lat, minor, major, 500_000)
    data = read_results(path)
    np.testing.assert_array_equal(data.iteration, np.arange(5000))
    np.testing.assert_array_equal(data.timestamp, np.arange(5000) * 500_000)
    np.testing.assert_array_equal(data.latency, lat)
    np.testing.assert_array_equal(data.minor_pagefaults, minor)
    np.testing.assert_array_equal(data.major_pagefaults, major)
    assert data.period_ns == 500_000
    assert data.stats().minor_pagefaults == int(minor.sum())


def test_loop_result_writes_the_same_file(tmp_path):
    from robocourse.rt import FakeClock, PeriodicLoop, Sleep

    r = PeriodicLoop(1_000_000, 50, wait=Sleep(), clock=FakeClock(seed=1)).run()
    r.write(tmp_path / "loop.txt")
    data = read_results(tmp_path / "loop.txt")
    np.testing.assert_array_equal(data.latency, r.latency_ns)
    np.testing.assert_array_equal(data.timestamp, r.timestamps_ns)


@pytest.mark.parametrize("content,fragment", [
    ("", "not an rttest results file"),
    ("iteration latency\n0 1\n", "not an rttest results file"),
    (f"{HEADER}\n0 0 1 0\n", "line 2: expected 5"),
    (f"{HEADER}\n0 0 1 0 0\n1 1000 x 0 0\n", "line 3: not whole numbers"),
])
def test_bad_files_name_the_problem(tmp_path, content, fragment):
    p = tmp_path / "bad.txt"
    p.write_text(content)
    with pytest.raises(ValueError, match=fragment):
        read_results(p)


def test_missing_file_and_empty_run(tmp_path):
    with pytest.raises(FileNotFoundError, match="robocourse rttest -f"):
        read_results(tmp_path / "none.txt")
    with pytest.raises(ValueError, match="nothing to write"):
        write_results(tmp_path / "x.txt", [], [], [], 1000)
    with pytest.raises(ValueError, match="differ in length"):
        format_results([1, 2], [0], [0, 0], 1000)
