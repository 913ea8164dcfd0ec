"""Latest-value hand-over between the brain and the cerebellum: in one process, or across two.

Counterparts: unitree's C++ deployment (a ``std::shared_ptr`` behind a mutex: the 500 Hz
command thread reads whatever the 50 Hz policy thread wrote last), rl_sar (the control loop
``try_pop``s the newest queued target and keeps the previous one otherwise) and a ROS 2
topic with KEEP_LAST 1. A latest-value buffer is not a queue: a reader gets the newest value
or nothing new, never a backlog, and a slow writer makes the reader repeat, not wait.

- :class:`LatestValue`: two threads of one process; ``write`` copies the value in,
  ``read`` copies it out, under a ``threading.Lock``.
- :class:`SharedLatestValue`: two processes; the value lives in shared memory
  (``multiprocessing.shared_memory``) behind a process-shared lock. The real-time side uses
  ``try_read``/``try_write``, which never wait for the lock: when the other side holds it,
  the call returns at once and the reader keeps its previous value (rl_sar's ``try_lock``).

Both carry a sequence number (incremented per write) and a stamp (the writer's time), so a
reader can tell a new value from a repeat and how old it is.
"""

from __future__ import annotations

import math
import threading

import numpy as np


def _check_size(size) -> int:
    if isinstance(size, bool) or not isinstance(size, (int, np.integer)) or size < 1:
        raise ValueError(f"size={size!r} must be an int >= 1 (the number of values handed over), e.g. 6")
    return int(size)


class LatestValue:
    """The newest ``size`` float64 values, their stamp and a sequence number (threads of one process)."""

    def __init__(self, size: int):
        self.size = _check_size(size)
        self._lock = threading.Lock()
        self._value = np.zeros(self.size)
        self._stamp = math.nan
        self._seq = 0

    def write(self, value, stamp: float) -> int:
        """Copy ``value`` in (the writer may reuse its buffer); return the new sequence number."""
        v = np.asarray(value, dtype=float).reshape(-1)
        if v.size != self.size:
            raise ValueError(f"wrote {v.size} values to a LatestValue of size {self.size}")
        with self._lock:
            self._value[:] = v
            self._stamp = float(stamp)
            self._seq += 1
            return self._seq

    def read_into(self, out: np.ndarray) -> tuple[int, float]:
        """Copy the newest value into ``out``; return ``(seq, stamp)`` (seq 0: nothing written yet)."""
        with self._lock:
            out[:] = self._value
            return self._seq, self._stamp

    def read(self) -> tuple[np.ndarray, int, float]:
        """``(copy of the value, seq, stamp)``."""
        out = np.empty(self.size)
        seq, stamp = self.read_into(out)
        return out, seq, stamp


class SharedLatestValue:
    """The newest ``size`` values in shared memory, for a writer and a reader in two processes.

    Create it in the parent (``SharedLatestValue(size)``), hand ``spec()`` to the child, open it
    there with ``SharedLatestValue.attach(spec)``. The parent ``close()``s and unlinks it.
    Layout: ``[seq, stamp, value...]`` as float64; every access holds ``lock``.
    """

    def __init__(self, size: int, *, _attach: tuple | None = None):
        from multiprocessing import shared_memory

        self.size = _check_size(size)
        if _attach is None:
            import multiprocessing as mp

            self._shm = shared_memory.SharedMemory(create=True, size=8 * (self.size + 2))
            self.lock = mp.get_context("spawn").Lock()
            self._owner = True
        else:
            name, self.lock = _attach
            self._shm = shared_memory.SharedMemory(name=name)
            self._owner = False
        self._buf = np.ndarray((self.size + 2,), dtype=np.float64, buffer=self._shm.buf)
        if self._owner:
            self._buf[:] = 0.0
            self._buf[1] = math.nan

    def spec(self) -> tuple:
        """What a child process needs to attach (picklable: name, size, lock)."""
        return (self._shm.name, self.size, self.lock)

    @classmethod
    def attach(cls, spec: tuple) -> SharedLatestValue:
        name, size, lock = spec
        return cls(size, _attach=(name, lock))

    def _write(self, v: np.ndarray, stamp: float) -> int:
        b = self._buf
        b[2:] = v
        b[1] = stamp
        b[0] += 1.0
        return int(b[0])

    def write(self, value, stamp: float) -> int:
        """Copy ``value`` in, waiting for the lock if the reader holds it (the non-real-time side)."""
        v = np.asarray(value, dtype=float).reshape(-1)
        if v.size != self.size:
            raise ValueError(f"wrote {v.size} values to a SharedLatestValue of size {self.size}")
        with self.lock:
            return self._write(v, stamp)

    def try_write(self, value, stamp: float) -> int:
        """Copy ``value`` in if the lock is free now; return the new seq, or 0 (skipped, try next tick)."""
        if not self.lock.acquire(False):
            return 0
        try:
            return self._write(np.asarray(value, dtype=float).reshape(-1), stamp)
        finally:
            self.lock.release()

    def read_into(self, out: np.ndarray) -> tuple[int, float]:
        """Copy the newest value into ``out`` (waiting for the lock); ``(seq, stamp)``."""
        with self.lock:
            out[:] = self._buf[2:]
            return int(self._buf[0]), float(self._buf[1])

    def try_read_into(self, out: np.ndarray) -> tuple[int, float] | None:
        """Like :meth:`read_into` if the lock is free now; None when the writer holds it (keep the old value)."""
        if not self.lock.acquire(False):
            return None
        try:
            out[:] = self._buf[2:]
            return int(self._buf[0]), float(self._buf[1])
        finally:
            self.lock.release()

    def close(self) -> None:
        """Detach; the creating process also unlinks the memory."""
        buf, self._buf = self._buf, None
        del buf
        try:
            self._shm.close()
        except BufferError:
            return
        if self._owner:
            try:
                self._shm.unlink()
            except FileNotFoundError:
                pass
