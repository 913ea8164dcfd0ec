"""Run one submission in a throwaway sandbox: bubblewrap where present, a guarded process otherwise.

Counterpart of otter-grader's per-submission container and Gradescope's throwaway autograder
container, without Docker. With ``bwrap`` (Debian package ``bubblewrap``) each run gets:

- its own mount namespace showing only read-only views of /usr, the Python installation,
  the virtual environment and the robocourse library, plus one private read-write folder
  (``/submission``) holding a copy of this submission alone: no solutions/, no other
  submissions, no instructor check folder, no output folder;
- no network (``--unshare-net``), its own PID namespace (``--unshare-pid``; the grader's pid
  and every other process are invisible, and all children die with the namespace's init),
  ``--die-with-parent``, ``--new-session``, all capabilities dropped, uid 65534;
- a clean environment built from an allow-list (never the grader's secrets).

Limits enforced by the grader, whatever the code does: wall time (the whole namespace is
killed, never a wait on a pipe); memory, processes and CPU per submission by
:mod:`resources` (a cgroup per submission where the grader may create one: shared memory and
memfd count; a CPU slot of its own when no more submissions run at once than there are CPUs;
otherwise the resident memory and process count are polled every 0.1 s, with RLIMIT_AS per
process as a hard backstop); a private, size-limited work folder (a tmpfs where the grader is
root, else its size polled) and a private /dev/shm tmpfs; output bytes (stdout/stderr go to a
file capped by RLIMIT_FSIZE and read back through a bounded reader).

Without bwrap (``mode="process"``) the fallback is a fresh session/process group killed whole,
the same rlimits, a private copy and the clean environment, but the code can see the file
system and other processes: the grader marks such rows "NOT SANDBOXED".
"""

from __future__ import annotations

import contextlib
import os
import resource
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import uuid
from dataclasses import dataclass
from pathlib import Path

import psutil

from . import resources
from .checks import GRADING_ENV

#: Environment variables a submission may see (everything else, e.g. tokens, is dropped).
ENV_ALLOW = ("LANG", "LC_ALL", "TZ")
SANDBOX_ROOT = "/submission"
POLL_S = 0.1


@dataclass(frozen=True)
class Limits:
    """Per-submission limits (otter: timeout; nbgrader: max output size)."""

    time_s: float = 300.0
    memory_mb: int = 4096
    max_processes: int = 64
    output_bytes: int = 2_000_000  # bytes of stdout/stderr kept for the instructor's log
    file_bytes: int = 64 * 1024 * 1024  # the largest file the submission may write
    work_mb: int = 1024  # the submission's work folder (its /submission and /tmp), in all
    shm_mb: int = 256  # its private /dev/shm
    threads_per_process: int = 16  # tasks (threads) the pids cgroup allows per allowed process

    def __post_init__(self):
        if not self.time_s > 0:
            raise ValueError(f"time limit must be > 0 s, got {self.time_s!r}; e.g. --time-limit 300")
        if self.memory_mb < 256:
            raise ValueError(f"memory limit must be >= 256 MB, got {self.memory_mb!r}; e.g. --memory 4096")
        if self.max_processes < 4:
            raise ValueError(f"process limit must be >= 4, got {self.max_processes!r}")
        if self.work_mb < 64 or self.shm_mb < 16:
            raise ValueError(f"the work folder needs >= 64 MB and /dev/shm >= 16 MB, got {self.work_mb!r} and "
                             f"{self.shm_mb!r}")


@dataclass
class Outcome:
    returncode: int | None
    stopped: str  # "" or why the grader killed it ("time", "memory", "processes")
    sandbox: str  # "bwrap" or "process"
    seconds: float
    peak_memory_mb: float
    peak_processes: int
    log: str  # the first output_bytes of stdout+stderr (bounded)
    log_truncated: bool
    leftover: int  # processes still alive after the kill (should be 0)
    resources: str = ""  # how the limits were enforced (resources.Box.describe)
    cpus: tuple[int, ...] | None = None  # the CPU slot the submission had to itself, if any


def bwrap_path() -> str | None:
    return shutil.which("bwrap")


_BWRAP_OK: dict[str, bool] = {}


def bwrap_works() -> bool:
    """bwrap is installed and can create the namespaces we need on this machine."""
    path = bwrap_path()
    if path is None:
        return False
    if path not in _BWRAP_OK:
        try:
            proc = subprocess.run([path, "--unshare-all", "--die-with-parent", "--unshare-user", "--uid", "65534",
                                   "--ro-bind", "/", "/", "--proc", "/proc", "--dev", "/dev", "true"],
                                  capture_output=True, timeout=20)
            _BWRAP_OK[path] = proc.returncode == 0
        except (OSError, subprocess.TimeoutExpired):
            _BWRAP_OK[path] = False
    return _BWRAP_OK[path]


