"""Disturbances for experiments: the things that put a tail on a loop's latency.

No single ROS 2 counterpart: the seed's write-up names them (other load on the core,
allocating in the loop, page faults on fresh memory, logging) and the pendulum demo is run
under ``stress``. Python adds its own: the garbage collector. In-loop disturbances are
callables to pass as (or chain into) the loop's callback; :class:`CpuLoad` is a context
manager running busy processes pinned to a CPU.
"""

from __future__ import annotations

import collections
import gc
import logging
import mmap
import os
import subprocess
import sys
import threading
import time

# A child inherits its parent's scheduling policy: started from a SCHED_FIFO process (rttest with
# -p, a benchmark's RT settings) a busy loop would be a real-time hog that starves every CPU it may
# use. It returns to SCHED_OTHER first, so it is always the ordinary load the docstring promises.
# A parent killed by a signal runs no __exit__: the loop looks up its parent every few million turns
# (a fraction of a second) and ends once it has been re-parented, so no orphan spins on.
_BUSY = ("import os, sys\n"
         "parent = int(sys.argv[1])\n"
         "if hasattr(os, 'sched_setscheduler'):\n"
         "    try:\n        os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0))\n"
         "    except OSError:\n        pass\n"
         "if hasattr(os, 'sched_setaffinity'):\n    os.sched_setaffinity(0, {int(a) for a in sys.argv[2:]})\n"
         "n = 0\n"
         "while True:\n    n += 1\n"
         "    if n == 3_000_000:\n        n = 0\n"
         "        if os.getppid() != parent:\n            break\n")


