"""Inside the sandbox: execute one notebook and gather the probes' data (``python -m``).

Started by ``grader.py`` through ``sandbox.run`` with the sandbox folder as its only argument.
It reads the grader's request (which checks, their inputs, their probes), deletes it, runs the
notebook's code cells in an IPython shell in this process (magics and display work as in
Jupyter; no kernel, no sockets), and right after the cell that calls ``check("name", ...)``
(or at the end, for a deleted check cell or an instructor's hidden check) runs that check's
probe on the notebook's globals. Each probe's data is appended to ``probes.jsonl`` at once, so
a notebook that crashes later keeps what was gathered before. Nothing here decides a grade:
everything this process writes is treated by the grader as the student's untrusted output.

Each cell has a time limit (SIGALRM interrupts it; execution goes on with the next cell);
``sys.exit`` and exceptions are recorded as cell errors; printed output is counted, not kept.
"""

from __future__ import annotations

import io
import json
import os
import signal
import sys
import time
from pathlib import Path

PYTHON_KERNEL_NAMES = ("robocourse", "python3", "python", "python2")
REQUEST, PROBES, STATUS, NOTEBOOK = "request.json", "probes.jsonl", "status.json", "submission.ipynb"


class CellTimeout(BaseException):
    """A cell ran past the per-cell time limit (BaseException: a bare ``except Exception`` cannot eat it)."""


class _CountingSink(io.TextIOBase):
    """sys.stdout/stderr replacement: counts characters, keeps none (output is not graded)."""

    def __init__(self):
        self.chars = 0

    def write(self, s):
        self.chars += len(s)
        return len(s)

    def writable(self):
        return True

    def isatty(self):
        return False


def kernel_problem(nb: dict) -> str:
    """'' when the notebook is Python; else why it cannot be graded."""
    meta = nb.get("metadata", {}) or {}
    spec = meta.get("kernelspec", {}) or {}
    name = str(spec.get("name", ""))
    language = str(spec.get("language") or (meta.get("language_info", {}) or {}).get("name") or "python").lower()
    if language == "python" or name in PYTHON_KERNEL_NAMES or name.startswith("python"):
        return ""
    return (f"the notebook asks for kernel {name or '?'!r} (language {language!r}), which cannot run the exercise; "
            "open it in JupyterLab, pick 'Python (robocourse)' and save")


def _load_probe(spec: dict):
    from .checks import resolve
    from .probes import call, calls, plain

    if "ref" in spec:
        return resolve(spec["ref"])
    namespace = {"call": call, "calls": calls, "plain": plain, "__name__": "robocourse_probe"}
    exec(compile(spec["source"], "<instructor probe>", "exec"), namespace)  # the instructor's probe text
    return namespace[spec["func"]]


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    folder = Path(argv[0] if argv else ".")
    status = {"started": True, "finished": False, "reason": "", "errors": [], "cells": 0, "last_cell": -1,
              "output_chars": 0}

    def write_status():
        (folder / STATUS).write_text(json.dumps(status))

    # a write past the file-size limit fails with EFBIG instead of killing the run
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    request = json.loads((folder / REQUEST).read_text())
    (folder / REQUEST).unlink()
    cell_timeout = float(request.get("cell_timeout", 60))
    try:
        # jsonschema (under nbformat) builds rfc3987-syntax's IRI grammar when imported: ~1.2 s
        # of CPU in every graded submission. The notebook schema uses no "format" keyword, so
        # nothing checks an IRI here: skip building the parser (validation is unchanged).
        sys.modules.setdefault("rfc3987_syntax", None)
        import nbformat

        nb = nbformat.reads((folder / NOTEBOOK).read_text(encoding="utf-8"), as_version=4)
        nbformat.validate(nb)
        cells = list(nb.cells)
    except Exception as exc:  # invalid JSON, wrong schema
        status["reason"] = (f"the file is not a valid notebook ({type(exc).__name__}: {str(exc)[:200]}); "
                            "re-download it or save it again from JupyterLab")
        status["finished"] = True
        write_status()
        return 0
    problem = kernel_problem(nb)
    if problem:
        status["reason"], status["finished"] = problem, True
        write_status()
        return 0

    from .checks import Check, run_probe
    from .exercises import CHECK_CALL

    pending = {c["name"]: c for c in request["checks"]}
    after_cell: dict[int, list[str]] = {}
    for index, cell in enumerate(cells):
        if cell.get("cell_type") == "code":
            for name in CHECK_CALL.findall(cell.get("source", "")):
                if name in pending and not any(name in v for v in after_cell.values()):
                    after_cell.setdefault(index, []).append(name)

    sink = _CountingSink()
    sys.stdout = sys.stderr = sink
    from IPython.core.interactiveshell import InteractiveShell

    class Shell(InteractiveShell):
        def enable_gui(self, gui=None):  # %matplotlib inline without a GUI event loop
            pass

    shell = Shell.instance(colors="NoColor")
    probes_out = open(folder / PROBES, "a", encoding="utf-8")

    def probe(name):
        spec = pending.pop(name, None)
        if spec is None:
            return
        missing = [u for u in spec["uses"] if u not in shell.user_ns]
        if missing:
            data = {"outputs": None, "reason": "missing", "delegated": [], "seconds": 0.0,
                    "error": f"the notebook defines no {', '.join(missing)}: keep the names the exercise asks for"}
        else:
            chk = Check(name, None, _load_probe(spec["probe"]), tuple(spec["uses"]), None, 1.0,
                        float(spec["time_limit"]), "", tuple(spec.get("references", ())))
            data = run_probe(chk, spec["inputs"], [shell.user_ns[u] for u in spec["uses"]])
        try:
            line = json.dumps({"name": name, **data})
        except (TypeError, ValueError) as exc:
            line = json.dumps({"name": name, "outputs": None, "reason": "raised", "delegated": [],
                               "error": f"the output could not be sent to the grader ({exc})"})
        probes_out.write(line + "\n")
        probes_out.flush()

    def on_alarm(signum, frame):
        raise CellTimeout(f"interrupted after the {cell_timeout:g} s cell time limit")

    signal.signal(signal.SIGALRM, on_alarm)
    start = time.monotonic()
    for index, cell in enumerate(cells):
        if cell.get("cell_type") != "code":
            continue
        status["last_cell"] = index
        write_status()
        signal.setitimer(signal.ITIMER_REAL, cell_timeout)
        try:
            result = shell.run_cell(cell.get("source", ""), store_history=False, silent=False)
        except CellTimeout as exc:  # fired outside the user's code, between IPython's steps
            result = None
            status["errors"].append(f"cell {index}: CellTimeout: {exc}")
        finally:
            signal.setitimer(signal.ITIMER_REAL, 0)
        if result is not None:
            err = result.error_before_exec or result.error_in_exec
            if err is not None:
                ename = type(err).__name__
                status["errors"].append(f"cell {index}: {ename}: {str(err)[:200]}")
        for name in after_cell.get(index, []):
            probe(name)
        status["cells"] += 1
    for name in list(pending):
        probe(name)
    status["finished"] = True
    status["seconds"] = round(time.monotonic() - start, 3)
    status["output_chars"] = sink.chars
    write_status()
    probes_out.close()
    os._exit(0)  # threads a notebook left running must not keep the sandbox alive


if __name__ == "__main__":
    sys.exit(main())