def choose_mode(mode: str) -> str:
    """'auto' -> 'bwrap' if it works here, else 'process'; 'bwrap' is an error where it cannot work."""
    if mode not in ("auto", "bwrap", "process"):
        raise ValueError(f"sandbox mode must be auto, bwrap or process, got {mode!r}")
    if mode == "auto":
        return "bwrap" if bwrap_works() else "process"
    if mode == "bwrap" and not bwrap_works():
        raise ValueError("--sandbox bwrap: bubblewrap is not installed or cannot create namespaces here; "
                         "install it (apt-get install bubblewrap) or pass --sandbox process (not isolated)")
    return mode


def clean_env(home: str, marker: str) -> dict:
    env = {k: os.environ[k] for k in ENV_ALLOW if k in os.environ}
    env.update({
        "PATH": f"{Path(sys.executable).parent}:/usr/local/bin:/usr/bin:/bin",
        "HOME": home, "TMPDIR": f"{home}/tmp", "USER": "student", "LOGNAME": "student",
        "MPLBACKEND": "Agg", "MPLCONFIGDIR": f"{home}/tmp", "IPYTHONDIR": f"{home}/tmp/ipython",
        "ROBOCOURSE_TEST": "1", GRADING_ENV: "1", "PYTHONDONTWRITEBYTECODE": "1",
        "PYTHONHASHSEED": "0", "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1",
        "ROBOCOURSE_SANDBOX_ID": marker,
    })
    return env


def _read_only_paths() -> list[str]:
    """The Python installation, the venv and the directory the robocourse package lives in."""
    import robocourse

    paths = {sys.base_prefix, sys.prefix, str(Path(robocourse.__file__).resolve().parents[1]),
             str(Path(sys.executable).resolve().parents[1])}
    out: list[str] = []
    for p in sorted(paths, key=len):
        if p == "/" or p == "/usr" or p.startswith("/usr/"):
            continue  # already bound read-only
        if not any(p.startswith(q + "/") for q in out):
            out.append(p)
    return out


def compile_library(skip_modules=()) -> str:
    """Bytecode for the course library beside its sources (``__pycache__``), compiled here, outside any
    sandbox, once per grading run: a sandbox reads the library read-only and cannot cache what it
    compiles, so without it every submission's interpreter compiles the library again (measured:
    sandbox start and library import 4.7 s median from source, 3.5 s from bytecode, 10 runs each at load
    average 22 on 2 CPUs). Files already compiled are only checked (their timestamps). The judge-side
    ``skip_modules`` are left out (hidden in the sandbox, bytecode too). ``ROBOCOURSE_COMPILE_LIBRARY=0``
    turns it off (benchmarks/grading_throughput.py compares). Returns what happened."""
    import compileall
    import importlib.util
    import re

    import robocourse

    if os.environ.get("ROBOCOURSE_COMPILE_LIBRARY", "1") == "0":
        return "not compiled: ROBOCOURSE_COMPILE_LIBRARY=0"
    root = Path(robocourse.__file__).resolve().parent
    if not os.access(root, os.W_OK):
        return f"not compiled: {root} is read-only (an installed package carries its bytecode)"
    skip = []
    for name in skip_modules:
        with contextlib.suppress(ImportError, ValueError, AttributeError):
            origin = importlib.util.find_spec(name).origin
            if origin:
                skip.append(re.escape(str(Path(origin).resolve())) + "$")
    rx = re.compile("|".join(skip)) if skip else None
    with open(os.devnull, "w") as quiet, contextlib.redirect_stdout(quiet):
        ok = compileall.compile_dir(str(root), quiet=2, rx=rx, workers=1)
    return f"compiled {root}" if ok else f"compiled {root} (some files failed; those are compiled in each sandbox)"


def hidden_files(modules) -> list[str]:
    """The source and bytecode files of ``modules`` (judge-side modules), to hide in a sandbox."""
    import importlib.util

    out = []
    for name in modules:
        try:
            spec = importlib.util.find_spec(name)
        except (ImportError, ValueError):
            continue
        origin = getattr(spec, "origin", None) if spec else None
        if not origin or not origin.endswith(".py") or not os.path.isfile(origin):
            continue
        out.append(origin)
        cache = Path(origin).parent / "__pycache__"
        if cache.is_dir():
            out += sorted(str(p) for p in cache.glob(f"{Path(origin).stem}.*.pyc"))
    return out


