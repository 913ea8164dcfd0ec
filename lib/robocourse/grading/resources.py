"""Per-submission resources: memory (shared memory and memfd included), CPU and processes by cgroup.

Counterpart: Gradescope and otter run each submission in a container whose cgroup carries its
limits; nbgrader has none. Polling the resident memory of a sandbox's processes misses memory
held outside any process (POSIX shared memory, a memfd, tmpfs files): 3 GB held that way under
a 1 GB limit, and CPU spinners within the process limit slowed an honest neighbour's timing
check. A cgroup charges every page a submission touches, shmem included, to that submission.

Three ways, chosen by :func:`mode` (the grader says which in its summary):

- ``"cgroup-v1"`` (root, controllers mounted, as on this machine): one cgroup per submission in
  the memory, pids, cpu and cpuset hierarchies, each created *under the grader's own cgroup*
  (usage still rolls up to whoever limits the grader): ``memory.limit_in_bytes`` (and
  ``memsw``, no swap), ``pids.max``, ``cpu.cfs_quota_us`` (at most one CPU) and, for an exclusive
  CPU slot, ``cpuset.cpus`` and a weight (``cpu.shares``, :data:`TIMING_WEIGHT`). The sandbox's first process joins them before it execs, so every
  descendant is inside. A kernel OOM kill or a refused fork is read back (``memory.oom_control``,
  ``pids.events``) and ends the run with the reason.
- ``"cgroup-v2-delegated"`` (not root, a systemd user session): the command runs under
  ``systemd-run --user --scope`` with ``MemoryMax``, ``MemorySwapMax=0``, ``TasksMax``,
  ``CPUQuota`` and, for a slot, ``AllowedCPUs`` and ``CPUWeight`` (cgroup v2, delegated to the user).
- ``"polling"`` (neither): the sandbox's resident memory and process count are polled every
  0.1 s with RLIMIT_AS per process as a backstop; memory held outside processes is counted only
  where it is visible (the sandbox's private /dev/shm and its work folder). CPU isolation is an
  affinity mask the code could change; the grader says so.

The work folder and /dev/shm are private and size-limited in every mode with bubblewrap: /dev/shm
is the sandbox's own tmpfs (``--size``); the work folder is a tmpfs mounted for the submission
when the grader is root (its pages are charged to the submission's memory cgroup too), else its
size is polled.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import signal
import subprocess
import threading
import uuid
from dataclasses import dataclass, field
from pathlib import Path

CGROUP_ROOT = Path("/sys/fs/cgroup")
V1_CONTROLLERS = ("memory", "pids", "cpu", "cpuset")
_MODE: list[str] = []


def _own_v1_path(controller: str) -> Path | None:
    """This process's cgroup directory in a v1 hierarchy (from /proc/self/cgroup)."""
    try:
        lines = Path("/proc/self/cgroup").read_text().splitlines()
    except OSError:
        return None
    for line in lines:
        _, names, path = line.split(":", 2)
        if controller in names.split(","):
            return CGROUP_ROOT / controller / path.lstrip("/")
    return None


#: why each cgroup way was not taken (filled by :func:`mode`; shown when the grader falls back to polling)
WHY_NOT: dict[str, str] = {}


def _v1_usable() -> bool:
    if os.geteuid() != 0:
        WHY_NOT["cgroup-v1"] = "the grader is not root"
        return False
    for c in V1_CONTROLLERS:
        base = _own_v1_path(c)
        if base is None or not base.is_dir():
            WHY_NOT["cgroup-v1"] = f"no cgroup v1 {c} hierarchy is mounted"
            return False
        probe = base / f"robocourse-probe-{uuid.uuid4().hex[:8]}"
        try:
            probe.mkdir()
            probe.rmdir()
        except OSError as exc:
            WHY_NOT["cgroup-v1"] = f"a cgroup cannot be made in {base} ({exc.strerror or exc})"
            return False
    return True


