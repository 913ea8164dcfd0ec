"""robocourse.rt.inversion: a shared mutex makes the high priority loop wait; a lock-free hand-off never does."""

import pytest

from robocourse.rt import inversion

# SCHED_FIFO processes pinned to one CPU, compared by how long a reader waits: run alone
pytestmark = pytest.mark.serial

OK, WHY = inversion.available()
needs_rt = pytest.mark.skipif(not OK, reason=f"inversion needs SCHED_FIFO and affinity: {WHY}")


@needs_rt
def test_mutex_reader_waits_for_the_holder_and_lock_free_reader_never_does():
    # the writer holds the value for 20 ms at a time: a reader that takes the mutex must sometimes
    # wait for most of that; the lock-free reader copies a slot and goes on (margins of 10x, not timings)
    locked = inversion.measure("mutex", medium=False, iterations=200, hold_s=0.02, rest_s=0.01)
    free = inversion.measure("lock-free", medium=False, iterations=200, hold_s=0.02, rest_s=0.01)
    assert locked.access_ns.max() > 10e6
    assert free.access_ns.max() < 2e6
    assert len(locked.access_ns) == len(free.access_ns) == 200
    assert "waits > 1 ms" in free.summary()


@needs_rt
def test_pi_mutex_can_be_created_process_shared():
    run = inversion.measure("pi-mutex", medium=False, iterations=50)
    assert run.mode == "pi-mutex" and run.access_ns.size == 50


@pytest.mark.parametrize("kwargs,fragment", [
    ({"mode": "spinlock"}, "mode='spinlock': one of mutex, pi-mutex, lock-free"),
    ({"mode": "mutex", "iterations": 0}, "iterations=0: a positive int"),
    ({"mode": "mutex", "priorities": (50, 10, 80)}, "need 1 <= low < medium < high <= 98"),
])
def test_bad_arguments_are_refused_before_any_process_starts(kwargs, fragment):
    with pytest.raises(ValueError, match=fragment):
        inversion.measure(**kwargs)
