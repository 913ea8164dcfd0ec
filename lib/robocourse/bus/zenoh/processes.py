"""Run part of a graph in a child process, from a notebook: ``start_child(fn, connect=...)``.

The counterpart of starting a node with ``ros2 run`` in a second terminal (or a launch file's
separate process): the child is a fresh Python interpreter with its own
``Context(transport="zenoh")``, so it shares nothing with the notebook but the wire. ``fn``
is sent as *source* (like ``multiprocessing``'s "spawn" start method, which pickles a function
by name): everything it uses must be imported inside it. A ``"module:function"`` string runs
an importable function instead.

``fn(ctx, **args)`` creates its nodes on ``ctx`` (and may start threads); the child then spins
every node of ``ctx`` for ``duration`` seconds of wall time and stops by itself. If ``fn``
returns a callable, its (JSON-able) return value is sent back at the end: ``child.result()``.
With ``with_context=False`` the child opens no robocourse context and calls
``fn(duration=..., **args)``, which runs its own loop (a plain zenoh peer, for instance).

The child also exits when the notebook goes away (its stdin closes), and every child still
running when the notebook's interpreter exits is killed: no orphans.
"""

from __future__ import annotations

import atexit
import contextlib
import inspect
import json
import os
import select
import socket
import subprocess
import sys
import textwrap
import threading
import time
import traceback

_CHILDREN: list[Child] = []


def free_endpoint(host: str = "127.0.0.1") -> str:
    """A zenoh TCP locator on a port that is free right now, e.g. ``tcp/127.0.0.1:40123``."""
    with socket.socket() as s:
        s.bind((host, 0))
        return f"tcp/{host}:{s.getsockname()[1]}"


def free_router(host: str = "127.0.0.1", attempts: int = 5):
    """``(router session, endpoint)``: a zenoh router (``rmw_zenohd``) listening on a port of its own.

    The port is free when :func:`free_endpoint` picks it, but any process may take it before the
    router binds it (every zenoh peer listens on a port 0 of its own): then another is picked.
    """
    if isinstance(attempts, bool) or not isinstance(attempts, int) or attempts < 1:
        raise ValueError(f"free_router(attempts={attempts!r}): give a whole number of tries, at least 1, e.g. 5")
    from .transport import router

    for _ in range(attempts - 1):
        ep = free_endpoint(host)
        with contextlib.suppress(OSError):
            return router([ep]), ep
    ep = free_endpoint(host)
    return router([ep]), ep           # the last try's error, if any, is the caller's


def _spec(target, args, duration, with_context, domain_id, connect):
    if isinstance(target, str):
        if target.count(":") != 1:
            raise ValueError(f"target {target!r} must be 'module:function' (e.g. "
                             f"'robocourse.bus.zenoh.peer:main') or a function")
        where = {"import": target}
    elif inspect.isfunction(target):
        if target.__name__ == "<lambda>":
            raise ValueError("a lambda cannot be sent to a child process by source; define it "
                             "with def at the top level of a cell")
        try:
            source = textwrap.dedent(inspect.getsource(target))
        except (OSError, TypeError) as exc:
            raise ValueError(f"the source of {target.__name__!r} is not available ({exc}); define it "
                             f"with def in a notebook cell or a module") from None
        where = {"source": source, "name": target.__name__}
    else:
        raise TypeError(f"target {target!r} must be a function or a 'module:function' string")
    if not (isinstance(duration, (int, float)) and not isinstance(duration, bool) and 0 < duration < 3600):
        raise ValueError(f"duration={duration!r} must be seconds in (0, 3600): the child stops by "
                         f"itself after it, e.g. duration=5.0")
    try:
        json.dumps(args or {})
    except TypeError as exc:
        raise TypeError(f"args must be JSON-able plain data (numbers, strings, lists, dicts): {exc}") from None
    return {**where, "args": args or {}, "duration": float(duration), "with_context": bool(with_context),
            "domain_id": domain_id, "connect": list(connect)}


