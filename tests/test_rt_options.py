"""robocourse.rt.options: rttest's options, units, defaults, and a clear error for every bad value."""

import pytest

from robocourse.rt.options import (
    GIB,
    KIB,
    MIB,
    RttestOptions,
    RttestUsageError,
    parse_duration,
    parse_rttest_args,
    parse_size,
)


def test_defaults_are_rttests():
    o = parse_rttest_args([])
    assert (o.iterations, o.period_ns, o.priority, o.policy, o.stack_size, o.heap_size, o.filename) == (
        1000, 1_000_000, 80, "rr", MIB, 8 * GIB, None)


@pytest.mark.parametrize("text,ns", [
    ("1ms", 1_000_000), ("250", 250_000), ("250us", 250_000), ("500000ns", 500_000), ("1s", 10**9),
    ("0.5ms", 500_000), ("2MS", 2_000_000), ("1 ms", 1_000_000),
])
def test_durations(text, ns):
    assert parse_duration(text) == ns


@pytest.mark.parametrize("text,size", [
    ("1mb", MIB), ("2", 2 * MIB), ("512kb", 512 * KIB), ("1gb", GIB), ("100b", 100), ("0", 0), ("8GB", 8 * GIB),
])
def test_sizes(text, size):
    assert parse_size(text) == size


def test_all_options_together_and_attached_values():
    o = parse_rttest_args(["-i", "20000", "-u", "500us", "-t", "98", "-s", "fifo", "-m", "2mb",
                           "-d", "64mb", "-f", "out.txt", "--wait", "spin", "--spin=50us"])
    assert o == RttestOptions(20000, 500_000, 98, "fifo", 2 * MIB, 64 * MIB, "out.txt", "spin", 50_000, None)
    assert parse_rttest_args(["-i0", "-u1ms", "-sRR"]).iterations == 0
    assert parse_rttest_args(["-i", "-5"]).iterations == -5  # <= 0 means endless, as in rttest


@pytest.mark.parametrize("argv,fragment", [
    (["-i", "ten"], "-i 'ten': the iteration count must be a whole number"),
    (["-i", "1.5"], "-i '1.5'"),
    (["-u", "fast"], "-u 'fast': not a duration"),
    (["-u", "0"], "greater than zero"),
    (["-u", "-1ms"], "greater than zero"),
    (["-u", "10min"], "unknown unit 'min'"),
    (["-u", "1.5ns"], "whole number of nanoseconds"),
    (["-u", ""], "not a duration"),
    (["-t", "high"], "-t 'high': the priority must be a whole number"),
    (["-t", "0"], "from 1 to 98"),
    (["-t", "99"], "priority 99 is where the kernel's watchdog"),
    (["-t", "100"], "from 1 to 98"),
    (["-s", "other"], "must be fifo or rr"),
    (["-s", "deadline"], "must be fifo or rr"),
    (["-m", "lots"], "-m 'lots': not a size"),
    (["-m", "1tb"], "unknown unit 'tb'"),
    (["-m", "-1mb"], "cannot be negative"),
    (["-m", "0.5b"], "whole number of bytes"),
    (["-d", "huge"], "-d 'huge': not a size"),
    (["-d", "3pb"], "unknown unit 'pb'"),
    (["-f", ""], "file name is empty"),
    (["-f", "/no/such/dir/out.txt"], "does not exist"),
    (["-x", "1"], "unknown option '-x'"),
    (["--verbose"], "unknown option '--verbose'"),
    (["-i"], "option -i needs a value"),
    (["--wait"], "option --wait needs a value"),
    (["1000"], "unexpected argument '1000'"),
    (["--wait", "yield"], "use sleep, hybrid, adaptive or spin"),
    (["--spin", "abc"], "--spin 'abc': not a duration"),
    (["-u", "100us", "--spin", "200us"], "longer than the period"),
    (["--cpu", "x"], "--cpu 'x': the CPU number must be a whole number"),
    (["--cpu", "4096"], "pick one of them"),
])
def test_every_bad_value_is_a_clear_usage_error(argv, fragment):
    with pytest.raises(RttestUsageError) as info:
        parse_rttest_args(argv)
    assert fragment in str(info.value)
    assert isinstance(info.value, ValueError)


def test_default_wait_is_rttests_sleep():
    assert parse_rttest_args([]).wait == "sleep"
    assert parse_rttest_args(["--wait", "hybrid"]).wait == "hybrid"