def sweep_stale_v1(min_age_s: float = 60.0) -> list[Path]:
    """Remove empty ``robocourse-sub-<pid>-*`` cgroups whose grader is gone (a grader killed by SIGKILL
    cannot clean up after itself); returns what was removed. Only empty ones: rmdir refuses the rest."""
    import time

    removed = []
    for c in V1_CONTROLLERS:
        base = _own_v1_path(c)
        if base is None:
            continue
        try:
            entries = list(base.glob("robocourse-sub-*"))
        except OSError:
            continue
        for d in entries:
            try:
                pid = int(d.name.split("-")[2])
                os.kill(pid, 0)
                continue  # its grader still runs
            except ProcessLookupError:
                pass
            except (ValueError, IndexError, PermissionError):
                continue
            try:
                if time.time() - d.stat().st_mtime < min_age_s:
                    continue
                d.rmdir()
                removed.append(d)
            except OSError:
                pass
    return removed


V2_TRIAL = ["systemd-run", "--user", "--scope", "--quiet", "-p", "MemoryMax=64M", "-p", "TasksMax=16",
            "-p", "CPUQuota=100%", "true"]


def _v2_delegated_usable() -> bool:
    if os.geteuid() == 0:
        WHY_NOT["cgroup-v2-delegated"] = "it is for a grader that is not root (as root, cgroup v1 is the way)"
        return False
    if shutil.which("systemd-run") is None:
        WHY_NOT["cgroup-v2-delegated"] = "systemd-run is not installed (no systemd)"
        return False
    try:
        proc = subprocess.run(V2_TRIAL, capture_output=True, text=True, timeout=20)
    except (OSError, subprocess.TimeoutExpired) as exc:
        WHY_NOT["cgroup-v2-delegated"] = f"`{' '.join(V2_TRIAL)}` did not run ({exc})"
        return False
    if proc.returncode != 0:
        said = (proc.stderr or proc.stdout).strip().splitlines()
        WHY_NOT["cgroup-v2-delegated"] = (f"`{' '.join(V2_TRIAL)}` failed (exit {proc.returncode}"
                                          + (f": {said[0][:200]}" if said else "") + ")")
        return False
    return True


def fallback_hint() -> str:
    """Why no cgroup was used and what the instructor needs for one (empty when a cgroup way is in use)."""
    if mode() != "polling":
        return ""
    why = "; ".join(f"{k}: {v}" for k, v in WHY_NOT.items()) or "ROBOCOURSE_GRADE_RESOURCES=polling"
    return (f"no cgroup ({why}). For per-submission limits that count shared memory, run the grader either as "
            "root with the cgroup v1 memory, pids, cpu and cpuset controllers mounted, or as a user of a systemd "
            f"session in which `{' '.join(V2_TRIAL)}` succeeds (cgroup v2 with the memory, pids and cpu "
            "controllers delegated to the user: systemd's user@.service has Delegate=yes by default)")


def mode() -> str:
    """"cgroup-v1", "cgroup-v2-delegated" or "polling" (decided once per process)."""
    if not _MODE:
        forced = os.environ.get("ROBOCOURSE_GRADE_RESOURCES", "")
        if forced in ("cgroup-v1", "cgroup-v2-delegated", "polling"):
            _MODE.append(forced)
        else:
            _MODE.append("cgroup-v1" if _v1_usable() else "cgroup-v2-delegated" if _v2_delegated_usable()
                         else "polling")
            if _MODE[0] == "cgroup-v1":
                sweep_stale_v1()
    return _MODE[0]


#: A timing slot's cgroup weight, in ordinary processes per CPU it was given (cgroup v1 ``cpu.shares`` =
#: 1024 x this x CPUs; v2 ``CPUWeight``). The cgroup is one scheduling entity: at the default weight a
#: submission's loop *and* the simulated robot it talks to shared one process's turn against every busy
#: process beside the grader (the FR3 box then sent 5 states in 70 ms under chapter 1's CPU load and the
#: verdict was the machine's). Its CPU time stays capped by its quota; the weight only decides who runs first
#: (clamped to the kernel's and systemd's maxima: 262144 shares, CPUWeight 10000).
TIMING_WEIGHT = 8


