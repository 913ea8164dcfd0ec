"""robocourse.rt.cyclictest: parse its summary, verbose and JSON output; missing-binary message."""

import json
import shutil

import numpy as np
import pytest
from robocourse.rt import cyclictest as ct

SUMMARY = "T: 0 ( 9923) P:80 I:1000 C:   2000 Min:     14 Act:   26 Avg:   25 Max:    2915\n"
VERBOSE = ("Max CPUs = 2\nOnline CPUs = 2\n# /dev/cpu_dma_latency set to 0us\nThread 0 Interval: 1000\n"
           "       0:       0:   20322\n       0:       1:   15206\n       1:       0:   999\n"
           "       0:       2:   14116\n" + SUMMARY.replace("Min:     14", "Min:  14116"))
JSON = {"file_version": 1, "rt_test_version:": "2.40", "sysinfo": {"realtime": 0}, "num_threads": 1,
        "thread": {"0": {"histogram": {"13": 26, "14": 107}, "cycles": 133, "min": 13, "max": 14,
                         "avg": 13.8, "cpu": 0, "node": 0}}}


def test_parse_summary_line():
    (t,) = ct.parse_summary(SUMMARY)
    assert (t.thread, t.tid, t.priority, t.interval_us, t.cycles, t.min, t.act, t.avg, t.max) == (
        0, 9923, 80, 1000, 2000, 14, 26, 25, 2915)
    assert len(ct.parse_summary(SUMMARY + SUMMARY.replace("T: 0", "T: 1"))) == 2


def test_parse_verbose_per_thread():
    np.testing.assert_array_equal(ct.parse_verbose(VERBOSE), [20322, 15206, 14116])
    np.testing.assert_array_equal(ct.parse_verbose(VERBOSE, thread=1), [999])


def test_parse_json():
    d = ct.parse_json(json.dumps(JSON))
    assert d["version"] == "2.40" and d["realtime_kernel"] is False
    assert d["threads"][0]["histogram"] == {13: 26, 14: 107} and d["threads"][0]["cycles"] == 133


def test_missing_cyclictest_says_how_to_install(monkeypatch):
    monkeypatch.setenv("PATH", "/nonexistent")
    assert not ct.available()
    with pytest.raises(ct.CyclictestMissing, match="sudo apt-get install rt-tests"):
        ct.run_cyclictest(loops=10)


def test_command_matches_the_python_loop_settings():
    if not ct.available():
        pytest.skip("cyclictest not installed (sudo apt-get install rt-tests)")
    cmd = ct.build_command(interval_us=500, loops=100, priority=80, policy="fifo", mlock=True, cpu=1)
    assert cmd[1:] == ["-t", "1", "-i", "500", "-d", "0", "-l", "100", "-N", "-q", "--policy=fifo",
                       "-p", "80", "-m", "-a", "1", "-v"]
    with pytest.raises(ValueError, match="policy"):
        ct.build_command(policy="batchy")


@pytest.mark.skipif(shutil.which("cyclictest") is None, reason="cyclictest not installed (rt-tests)")
def test_real_run_returns_every_sample():
    r = ct.run_cyclictest(interval_us=1000, loops=200)
    assert len(r.latency_ns) == 200 and r.unit == "ns"
    (t,) = r.threads
    assert t.cycles == 200 and t.min == r.latency_ns.min() and t.max == r.latency_ns.max()
    assert r.stats().iterations == 200
