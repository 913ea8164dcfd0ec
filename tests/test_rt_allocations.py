"""measure_allocations: a call that builds a buffer peaks higher with more data; one that writes in place
does not; what a call keeps (a list appended every cycle) is counted per call; bad arguments are refused."""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest

from robocourse.rt.allocations import measure_allocations


def _peaks(make, sizes=(2, 66), repeats=2):
    return [min(measure_allocations(make(n)).peak_bytes for _ in range(repeats)) for n in sizes]


def test_writing_into_preallocated_arrays_peaks_the_same_for_2_and_66_values():
    def make(n):
        src, dst, idx = np.arange(n, dtype=float), np.zeros(n), np.arange(n)
        return lambda: np.take(src, idx, out=dst, mode="clip")
    small, big = _peaks(make)
    assert abs(big - small) < 128


@pytest.mark.parametrize("build", [
    lambda src, idx: src[idx],                    # fancy indexing: a new array
    lambda src, idx: np.zeros(len(src)),          # a fresh buffer
    lambda src, idx: [float(v) for v in src],     # a list of boxed floats
    lambda src, idx: np.take(src, idx, out=np.empty(len(src))),
])
def test_building_a_buffer_per_call_peaks_at_least_8_bytes_more_per_value(build):
    def make(n):
        src, idx = np.arange(n, dtype=float), np.arange(n)
        return lambda: build(src, idx)
    small, big = _peaks(make)
    assert big - small >= 8 * 64


def test_np_take_without_mode_buffers_its_out_argument():   # numpy's documented behaviour for mode="raise"
    def make(n):
        src, dst, idx = np.arange(n, dtype=float), np.zeros(n), np.arange(n)
        return lambda: np.take(src, idx, out=dst)
    small, big = _peaks(make)
    assert big - small >= 8 * 64


def test_what_a_call_keeps_is_counted_per_call_and_a_flat_call_keeps_nothing():
    kept = []
    leak = measure_allocations(lambda: kept.append(np.zeros(4)))
    assert leak.retained_bytes_per_call >= 4 * 8 + 8          # the array's data and the list's slot at least
    flat = measure_allocations(lambda: np.add(1.0, 2.0))
    assert abs(flat.retained_bytes_per_call) < 8
    assert leak.calls == flat.calls == 100


def test_tracing_already_on_is_left_on_and_off_is_left_off():
    measure_allocations(lambda: None, calls=2, warmup=0)
    assert not tracemalloc.is_tracing()
    tracemalloc.start()
    try:
        measure_allocations(lambda: None, calls=2, warmup=0)
        assert tracemalloc.is_tracing()
    finally:
        tracemalloc.stop()


@pytest.mark.parametrize("kwargs, match", [
    ({"fn": 3}, "must be a function of no argument"),
    ({"fn": lambda: None, "calls": 0}, "at least one call"),
    ({"fn": lambda: None, "warmup": -1}, "warmup=-1"),
])
def test_bad_arguments_are_refused_with_the_rule(kwargs, match):
    with pytest.raises(ValueError, match=match):
        measure_allocations(**kwargs)