def bwrap_command(workdir: Path, argv: list[str], env: dict, read_only: list[str] | None = None,
                  hide: list[str] = (), shm_mb: int = 256) -> list[str]:
    """The bwrap argv: /usr, the Python installation and ``read_only`` (default: the venv and the
    library) read-only, ``workdir`` at /submission, and /tmp the submission's own ``tmp``.
    Each file in ``hide`` (the judge modules and their bytecode) reads as empty inside.

    /tmp is bound before the read-only paths, so a course that lives under /tmp (a clone in
    /tmp, a venv in /tmp) still gets its read-only binds on top of the submission's /tmp (a
    symlink at /tmp could not be made once a bind had created the directory)."""
    cmd = [bwrap_path(), "--unshare-all", "--die-with-parent", "--new-session", "--cap-drop", "ALL",
           "--unshare-user", "--uid", "65534", "--gid", "65534", "--ro-bind", "/usr", "/usr"]
    for top in ("bin", "lib", "lib64", "lib32", "sbin"):
        p = Path("/") / top
        if p.is_symlink():
            cmd += ["--symlink", os.readlink(p), f"/{top}"]
        elif p.is_dir():
            cmd += ["--ro-bind", str(p), f"/{top}"]
    for etc in ("ld.so.cache", "ld.so.conf", "ld.so.conf.d", "localtime", "fonts", "alternatives", "passwd",
                "group", "nsswitch.conf", "matplotlibrc"):
        cmd += ["--ro-bind-try", f"/etc/{etc}", f"/etc/{etc}"]
    cmd += ["--bind", str(workdir / "tmp"), "/tmp"]
    for p in _read_only_paths() if read_only is None else read_only:
        cmd += ["--ro-bind", p, p]
    for path in hide:
        cmd += ["--ro-bind", "/dev/null", path]
    cmd += ["--proc", "/proc", "--dev", "/dev", "--perms", "1777", "--size", str(shm_mb * 2**20), "--tmpfs", "/dev/shm",
            "--bind", str(workdir), SANDBOX_ROOT,
            "--chdir", SANDBOX_ROOT, "--clearenv"]
    for k, v in env.items():
        cmd += ["--setenv", k, v]
    return cmd + ["--"] + argv


def _limits(limits: Limits, box=None):
    def apply():
        if box is not None:
            box.join()
        mem = limits.memory_mb * 1024 * 1024
        resource.setrlimit(resource.RLIMIT_AS, (mem, mem))
        resource.setrlimit(resource.RLIMIT_FSIZE, (limits.file_bytes, limits.file_bytes))
        resource.setrlimit(resource.RLIMIT_CORE, (0, 0))
        soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
        resource.setrlimit(resource.RLIMIT_NOFILE, (min(1024, hard), min(1024, hard)))
    return apply


def _tree(pid: int) -> list[psutil.Process]:
    try:
        root = psutil.Process(pid)
        return [root] + root.children(recursive=True)
    except psutil.Error:
        return []


def _marked(marker: str) -> list[psutil.Process]:
    """Processes that still carry this run's marker in their environment (fallback mode)."""
    found = []
    for p in psutil.process_iter():
        try:
            if p.pid != os.getpid() and p.environ().get("ROBOCOURSE_SANDBOX_ID") == marker:
                found.append(p)
        except psutil.Error:
            continue
    return found


def _alive(p: psutil.Process) -> bool:
    try:
        return p.is_running() and p.status() != psutil.STATUS_ZOMBIE
    except psutil.Error:
        return False


def _kill(procs: list[psutil.Process]) -> None:
    procs = [p for p in procs if _alive(p)]  # waiting on a dead non-child costs psutil seconds
    for p in procs:
        try:
            p.kill()
        except psutil.Error:
            pass
    psutil.wait_procs(procs, timeout=3)


@contextlib.contextmanager
def workdir(parent: Path, limits: Limits):
    """A fresh private folder for one submission, size-limited: a tmpfs of ``limits.work_mb``
    mounted on it where the grader may mount (root); elsewhere :func:`run` polls its size."""
    folder = Path(tempfile.mkdtemp(prefix="sub-", dir=parent))
    mounted = resources.mount_quota(folder, limits.work_mb)
    try:
        os.chmod(folder, 0o700)
        yield folder
    finally:
        if mounted:
            resources.unmount(folder)
        shutil.rmtree(folder, ignore_errors=True)


