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

import contextlib
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

    Create it in one process (``SharedLatestValue(size)``), hand ``spec()`` (plain JSON data:
    the memory's name, the size and a lock file's path) to the other, open it there with
    ``SharedLatestValue.attach(spec)``. The creator ``close()``s and removes both.
    Layout: ``[seq, stamp, value...]`` as float64; every access holds an exclusive ``flock``
    on the lock file (a system call: it orders the memory accesses on every CPU, and works
    between any two processes, however they were started).
    """

    def __init__(self, size: int, *, _attach: tuple | None = None):
        import os
        import tempfile

        self.size = _check_size(size)
        if _attach is None:
            self._shm = _untracked_shm(create=True, size=8 * (self.size + 2))
            fd, self.lock_path = tempfile.mkstemp(prefix="robocourse_latest_", suffix=".lock")
            os.close(fd)
            self._owner = True
        else:
            name, self.lock_path = _attach
            self._shm = _untracked_shm(name=name)
            self._owner = False
        self._fd = os.open(self.lock_path, os.O_RDWR)
        self._buf = np.ndarray((self.size + 2,), dtype=np.float64, buffer=self._shm.buf)
        if self._owner:
            self._buf[:] = 0.0
            self._buf[1] = math.nan

    def spec(self) -> list:
        """What another process needs to attach: ``[memory name, size, lock file]`` (JSON-able)."""
        return [self._shm.name, self.size, self.lock_path]

    @classmethod
    def attach(cls, spec) -> SharedLatestValue:
        name, size, lock_path = spec
        return cls(int(size), _attach=(str(name), str(lock_path)))

    # --- the lock -----------------------------------------------------------------------------
    def _acquire(self, block: bool) -> bool:
        import fcntl

        try:
            fcntl.flock(self._fd, fcntl.LOCK_EX | (0 if block else fcntl.LOCK_NB))
        except BlockingIOError:
            return False
        return True

    def _release(self) -> None:
        import fcntl

        fcntl.flock(self._fd, fcntl.LOCK_UN)

    @contextlib.contextmanager
    def locked(self):
        """Hold the lock (blocking) for the ``with`` block: what the other side sees as busy."""
        self._acquire(True)
        try:
            yield self
        finally:
            self._release()

    # --- values -------------------------------------------------------------------------------
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
        with self.locked():
            return self._write(v, stamp)

    def try_write(self, value, stamp: float) -> int:
        """Copy ``value`` in if the lock is free now; return the new seq, or 0 (skipped, try next tick)."""
        v = np.asarray(value, dtype=float).reshape(-1)
        if v.size != self.size:
            raise ValueError(f"wrote {v.size} values to a SharedLatestValue of size {self.size}")
        if not self._acquire(False):
            return 0
        try:
            return self._write(v, stamp)
        finally:
            self._release()

    def read_into(self, out: np.ndarray) -> tuple[int, float]:
        """Copy the newest value into ``out`` (waiting for the lock); ``(seq, stamp)``."""
        with self.locked():
            out[:] = self._buf[2:]
            return int(self._buf[0]), float(self._buf[1])

    def try_read_into(self, out: np.ndarray) -> tuple[int, float] | None:
        """Like :meth:`read_into` if the lock is free now; None when the writer holds it (keep the old value)."""
        if not self._acquire(False):
            return None
        try:
            out[:] = self._buf[2:]
            return int(self._buf[0]), float(self._buf[1])
        finally:
            self._release()

    def read(self) -> tuple[np.ndarray, int, float]:
        """``(copy of the value, seq, stamp)``."""
        out = np.empty(self.size)
        seq, stamp = self.read_into(out)
        return out, seq, stamp

    def close(self) -> None:
        """Detach; the creating process also removes the memory and the lock file."""
        import os

        if self._buf is None:
            return
        self._buf = None
        os.close(self._fd)
        try:
            self._shm.close()
        except BufferError:
            return
        if self._owner:
            for remove in (lambda: _unlink_shm(self._shm), lambda: os.unlink(self.lock_path)):
                try:
                    remove()
                except FileNotFoundError:
                    pass


def _untracked_shm(**kwargs):
    """Shared memory that no resource tracker owns: the creator removes it in ``close()``.

    Before Python 3.13 every process that opened a segment registered it with a resource tracker
    (shared with multiprocessing children, separate for other processes), and an attaching
    process's tracker removed the creator's memory, or complained, when it exited.
    """
    from multiprocessing import resource_tracker, shared_memory

    try:
        return shared_memory.SharedMemory(track=False, **kwargs)
    except TypeError:                                   # Python < 3.13: no track argument
        shm = shared_memory.SharedMemory(**kwargs)
        try:
            resource_tracker.unregister(shm._name, "shared_memory")
        except Exception:  # noqa: BLE001 - best effort: the tracker only warns
            pass
        return shm


def _unlink_shm(shm) -> None:
    try:
        shm.unlink() if getattr(shm, "_track", True) is False else _posix_unlink(shm)
    except TypeError:
        _posix_unlink(shm)


def _posix_unlink(shm) -> None:
    from multiprocessing import shared_memory

    shared_memory._posixshmem.shm_unlink(shm._name)     # unlink without telling a tracker that never knew