class CpuLoad:
    """``with CpuLoad(cpu=1, processes=2):`` busy-looping processes pinned to ``cpu`` (like stress -c).

    They run under SCHED_OTHER: a SCHED_OTHER loop on the same core must share the CPU with
    them (the scheduler's fair share shows up as latency); a SCHED_FIFO loop preempts them.
    Entering and leaving may happen on two threads (chapter 1 switches the load on and off from
    threads so the measured loop never waits): leaving waits until entering has started every
    process, then ends them all, so none is left spinning and no one waits on a process nobody ended.
    """

    def __init__(self, cpu: int | None = None, processes: int = 1):
        allowed = (sorted(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity")
                   else list(range(os.cpu_count() or 1)))
        if cpu is None:
            cpu = allowed[-1]
        if cpu not in allowed:
            raise ValueError(f"CpuLoad(cpu={cpu!r}): this process may use CPUs {allowed}; pick one of them")
        if not isinstance(processes, int) or processes < 1:
            raise ValueError(f"CpuLoad(processes={processes!r}): need at least 1 process")
        self.cpu = cpu
        self.processes = processes
        self._procs: list[subprocess.Popen] = []
        self._lock = threading.Lock()

    def __enter__(self):
        with self._lock:
            for _ in range(self.processes):
                self._procs.append(subprocess.Popen([sys.executable, "-c", _BUSY, str(os.getpid()), str(self.cpu)],
                                                    stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL))
        time.sleep(0.05)  # let them start spinning before the measurement does
        return self

    def __exit__(self, *exc):
        with self._lock:      # an __enter__ still starting processes on another thread finishes first
            procs, self._procs = self._procs, []
        for p in procs:
            p.kill()
        for p in procs:
            p.wait()
        return False

    @property
    def pids(self) -> list[int]:
        return [p.pid for p in self._procs]


class AllocationStorm:
    """Allocate (and drop) ``objects`` small Python objects and a ``nbytes`` buffer every iteration."""

    def __init__(self, objects: int = 2000, nbytes: int = 256 * 1024):
        self.objects = int(objects)
        self.nbytes = int(nbytes)

    def __call__(self, tick=None):
        junk = [(i, str(i)) for i in range(self.objects)]
        buf = bytearray(self.nbytes)
        del junk, buf
        return None


class FreshMemory:
    """Map ``nbytes`` of brand-new anonymous memory every iteration and touch each page.

    Every first touch of a page is a minor page fault (the kernel finds and zeroes a page):
    ``nbytes / 4096`` faults per iteration, which no prefaulting can prevent, because the
    memory is new each time. The cure is to allocate before the loop and reuse.
    """

    def __init__(self, nbytes: int = 1024 * 1024):
        if nbytes < mmap.PAGESIZE:
            raise ValueError(f"FreshMemory(nbytes={nbytes!r}): use at least one page ({mmap.PAGESIZE} B)")
        self.nbytes = int(nbytes)

    def __call__(self, tick=None):
        m = mmap.mmap(-1, self.nbytes)
        for offset in range(0, self.nbytes, mmap.PAGESIZE):
            m[offset] = 1
        m.close()
        return None


class HeapGrowth:
    """Grow the malloc heap by ``chunk`` bytes every iteration, keeping ``keep`` chunks alive.

    This is the allocation pattern rttest's dynamic prefault is made for: the first time the
    heap grows into new pages they fault *inside the loop*. After
    :func:`~robocourse.rt.settings.prefault_heap` (heap faulted in once, M_TRIM_THRESHOLD -1
    so freed memory stays mapped, M_MMAP_MAX 0) the same allocations reuse mapped pages: zero faults.
    """

    def __init__(self, chunk: int = 64 * 1024, keep: int = 200):
        self.chunk = int(chunk)
        self.keep = int(keep)
        self._held: list[bytearray] = []

    def __call__(self, tick=None):
        self._held.append(bytearray(self.chunk))  # zero-filled: every page is written
        if len(self._held) >= self.keep:
            self._held.clear()
        return None


class GcPressure:
    """A large live state plus a rolling window of recent objects: the gc's worst case.

    ``live`` containers stay alive the whole time (a map, a model, a history). Each iteration
    creates ``per_iteration`` small self-referencing containers and keeps the last ``window``
    iterations' worth (recent messages, say). Because they are cycles, dropping them does not
    free them: CPython's allocation count keeps growing, young collections run regularly,
    the survivors reach the oldest generation, and every so often a *full* collection walks
    all ``live`` objects too. gc.freeze() takes the live state out of that walk.
    """

    def __init__(self, live: int = 300_000, per_iteration: int = 100, window: int = 200):
        self.live = [[i] for i in range(int(live))]
        self.per_iteration = int(per_iteration)
        self.recent: collections.deque = collections.deque(maxlen=int(window))

    def __call__(self, tick=None):
        batch = [[] for _ in range(self.per_iteration)]
        for node in batch:
            node.append(node)  # a reference cycle (think parent <-> child): only the gc can free it
        self.recent.append(batch)
        return None

    @staticmethod
    def time_full_collection() -> float:
        """Seconds one gc.collect() takes right now."""
        t = time.perf_counter()
        gc.collect()
        return time.perf_counter() - t


class GcPauses:
    """``with GcPauses() as p:`` records the duration of every collection (gc.callbacks)."""

    def __init__(self):
        self.pauses: list[tuple[int, float]] = []
        self._t0 = 0.0

    def _callback(self, phase, info):
        if phase == "start":
            self._t0 = time.perf_counter()
        else:
            self.pauses.append((info["generation"], time.perf_counter() - self._t0))

    def __enter__(self):
        gc.callbacks.append(self._callback)
        return self

    def __exit__(self, *exc):
        gc.callbacks.remove(self._callback)
        return False

    def full(self) -> list[float]:
        """Durations (s) of the full (generation 2) collections."""
        return [d for g, d in self.pauses if g == 2]


class LogEveryIteration:
    """Log one line per iteration through ``logging`` to a file (the seed's "don't print in the loop")."""

    def __init__(self, path, level: int = logging.INFO):
        self.logger = logging.getLogger(f"robocourse.rt.disturb.{id(self)}")
        self.logger.propagate = False
        self.logger.setLevel(level)
        self.handler = logging.FileHandler(path, mode="w")
        self.handler.setFormatter(logging.Formatter("%(asctime)s %(levelname)s %(message)s"))
        self.logger.addHandler(self.handler)

    def __call__(self, tick=None):
        if tick is not None:
            self.logger.info("iteration %d latency %d ns", tick.iteration, tick.latency_ns)
        else:
            self.logger.info("iteration")
        return None

    def close(self):
        self.logger.removeHandler(self.handler)
        self.handler.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False


def chain(*callbacks):
    """One callback that calls each of ``callbacks`` in order (and passes STOP through)."""
    from .loop import STOP

    def run(tick):
        result = None
        for cb in callbacks:
            if cb(tick) is STOP:
                result = STOP
        return result

    return run
