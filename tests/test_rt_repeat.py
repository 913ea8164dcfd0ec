"""robocourse.rt.repeat: interleaved rounds, medians with spread, sentences that follow the numbers."""

import numpy as np
import pytest

from robocourse.rt import FakeClock, PeriodicLoop, Sleep
from robocourse.rt.repeat import measure_rounds


class Fixed:
    """A run whose latency samples are given (stands in for a LoopResult)."""

    def __init__(self, lat):
        self.latency_ns = np.asarray(lat, dtype=np.int64)
        self.busy_ns = np.zeros_like(self.latency_ns)

    def stats(self):
        from robocourse.rt.stats import compute_stats

        return compute_stats(self.latency_ns)


def _sequence(values):
    it = iter(values)
    return lambda: Fixed([next(it)] * 10)


def test_order_alternates_every_round():
    calls = []
    rep = measure_rounds({n: (lambda n=n: calls.append(n) or Fixed([1])) for n in "abc"}, rounds=4)
    assert rep.order == [list("abc"), list("cba"), list("abc"), list("cba")]
    assert calls == list("abccbaabccba") and rep.rounds == 4


def test_median_and_range_over_rounds():
    rep = measure_rounds({"a": _sequence([1000, 5000, 2000])}, rounds=3)
    assert rep.median("a", "p50") == 2000 and rep.spread("a", "p50") == (1000, 5000)
    assert rep.cell("a", "p50") == "2.0 [1.0-5.0]"
    assert "median [lowest-highest] over 3 rounds" in rep.table(("p50",))


def test_claim_says_lower_only_when_every_round_is_apart():
    rep = measure_rounds({"a": _sequence([1000] * 5), "b": _sequence([2000, 2100, 1900, 2000, 2050])}, rounds=5)
    c = rep.claim("a", "b", "p50")
    assert c.verdict == "lower" and "**a lower than b** in every round" in c.text
    assert "a 1.0 us [1.0–1.0], b 2.0 us [1.9–2.1]" in c.text and "of 5 rounds" in c.text
    assert rep.claim("b", "a", "p50").verdict == "higher"
    mixed = measure_rounds({"a": _sequence([1, 3, 1, 3, 1]), "b": _sequence([2] * 5)}, rounds=5)
    text = mixed.claim("a", "b", "p50", scale=1, unit="ns", digits=0).text
    assert "**this run cannot tell** a from b: their ranges overlap; a was lower in 3 of 5 rounds" in text


def test_claim_of_one_experiment_against_a_limit():
    rep = measure_rounds({"a": _sequence([40_000, 60_000, 45_000])}, rounds=3)
    c = rep.claim("a", None, "max", limit=50_000, limit_name="the 5 % budget")
    assert c.verdict == "mixed" and "above the 5 % budget (50.0 us) in 1 of 3 rounds" in c.text


def test_real_loops_are_measured_each_round():
    rep = measure_rounds({"sleep": lambda: PeriodicLoop(1_000_000, 20, Sleep(), clock=FakeClock(seed=3),
                                                        pagefaults=False).run()}, rounds=2)
    assert [r.iterations for r in rep.runs["sleep"]] == [20, 20]
    assert rep.pooled_latency_ns("sleep").size == 40


@pytest.mark.parametrize("kwargs,fragment", [
    ({"experiments": {"a": lambda: None}, "rounds": 0}, "rounds=0: run every experiment at least once"),
    ({"experiments": {}, "rounds": 2}, "at least one experiment"),
    ({"experiments": {"a": 3}, "rounds": 2}, "experiment 'a' must be a function"),
])
def test_bad_arguments_are_refused(kwargs, fragment):
    with pytest.raises(ValueError, match=fragment):
        measure_rounds(**kwargs)


def test_unknown_metric_is_named():
    rep = measure_rounds({"a": _sequence([1])}, rounds=1)
    with pytest.raises(ValueError, match="unknown metric 'p42'"):
        rep.median("a", "p42")


def test_progress_line_counts_every_run(monkeypatch):
    from robocourse.notebook import progress_line as progress_mod

    seen = []

    class Recording(progress_mod.progress):
        def close(self):
            seen.append((self.n, self.total, self.desc))
            super().close()

    monkeypatch.setattr(progress_mod, "progress", Recording)
    rep = measure_rounds({"a": _sequence([1, 2]), "b": _sequence([3, 4])}, rounds=2, progress=True)
    assert rep.rounds == 2 and seen == [(4, 4, "runs")]
