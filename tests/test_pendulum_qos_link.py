"""The QoS demo of chapter 2: newest-sample age over the seeded lossy link (exact in simulated time)."""

import numpy as np
import pytest

from robocourse.pendulum.qos_link import newest_sample_ages


def test_best_effort_loses_samples_and_reliable_resends_every_one():
    r = newest_sample_ages(loss=0.05, delay=0.0005, retransmit_delay=0.001, seed=0, seconds=1.0)
    # 1000 samples offered to each of the two subscriptions
    assert r.sent == 2000
    assert 20 <= r.lost <= 80                      # about 5 % of the BEST_EFFORT half
    assert r.retransmitted >= 20                   # the RELIABLE half's losses were resent
    assert len(r.ages_ms["BEST_EFFORT"]) == len(r.ages_ms["RELIABLE"]) == 990


def test_with_a_slow_resend_reliable_serves_older_samples_than_best_effort():
    fast = newest_sample_ages(loss=0.05, delay=0.0005, retransmit_delay=0.001, seed=1, seconds=1.0)
    slow = newest_sample_ages(loss=0.05, delay=0.0005, retransmit_delay=0.01, seed=1, seconds=1.0)
    # BEST_EFFORT does not care how slow a resend would be: the same samples are lost either way
    np.testing.assert_array_equal(fast.ages_ms["BEST_EFFORT"], slow.ages_ms["BEST_EFFORT"])
    assert np.max(slow.ages_ms["BEST_EFFORT"]) <= 5.0
    # a 10 ms resend holds every newer sample behind the lost one (in-order delivery)
    assert np.max(slow.ages_ms["RELIABLE"]) >= 10.0
    assert slow.stale_fraction("RELIABLE", 1.0) > 3 * slow.stale_fraction("BEST_EFFORT", 1.0)


def test_same_seed_same_losses():
    a = newest_sample_ages(loss=0.1, delay=0.0, retransmit_delay=0.002, seed=7, seconds=0.3)
    b = newest_sample_ages(loss=0.1, delay=0.0, retransmit_delay=0.002, seed=7, seconds=0.3)
    assert a.lost == b.lost and np.array_equal(a.ages_ms["RELIABLE"], b.ages_ms["RELIABLE"])


@pytest.mark.parametrize("kw, match", [({"seconds": 0}, "seconds=0"), ({"seconds": 0.005}, "warmup=10"),
                                       ({"loss": 1.5}, "loss=1.5")])
def test_bad_arguments_are_refused(kw, match):
    args = {"loss": 0.05, "delay": 0.0, "retransmit_delay": 0.001, "seed": 0, **kw}
    with pytest.raises(ValueError, match=match):
        newest_sample_ages(**args)
