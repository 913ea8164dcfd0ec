"""robocourse.rt.Adaptive: learns the sleep overshoot, spins only that window, bounded, adapts."""

import numpy as np
import pytest

from robocourse.rt import Adaptive, FakeClock, PeriodicLoop
from robocourse.rt.options import RttestUsageError, parse_rttest_args
from robocourse.rt.wait import strategy

PERIOD = 1_000_000


def run(wait, clock, n, callback=None):
    return PeriodicLoop(PERIOD, n, wait=wait, clock=clock, pagefaults=False).run(callback)


def test_window_is_the_learned_quantile_plus_margin_and_no_wake_up_is_late():
    # every sleep overshoots by 0..50 us (uniform): p99 is ~49.5 us, the window that plus 10 us
    clock = FakeClock(oversleep_ns=50_000, read_cost_ns=50, seed=1)
    a = Adaptive(max_spin_ns=300_000, quantile=0.99, margin_ns=10_000, history=1000, update_every=50)
    r = run(a, clock, 3000)
    assert 57_000 <= a.window_ns <= 60_000
    assert a.window_ns == pytest.approx(a.learned_quantile_ns() + 10_000, abs=1)
    assert a.late == 0 and r.latency_ns.max() < 1_000      # only the clock's read cost
    # it spins the window minus the overshoot: about 60 - 25 us on average, not the 300 us bound
    assert 25_000 <= a.mean_spin_ns <= 45_000
    assert a.waits == 3000 and a.window_trace[0] == (0, 300_000)


def test_starts_cautious_at_the_bound_until_it_has_seen_enough_wake_ups():
    clock = FakeClock(oversleep_ns=20_000, read_cost_ns=50, seed=2)
    a = Adaptive(max_spin_ns=250_000, update_every=40)
    run(a, clock, 39)
    assert a.window_ns == 250_000 and len(a.window_trace) == 1
    run(a, clock, 5)
    assert a.window_ns < 40_000


def test_never_spins_more_than_the_bound_however_late_the_sleeps_wake():
    # a 2 ms overshoot is beyond any window the user allows: the window stays at the bound and
    # the lateness shows as latency instead of as spinning
    clock = FakeClock(oversleep_ns=2_000_000, read_cost_ns=50, seed=3)
    a = Adaptive(max_spin_ns=100_000)
    r = run(a, clock, 500)
    assert a.window_ns == 100_000 and max(w for _, w in a.window_trace) == 100_000
    assert a.mean_spin_ns <= 100_000
    assert a.late > 0 and r.latency_ns.max() > 1_000_000


def test_adapts_when_the_load_comes_and_goes():
    clock = FakeClock(oversleep_ns=10_000, read_cost_ns=50, seed=4)
    a = Adaptive(max_spin_ns=400_000, history=500, update_every=25)
    phases = {1000: 200_000, 2000: 10_000}            # a disturbance on at 1000, off at 2000

    def callback(tick):
        clock.oversleep_ns = phases.get(tick.iteration, clock.oversleep_ns)

    r = run(a, clock, 3500, callback)
    ks = np.array([k for k, _ in a.window_trace])
    ws = np.array([w for _, w in a.window_trace])
    window_at = ws[np.searchsorted(ks, np.arange(3500), side="right") - 1]   # the window in force at wait i
    assert window_at[999] < 30_000                     # quiet: a small window
    # load on: each late wake-up widens the window at once (to it + the margin), so only a new
    # largest overshoot can be late: a handful at first, then none
    late_after_on = r.latency_ns[1000:1500] > 1_000
    assert 1 <= late_after_on.sum() <= 10 and not late_after_on[100:].any()
    assert window_at[1050] > 150_000
    assert window_at[1999] > 150_000                   # still loaded: it keeps the wide window
    # load off: forgotten once `history` newer wake-ups replace the loaded ones
    assert window_at[2600] < 30_000
    assert (r.latency_ns[2000:] < 1_000).all()         # narrowing never makes a wake-up late


def test_recomputes_only_when_there_is_time_before_the_sleep():
    # a callback that uses the whole period leaves no time to recompute: the window stays put
    # (never a late wake-up caused by bookkeeping), and it learns again once there is time
    clock = FakeClock(oversleep_ns=20_000, read_cost_ns=50, seed=5)
    a = Adaptive(max_spin_ns=300_000, update_every=10)

    def busy(tick):
        clock.work(PERIOD - 300_000 if tick.iteration < 200 else 0)

    run(a, clock, 200 + 100, busy)
    changes = [k for k, _ in a.window_trace[1:]]
    assert changes and min(changes) >= 200


@pytest.mark.parametrize("kwargs, fragment", [
    ({"max_spin_ns": -1}, "max_spin_ns"),
    ({"max_spin_ns": 1.5}, "max_spin_ns"),
    ({"quantile": 1.0}, "quantile"),
    ({"quantile": 0.2}, "quantile"),
    ({"margin_ns": -5}, "margin_ns"),
    ({"history": 5}, "history"),
    ({"update_every": 0}, "update_every"),
    ({"history": 100, "update_every": 200}, "update_every"),
])
def test_bad_arguments_name_the_value_and_the_fix(kwargs, fragment):
    with pytest.raises(ValueError, match=fragment) as err:
        Adaptive(**kwargs)
    assert "e.g. Adaptive(" in str(err.value)


def test_real_clock_never_wakes_early_and_accounts_its_spin():
    a = Adaptive(max_spin_ns=200_000)
    r = PeriodicLoop(500_000, 400, wait=a).run()
    assert (r.latency_ns >= 0).all()                   # it spins to the deadline, never returns early
    assert a.waits == 400 and 0 <= a.spin_ns_total <= 400 * 200_000 + 400 * 500_000
    assert 0 <= a.window_ns <= 200_000
    assert r.cpu_ns > 0 and r.wall_ns >= 400 * 500_000 and 0 < r.cpu_share <= 1.5
    assert "adaptive wait: window" in a.describe(500_000) and "% of a core" in a.describe(500_000)


def test_rttest_accepts_wait_adaptive_with_spin_as_its_bound_and_sleep_stays_default():
    assert parse_rttest_args([]).wait == "sleep"
    opts = parse_rttest_args(["--wait", "adaptive", "--spin", "150us"])
    w = strategy(opts.wait, opts.spin_ns)
    assert isinstance(w, Adaptive) and w.max_spin_ns == 150_000
    with pytest.raises(RttestUsageError, match="adaptive"):
        parse_rttest_args(["--wait", "smart"])
