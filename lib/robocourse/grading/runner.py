"""Inside the sandbox: execute one notebook and gather the probes' data (``python -m``).

Started by ``grader.py`` through ``sandbox.run`` with the sandbox folder as its only argument.
It reads the grader's request (which checks, their inputs, their probes), deletes it, runs the
notebook's code cells in an IPython shell in this process (magics and display work as in
Jupyter; no kernel, no sockets), and right after the cell that calls ``check("name", ...)``
(or at the end, for a deleted check cell or an instructor's hidden check) runs that check's
probe on the notebook's globals. Each probe's data is appended to ``probes.jsonl`` at once, so
a notebook that crashes later keeps what was gathered before. Nothing here decides a grade:
everything this process writes is treated by the grader as the student's untrusted output.

An answer bank's request (``bank.py``) carries ``segments`` instead of a notebook: each runs in
a fresh namespace (setup cell, answer cell, check cell) and its probe follows its last cell.
The notebook is read as plain JSON (nbformat's import alone costs seconds per sandbox).

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
    def mapping(value):
        return value if isinstance(value, dict) else {}

    meta = mapping(nb.get("metadata"))
    spec = mapping(meta.get("kernelspec"))
    name = str(spec.get("name", ""))
    language = str(spec.get("language") or mapping(meta.get("language_info")).get("name") or "python").lower()
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


def read_cells(text: str) -> list[dict]:
    """The cells of a version-4 notebook's JSON, each ``{"cell_type", "source"}`` with the source a str.

    What the runner needs of nbformat's reader, without importing nbformat (its jsonschema
    import costs seconds in every sandbox). Raises ValueError naming what is wrong.
    """
    nb = json.loads(text)
    if not isinstance(nb, dict) or not isinstance(nb.get("cells"), list):
        raise ValueError("no list of cells")
    if nb.get("nbformat") != 4:
        raise ValueError(f"nbformat {nb.get('nbformat')!r}; version 4 is what JupyterLab writes")
    cells = []
    for i, cell in enumerate(nb["cells"]):
        if not isinstance(cell, dict) or cell.get("cell_type") not in ("code", "markdown", "raw"):
            raise ValueError(f"cell {i} is not a code, markdown or raw cell")
        source = cell.get("source", "")
        if isinstance(source, list) and all(isinstance(x, str) for x in source):
            source = "".join(source)
        if not isinstance(source, str):
            raise ValueError(f"cell {i} has a source that is not text")
        cells.append({"cell_type": cell["cell_type"], "source": source})
    return cells


def _load_notebook(folder: Path):
    """The notebook's cells, or a sentence saying why it cannot be graded."""
    try:
        text = (folder / NOTEBOOK).read_text(encoding="utf-8")
        cells = read_cells(text)
        nb = json.loads(text)
    except (ValueError, UnicodeDecodeError, RecursionError) as exc:  # invalid JSON, wrong structure
        return (f"the file is not a valid notebook ({type(exc).__name__}: {str(exc)[:200]}); "
                "re-download it or save it again from JupyterLab")
    return kernel_problem(nb) or cells


def _fresh_namespace(shell) -> None:
    """Empty the user namespace for the next answer of a bank (IPython's reset, minus its history,
    alias and cache work: 0.01 s instead of 0.15 s per answer). Imported modules stay imported."""
    ns = shell.user_ns
    for key in [k for k in ns if k not in ("__builtin__", "__builtins__", "__name__")]:
        del ns[key]
    shell.user_ns_hidden.clear()
    shell.init_user_ns()


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    folder = Path(argv[0] if argv else ".")
    status = {"started": True, "finished": False, "reason": "", "errors": [], "cells": 0, "last_cell": -1,
              "output_chars": 0}

    def write_status():
        try:
            (folder / STATUS).write_text(json.dumps(status))
        except OSError:  # the submission filled its own folder: the grader says so from outside
            pass

    # a write past the file-size limit fails with EFBIG instead of killing the run
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    request = json.loads((folder / REQUEST).read_text())
    (folder / REQUEST).unlink()
    cell_timeout = float(request.get("cell_timeout", 60))
    if request.get("segments") is not None:
        cells = []
    else:
        problem = _load_notebook(folder)
        if isinstance(problem, str):
            status["reason"], status["finished"] = problem, True
            write_status()
            return 0
        cells = problem

    from .checks import CHECK_CALL, Check, run_probe

    # one probe per requested record id ("name"; the check it runs is "check", default the same)
    pending = {c["name"]: c for c in request["checks"]}
    segments = request.get("segments")
    if segments is None:
        # a submitted notebook: one segment, each check probed right after the cell that calls it
        after_cell: dict[int, list[str]] = {}
        for index, cell in enumerate(cells):
            if cell.get("cell_type") == "code":
                for name in CHECK_CALL.findall(cell.get("source", "")):
                    if name in pending and not any(name in v for v in after_cell.values()):
                        after_cell.setdefault(index, []).append(name)
        segments = [{"cells": [(i, c.get("source", "")) for i, c in enumerate(cells) if c.get("cell_type") == "code"],
                     "after": after_cell, "fresh": False}]
    else:
        # a bank of answers (robocourse.grading.bank): each segment runs in a fresh namespace and
        # its probes follow its last cell
        segments = [{"cells": [(k, src) for k, src in enumerate(seg["cells"])],
                     "after": {len(seg["cells"]) - 1: list(seg["probes"])}, "fresh": True} for seg in segments]

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
            chk = Check(spec.get("check", name), None, _load_probe(spec["probe"]), tuple(spec["uses"]),
                        time_limit=float(spec["time_limit"]), references=tuple(spec.get("references", ())))
            data = run_probe(chk, spec["inputs"], [shell.user_ns[u] for u in spec["uses"]])
        try:
            line = json.dumps({"name": name, **data})
        except (TypeError, ValueError) as exc:
            line = json.dumps({"name": name, "outputs": None, "reason": "raised", "delegated": [],
                               "error": f"the output could not be sent to the grader ({exc})"})
        try:
            probes_out.write(line + "\n")
            probes_out.flush()
        except OSError:  # its folder is full: this record is lost, and the grader says why
            pass

    def on_alarm(signum, frame):
        raise CellTimeout(f"interrupted after the {cell_timeout:g} s cell time limit")

    signal.signal(signal.SIGALRM, on_alarm)
    start = time.monotonic()
    for number, segment in enumerate(segments):
        if segment["fresh"]:
            _fresh_namespace(shell)
            sys.stdout = sys.stderr = sink
        for index, source in segment["cells"]:
            where = f"cell {index}" if not segment["fresh"] else f"segment {number} cell {index}"
            status["last_cell"] = index
            write_status()
            signal.setitimer(signal.ITIMER_REAL, cell_timeout)
            try:
                result = shell.run_cell(source, store_history=False, silent=False)
            except CellTimeout as exc:  # fired outside the user's code, between IPython's steps
                result = None
                status["errors"].append(f"{where}: CellTimeout: {exc}")
            finally:
                signal.setitimer(signal.ITIMER_REAL, 0)
            if result is not None:
                err = result.error_before_exec or result.error_in_exec
                if err is not None:
                    ename = type(err).__name__
                    status["errors"].append(f"{where}: {ename}: {str(err)[:200]}")
            for name in segment["after"].get(index, []):
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