def allowed_cpus() -> list[int]:
    return sorted(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else list(range(os.cpu_count() or 1))


class CpuGate:
    """Who may run while a submission is graded: a submission with a timing check runs alone with
    every CPU (the grader starts no other submission until it ends; one already waiting goes
    first), the others run side by side, each held to one CPU's worth of time by its cgroup."""

    def __init__(self):
        self._cond = threading.Condition()
        self._active = 0
        self._exclusive = False
        self._waiting = 0

    @contextlib.contextmanager
    def hold(self, exclusive: bool):
        with self._cond:
            if exclusive:
                self._waiting += 1
                self._cond.wait_for(lambda: self._active == 0 and not self._exclusive)
                self._waiting -= 1
                self._exclusive = True
            else:
                self._cond.wait_for(lambda: not self._exclusive and not self._waiting)
                self._active += 1
        try:
            yield tuple(allowed_cpus()) if exclusive else None
        finally:
            with self._cond:
                if exclusive:
                    self._exclusive = False
                else:
                    self._active -= 1
                self._cond.notify_all()


def machine_busy() -> str:
    """A sentence when other programs load the machine (load average above its CPU count), else ''."""
    try:
        load = os.getloadavg()[0]
    except OSError:
        return ""
    n = len(allowed_cpus())
    return f"load average {load:.1f} on {n} CPU(s)" if load > n else ""


@dataclass
class Usage:
    """What a submission used, read back from its cgroup (None where the mode cannot tell)."""

    peak_memory_mb: float | None = None
    oom_kills: int = 0
    refused_forks: int = 0
    peak_processes: int | None = None


@dataclass
class Box:
    """One submission's resource limits in the chosen mode; use as a context manager."""

    memory_mb: int
    max_processes: int
    cpus: tuple[int, ...] | None = None  # CPUs it has to itself (a timing check), or None: one CPU's worth
    mode: str = field(default_factory=mode)
    dirs: dict = field(default_factory=dict)
    unit: str = ""
    fallback: str = ""  # why this submission fell back to polling, if it did

    def __enter__(self) -> Box:
        if self.mode == "cgroup-v1":
            name = f"robocourse-sub-{os.getpid()}-{uuid.uuid4().hex[:10]}"
            try:
                for c in V1_CONTROLLERS:
                    d = _own_v1_path(c) / name
                    d.mkdir()
                    self.dirs[c] = d
                limit = self.memory_mb * 2**20
                (self.dirs["memory"] / "memory.limit_in_bytes").write_text(str(limit))
                memsw = self.dirs["memory"] / "memory.memsw.limit_in_bytes"
                if memsw.exists():
                    memsw.write_text(str(limit))
                (self.dirs["pids"] / "pids.max").write_text(str(self.max_processes))
                period = int((self.dirs["cpu"] / "cpu.cfs_period_us").read_text())
                share = len(self.cpus) if self.cpus else 1
                (self.dirs["cpu"] / "cpu.cfs_quota_us").write_text(str(period * share))
                if self.cpus:   # a timing slot weighs as TIMING_WEIGHT ordinary processes per CPU (see below)
                    (self.dirs["cpu"] / "cpu.shares").write_text(str(min(262144, 1024 * TIMING_WEIGHT * share)))
                cpus = ",".join(map(str, self.cpus)) if self.cpus else \
                    (self.dirs["cpuset"].parent / "cpuset.cpus").read_text().strip()
                (self.dirs["cpuset"] / "cpuset.cpus").write_text(cpus)
                (self.dirs["cpuset"] / "cpuset.mems").write_text(
                    (self.dirs["cpuset"].parent / "cpuset.mems").read_text().strip())
            except OSError as exc:  # a controller refused (a full cgroup tree, a read-only mount): poll instead
                self.__exit__()
                self.mode, self.fallback = "polling", f"the cgroup could not be made ({exc.strerror or exc})"
            else:
                # a cgroup can exist and still refuse a process (an empty cpuset, a foreign hierarchy, a
                # real-time task in a cpu cgroup without an RT budget): a parked child, started as the
                # submission will be (at SCHED_OTHER), is put in first by this process, which sees the errno
                # (a failure inside preexec_fn reaches the parent only as "Exception occurred in preexec_fn")
                refused = self._test_join()
                if refused:
                    self.__exit__()
                    self.mode, self.fallback = "polling", f"the cgroup refused a process ({refused})"
        elif self.mode == "cgroup-v2-delegated":
            self.unit = f"robocourse-sub-{uuid.uuid4().hex[:10]}"
        return self

    def __exit__(self, *exc) -> bool:
        for c, d in list(self.dirs.items()):
            try:
                for pid in (d / "cgroup.procs").read_text().split():
                    try:
                        os.kill(int(pid), signal.SIGKILL)
                    except (ProcessLookupError, ValueError, PermissionError):
                        pass
            except OSError:
                pass
            for _ in range(50):  # a killed process leaves its cgroup a moment later
                try:
                    d.rmdir()
                    break
                except OSError:
                    import time

                    time.sleep(0.02)
            self.dirs.pop(c, None)
        return False

    def wrap(self, argv: list[str]) -> list[str]:
        """The command line that runs ``argv`` inside the limits (v2: through systemd-run)."""
        if self.mode != "cgroup-v2-delegated":
            return argv
        props = [f"MemoryMax={self.memory_mb}M", "MemorySwapMax=0", f"TasksMax={self.max_processes}",
                 f"CPUQuota={100 * (len(self.cpus) if self.cpus else 1)}%"]
        if self.cpus:
            props += [f"AllowedCPUs={','.join(map(str, self.cpus))}", f"CPUWeight={min(10000, 100 * TIMING_WEIGHT * len(self.cpus))}"]
        cmd = ["systemd-run", "--user", "--scope", "--quiet", f"--unit={self.unit}"]
        for p in props:
            cmd += ["-p", p]
        return cmd + ["--"] + argv

    def _test_join(self) -> str:
        """Put a parked child into every cgroup of this box; '' when all took it, else which refused and why."""
        try:
            child = subprocess.Popen(["sleep", "30"], preexec_fn=_drop_realtime, stdin=subprocess.DEVNULL,
                                     stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        except (OSError, subprocess.SubprocessError) as exc:
            return f"no test process could start: {exc}"
        try:
            self._enter(child.pid)
        except OSError as exc:
            return f"its {exc.filename} cgroup: {exc.strerror or exc}"
        finally:
            child.kill()
            child.wait()
        with contextlib.suppress(OSError):  # the peak read back later is the submission's, not this child's
            (self.dirs["memory"] / "memory.max_usage_in_bytes").write_text("0")
        return ""

    def _enter(self, pid: int) -> None:
        for c, d in self.dirs.items():
            try:
                (d / "cgroup.procs").write_text(str(pid))
            except OSError as exc:
                raise OSError(exc.errno, exc.strerror, c) from None  # filename: the controller that refused

    def join(self) -> None:
        """In the sandbox's first process, before exec (``preexec_fn``): drop any real-time policy, enter the
        cgroups, pin the CPU.

        A forked child inherits its parent's scheduling policy. A grader left at SCHED_FIFO/RR (chapter 1's
        tools run as root in the same process, a course run under ``chrt``) would hand it to the submission,
        and a fresh v1 ``cpu`` cgroup has no real-time budget (``cpu.rt_runtime_us`` = 0): the kernel refuses
        a real-time task there with EINVAL, so every submission failed to start ("Exception occurred in
        preexec_fn"). A submission starts at SCHED_OTHER; asking for more inside is the student's code's
        business (refused there, reported, carried on: chapter 1's unprivileged path).
        """
        _drop_realtime()
        self._enter(os.getpid())
        if self.cpus and self.mode == "polling" and hasattr(os, "sched_setaffinity"):
            os.sched_setaffinity(0, set(self.cpus))

    def usage(self) -> Usage:
        u = Usage()
        if self.mode == "cgroup-v1" and self.dirs:
            mem, pids = self.dirs["memory"], self.dirs["pids"]
            try:
                u.peak_memory_mb = round(int((mem / "memory.max_usage_in_bytes").read_text()) / 2**20, 1)
                for line in (mem / "memory.oom_control").read_text().splitlines():
                    if line.startswith("oom_kill "):
                        u.oom_kills = int(line.split()[1])
                for line in (pids / "pids.events").read_text().splitlines():
                    if line.startswith("max "):
                        u.refused_forks = int(line.split()[1])
                peak = pids / "pids.peak"
                if peak.exists():
                    u.peak_processes = int(peak.read_text())
            except (OSError, ValueError):
                pass
        elif self.mode == "cgroup-v2-delegated" and self.unit:
            path = _v2_unit_path(self.unit)
            if path is not None:
                try:
                    events = dict(line.split() for line in (path / "memory.events").read_text().splitlines())
                    u.oom_kills = int(events.get("oom_kill", 0))
                    u.refused_forks = int(dict(line.split() for line in
                                               (path / "pids.events").read_text().splitlines()).get("max", 0))
                    peak = path / "memory.peak"
                    if peak.exists():
                        u.peak_memory_mb = round(int(peak.read_text()) / 2**20, 1)
                except (OSError, ValueError):
                    pass
        return u

    def describe(self) -> str:
        cpus = ",".join(map(str, self.cpus)) if self.cpus else ""
        if self.mode == "polling":
            return (f"polling: {self.memory_mb} MB of resident memory (shared memory outside the sandbox's /dev/shm "
                    f"not counted), processes polled" + (f", CPU {cpus} by affinity (not enforced)" if cpus else "")
                    + (f"; {self.fallback}" if self.fallback else ""))
        share = len(self.cpus) if self.cpus else 1
        return (f"{self.mode}: {self.memory_mb} MB incl. shared memory, {self.max_processes} tasks, {share} CPU(s)"
                + (f": CPU {cpus} to itself" if cpus else ""))


def _drop_realtime() -> None:
    """SCHED_OTHER for the calling thread (lowering one's own policy is always allowed)."""
    if hasattr(os, "sched_setscheduler"):
        with contextlib.suppress(OSError):
            os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0))