def run(argv: list[str], workdir: Path, limits: Limits, mode: str = "auto", hide: list[str] = (),
        cpus: tuple[int, ...] | None = None) -> Outcome:
    """Run ``argv`` (a Python command) on ``workdir`` under ``limits``; kill everything at the end.

    ``hide``: files that read as empty inside the sandbox (bwrap only; see :func:`hidden_files`).
    ``cpus``: CPUs the submission has to itself (pinned by its cpuset cgroup where there is one).
    Memory, processes and CPU are limited per submission by :mod:`resources` (cgroups where the
    grader may create them); the work folder's size by its tmpfs or, without one, by polling.
    """
    mode = choose_mode(mode)
    marker = uuid.uuid4().hex
    (workdir / "tmp").mkdir(exist_ok=True)
    log_path = workdir.parent / f"{workdir.name}.log"
    quota_polled = not os.path.ismount(workdir)
    box = resources.Box(limits.memory_mb, limits.max_processes * limits.threads_per_process, cpus)
    if mode == "bwrap":
        env = clean_env(SANDBOX_ROOT, marker)
        cmd, cwd = bwrap_command(workdir, argv, env, hide=list(hide), shm_mb=limits.shm_mb), "/"
        env_outer = {"PATH": "/usr/bin:/bin"}
    else:
        env_outer = clean_env(str(workdir), marker)
        cmd, cwd = argv, str(workdir)
    start = time.monotonic()
    peak_mem = 0.0
    peak_procs = 0
    stopped = ""
    seen: dict[int, psutil.Process] = {}
    with box, open(log_path, "wb") as log:
        proc = subprocess.Popen(box.wrap(cmd), cwd=cwd, env=env_outer, stdin=subprocess.DEVNULL, stdout=log,
                                stderr=log, start_new_session=True, preexec_fn=_limits(limits, box), close_fds=True)
        polls = 0
        try:
            while True:
                try:
                    proc.wait(timeout=POLL_S)
                    break
                except subprocess.TimeoutExpired:
                    pass
                polls += 1
                procs = _tree(proc.pid)
                for p in procs:
                    seen.setdefault(p.pid, p)
                rss = 0
                for p in procs:
                    try:
                        rss += p.memory_info().rss
                    except psutil.Error:
                        pass
                peak_mem = max(peak_mem, rss / 2**20)
                peak_procs = max(peak_procs, len(procs) - (1 if mode == "bwrap" else 0))
                used = box.usage() if box.mode != "polling" else None
                if time.monotonic() - start > limits.time_s:
                    stopped = "time"
                elif used is not None and used.oom_kills:
                    stopped = "memory"
                elif used is None and rss > limits.memory_mb * 2**20:
                    stopped = "memory"
                elif len(procs) > limits.max_processes + 2 or (used is not None and used.refused_forks):
                    stopped = "processes"
                elif quota_polled and polls % 10 == 0 and \
                        resources.folder_bytes(workdir) > limits.work_mb * 2**20:
                    stopped = "disk"
                if stopped:
                    break
        finally:
            # kill the whole group/namespace: in bwrap mode the namespace's init dies with the
            # outer bwrap (--die-with-parent) and takes every process inside with it
            try:
                os.killpg(proc.pid, signal.SIGKILL)
            except (ProcessLookupError, PermissionError):
                pass
            _kill(_tree(proc.pid) + list(seen.values()))
            try:
                proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait(timeout=10)
            if mode == "process":
                _kill(_marked(marker))
            used = box.usage()
            if not stopped and used.oom_kills:
                stopped = "memory"  # the kernel's OOM killer ended the run between two polls
            if not stopped and _folder_full(workdir, limits, quota_polled):
                stopped = "disk"
            if used.peak_memory_mb is not None:
                peak_mem = max(peak_mem, used.peak_memory_mb)
            described = box.describe()
    leftover = [p for p in seen.values() if _alive(p)]
    leftover += [] if mode == "bwrap" else _marked(marker)
    text, truncated = read_bounded(log_path, limits.output_bytes)
    log_path.unlink(missing_ok=True)
    return Outcome(proc.returncode, stopped, mode, time.monotonic() - start, round(peak_mem, 1), peak_procs,
                   text, truncated, len(leftover), described, cpus)


def _folder_full(workdir: Path, limits: Limits, polled: bool) -> bool:
    """The submission filled its folder (its tmpfs has under 1 MB left, or it is over the polled quota)."""
    if polled:
        return resources.folder_bytes(workdir) > limits.work_mb * 2**20
    try:
        st = os.statvfs(workdir)
    except OSError:
        return False
    return st.f_bavail * st.f_frsize < 2**20


def read_bounded(path: Path, limit: int) -> tuple[str, bool]:
    """At most ``limit`` bytes of a file the sandbox wrote to (never a symlink, never unbounded)."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NOFOLLOW)
    except OSError:
        return "", False
    try:
        st = os.fstat(fd)
        if not (st.st_mode & 0o170000 == 0o100000):  # a regular file only
            return "", False
        data = os.read(fd, limit + 1)
    finally:
        os.close(fd)
    return data[:limit].decode("utf-8", errors="replace"), len(data) > limit
