"""rttest_plot's four files, and the `robocourse rttest` / `rttest-plot` commands."""

import numpy as np
import pytest

from robocourse.cli import main
from robocourse.rt.plot import rttest_plot
from robocourse.rt.results_file import read_results, write_results


def _results(tmp_path):
    rng = np.random.default_rng(0)
    return write_results(tmp_path / "run.txt", rng.integers(0, 50_000, 300), rng.integers(0, 3, 300),
                         np.zeros(300, int), 1_000_000)


@pytest.mark.parametrize("fmt,magic", [("svg", b"<svg"), ("png", b"\x89PNG")])
def test_rttest_plot_writes_the_four_named_files(tmp_path, fmt, magic):
    path = _results(tmp_path)
    paths = rttest_plot(path, fmt=fmt)
    assert [p.name for p in paths] == [f"run.txt_plot_{s}.{fmt}" for s in
                                       ("latency", "latency_hist", "minflt", "majflt")]
    for p in paths:
        assert magic in p.read_bytes()[:400]


def test_rttest_plot_bad_format(tmp_path):
    with pytest.raises(ValueError, match="svg or png"):
        rttest_plot(_results(tmp_path), fmt="jpg")


def test_cli_rttest_runs_prints_block_and_writes_file(tmp_path, capsys):
    out_file = tmp_path / "r.txt"
    rc = main(["rttest", "-i", "200", "-u", "500us", "-d", "4mb", "-f", str(out_file), "--wait", "sleep"])
    out = capsys.readouterr().out
    assert rc == 0
    assert f"rttest statistics for {out_file}:" in out
    assert "Initial minor pagefaults:" in out and "Initial major pagefaults:" in out
    data = read_results(out_file)
    assert len(data.latency) == 200 and data.period_ns == 500_000
    assert (data.latency >= 0).all()


def test_cli_rttest_sleeps_like_rttest_by_default_and_says_so(capsys):
    assert main(["rttest", "-i", "50", "-u", "1ms", "-d", "1mb"]) == 0
    out = capsys.readouterr().out
    lines = out.splitlines()
    i = lines.index("rttest statistics:")
    assert lines[i - 1] == "Wait strategy: sleep (clock_nanosleep to each absolute deadline, as rttest does)"


def test_cli_rttest_states_the_heap_prefault_once(capsys):
    # issue 25: a line printed before the prefault ("its rule faults in all of it") could contradict
    # the report of what the prefault did; now the report is the one statement, the cap a note under it
    assert main(["rttest", "-i", "20", "-u", "1ms"]) == 0
    lines = capsys.readouterr().out.splitlines()
    heap = [i for i, line in enumerate(lines) if "heap" in line and "prefault" in line]
    assert len(heap) == 1 and lines[heap[0]][3:].startswith("heap prefault")
    assert lines[heap[0] + 1].strip() == ("cap: robocourse's default, 64 MiB (rttest's default cap is 8 GiB: "
                                          "pass -d 8gb for rttest's)")


def test_cli_rttest_hybrid_is_named_in_the_block(capsys):
    assert main(["rttest", "-i", "20", "-u", "1ms", "-d", "1mb", "--wait", "hybrid", "--spin", "100us"]) == 0
    out = capsys.readouterr().out
    assert "Wait strategy: hybrid(100 us spin): sleeps, then busy-waits up to the deadline (rttest only sleeps" in out


@pytest.mark.parametrize("argv,fragment", [
    (["rttest", "-u", "fast"], "robocourse rttest: error: -u 'fast': not a duration"),
    (["rttest", "-s", "idle"], "must be fifo or rr"),
    (["rttest", "--bogus"], "unknown option '--bogus'"),
])
def test_cli_usage_errors_are_one_line_and_nonzero(capsys, argv, fragment):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert fragment in err and len(err.strip().splitlines()) == 1


def test_cli_plot(tmp_path, capsys):
    path = _results(tmp_path)
    assert main(["rttest-plot", str(path), "--format", "png", "--prefix", str(tmp_path / "p")]) == 0
    assert sorted(x.name for x in tmp_path.glob("p_*.png")) == [
        "p_latency.png", "p_latency_hist.png", "p_majflt.png", "p_minflt.png"]
    assert main(["rttest-plot", str(tmp_path / "missing.txt")]) == 2
    assert "no such results file" in capsys.readouterr().err


def test_log_bins_span_the_data_and_pile_the_floor():
    from robocourse.rt.plot import log_bins

    edges = log_bins([np.array([0.02, 1.0, 50.0]), np.array([4000.0])], bins=40, floor=0.1)
    assert len(edges) == 41 and edges[0] == 0.1 and edges[-1] == pytest.approx(4000.0, rel=1e-3)
    ratios = edges[1:] / edges[:-1]
    assert np.allclose(ratios, ratios[0])  # every decade gets the same width
    with pytest.raises(ValueError, match="positive floor"):
        log_bins([np.array([1.0])], floor=0)