def _v2_unit_path(unit: str) -> Path | None:
    try:
        out = subprocess.run(["systemctl", "--user", "show", "-p", "ControlGroup", "--value", f"{unit}.scope"],
                             capture_output=True, text=True, timeout=10).stdout.strip()
    except (OSError, subprocess.TimeoutExpired):
        return None
    return CGROUP_ROOT / out.lstrip("/") if out else None


# -- the private, size-limited work folder ------------------------------------------------------

def mount_quota(folder: Path, megabytes: int) -> bool:
    """Mount a tmpfs of ``megabytes`` on ``folder`` (root only); False where that cannot be done."""
    if os.geteuid() != 0 or shutil.which("mount") is None:
        return False
    proc = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={int(megabytes)}m,mode=0700,nosuid,nodev",
                           "robocourse-submission", str(folder)], capture_output=True, timeout=20)
    return proc.returncode == 0


def unmount(folder: Path) -> None:
    subprocess.run(["umount", "-l", str(folder)], capture_output=True, timeout=20)


def folder_bytes(folder: Path, limit_entries: int = 100_000) -> int:
    """Bytes used under ``folder`` (the polled quota without root); stops counting at ``limit_entries``."""
    total, seen = 0, 0
    stack = [str(folder)]
    while stack and seen < limit_entries:
        try:
            with os.scandir(stack.pop()) as it:
                for entry in it:
                    seen += 1
                    try:
                        if entry.is_dir(follow_symlinks=False):
                            stack.append(entry.path)
                        else:
                            total += entry.stat(follow_symlinks=False).st_blocks * 512
                    except OSError:
                        continue
        except OSError:
            continue
    return total