class Child:
    """A running child process (``start_child`` makes it). ``kill()`` is a crash (SIGKILL, no
    cleanup); ``close()`` asks it to stop and waits; ``result()`` waits for its report."""

    def __init__(self, spec: dict, name: str, ready_timeout: float):
        self.name = name
        self.proc = subprocess.Popen([sys.executable, "-m", "robocourse.bus.zenoh.processes"], stdin=subprocess.PIPE,
                                     stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                     env={**os.environ, "PYTHONUNBUFFERED": "1"})
        _CHILDREN.append(self)
        self.stderr_lines: list[str] = []
        threading.Thread(target=self._drain, daemon=True).start()
        self.proc.stdin.write(json.dumps(spec) + "\n")
        self.proc.stdin.flush()
        self._result = None
        self._has_result = False
        line = self._readline(ready_timeout)
        if not line.startswith("READY "):
            self.kill()
            self.close()
            if line.startswith("ERROR "):
                line = json.loads(line[6:])
            raise RuntimeError(f"child {name!r} did not start: {line.strip() or 'no output'}\n"
                               + "".join(self.stderr_lines[-20:]))
        ready = json.loads(line[6:])
        self.zid: str = ready["zid"]
        self.started = time.monotonic()

    @property
    def pid(self) -> int:
        return self.proc.pid

    def _drain(self):
        for line in self.proc.stderr:
            self.stderr_lines.append(line)
            del self.stderr_lines[:-200]

    def _readline(self, timeout):
        end = time.monotonic() + timeout
        while True:
            left = end - time.monotonic()
            if left <= 0:
                return ""
            r, _, _ = select.select([self.proc.stdout], [], [], left)
            if r:
                return self.proc.stdout.readline()

    def alive(self) -> bool:
        return self.proc.poll() is None

    def result(self, timeout: float = 30.0):
        """Wait for the child's report (what ``fn``'s returned callable gave); None if it had none."""
        end = time.monotonic() + timeout
        while not self._has_result:
            line = self._readline(max(0.0, end - time.monotonic()))
            if not line:
                state = "exited" if not self.alive() else f"still running after {timeout} s"
                raise RuntimeError(f"child {self.name!r} sent no result ({state})\n"
                                   + "".join(self.stderr_lines[-20:]))
            if line.startswith("RESULT "):
                self._result, self._has_result = json.loads(line[7:]), True
            elif line.startswith("ERROR "):
                raise RuntimeError(f"child {self.name!r} failed: {json.loads(line[6:])}")
        self.proc.wait(timeout=max(1.0, end - time.monotonic()))
        return self._result

    def kill(self) -> None:
        """SIGKILL: what a crash looks like (no token undeclared, no goodbye)."""
        if self.alive():
            self.proc.kill()
        self.proc.wait(timeout=10)

    def close(self, timeout: float = 5.0) -> None:
        """Close its stdin (it exits at once), wait, kill if it does not."""
        if self.alive():
            try:
                self.proc.stdin.close()
            except OSError:
                pass
            try:
                self.proc.wait(timeout=timeout)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(timeout=10)
        for f in (self.proc.stdin, self.proc.stdout):
            try:
                f.close()
            except OSError:
                pass
        if self in _CHILDREN:
            _CHILDREN.remove(self)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __repr__(self):
        return f"<Child {self.name!r} pid={self.pid} {'running' if self.alive() else 'exited'}>"


def start_child(target, *, connect, duration: float = 5.0, args: dict | None = None, name: str | None = None,
                with_context: bool = True, domain_id: int = 0, ready_timeout: float = 60.0) -> Child:
    """Start ``target`` in a new Python process on the zenoh graph at ``connect`` (a list of
    locators); return once its nodes exist (it printed READY). See the module docstring."""
    if isinstance(connect, str):
        raise ValueError(f"connect={connect!r} must be a list of locators, e.g. ['tcp/127.0.0.1:7447']")
    if isinstance(ready_timeout, bool) or not isinstance(ready_timeout, (int, float)) or not ready_timeout > 0:
        raise ValueError(f"ready_timeout={ready_timeout!r} must be positive seconds (how long the child may take "
                         f"to start), e.g. ready_timeout=60")
    spec = _spec(target, args, duration, with_context, domain_id, connect)
    return Child(spec, name or spec.get("name") or spec.get("import"), ready_timeout)


def close_all() -> None:
    """Stop every child this process started (also run at interpreter exit)."""
    for c in list(_CHILDREN):
        c.close(timeout=2.0)


atexit.register(close_all)


# ---------------------------------------------------------------- the child's side
def exit_with_parent():
    """Stop when our stdin closes (the parent died or closed the pipe): no orphans."""
    try:
        sys.stdin.read()
    except Exception:  # noqa: BLE001
        pass
    os._exit(0)


def _resolve(spec):
    if "import" in spec:
        import importlib

        mod, fn = spec["import"].split(":")
        return getattr(importlib.import_module(mod), fn)
    ns = {"__name__": "__child__"}
    exec(compile(spec["source"], f"<child {spec['name']}>", "exec"), ns)  # noqa: S102 - the parent's own code
    return ns[spec["name"]]


def _main() -> int:
    spec = json.loads(sys.stdin.readline())
    threading.Thread(target=exit_with_parent, daemon=True).start()
    out = sys.stdout
    try:
        fn = _resolve(spec)
        if not spec["with_context"]:
            print("READY " + json.dumps({"zid": ""}), file=out, flush=True)
            report = fn(duration=spec["duration"], **spec["args"])
            print("RESULT " + json.dumps(report), file=out, flush=True)
            return 0
        from robocourse.bus.context import Context
        from robocourse.bus.executors import SingleThreadedExecutor

        ctx = Context(transport="zenoh", domain_id=spec["domain_id"], connect=spec["connect"])
        report = fn(ctx, **spec["args"])
        ex = SingleThreadedExecutor(context=ctx)
        for node in list(ctx.nodes):
            ex.add_node(node)
        print("READY " + json.dumps({"zid": ctx.transport.zid}), file=out, flush=True)
        end = time.monotonic() + spec["duration"]
        while ctx.ok() and time.monotonic() < end:
            ex.spin_once(timeout_sec=min(0.05, max(0.0, end - time.monotonic())))
        data = report() if callable(report) else None
        print("RESULT " + json.dumps(data), file=out, flush=True)
        ctx.try_shutdown()
        return 0
    except BaseException as exc:  # noqa: BLE001 - reported to the parent, then exit 1
        print("ERROR " + json.dumps(f"{type(exc).__name__}: {exc}\n{traceback.format_exc()}"), file=out,
              flush=True)
        return 1


if __name__ == "__main__":
    sys.exit(_main())
