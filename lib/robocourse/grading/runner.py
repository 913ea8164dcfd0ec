"""Execute one submitted notebook for the grader, in its own process (``python -m``).

The parent (``grader.py``) starts this module with a memory rlimit and kills its whole process
tree after the time limit. Here we: read the notebook (invalid JSON -> a status, not a crash),
pick the kernel, append the cell that runs instructor-added checks, execute every cell with a
per-cell timeout (errors and ``sys.exit`` do not stop the run), cap stored output, and write a
status JSON. Check results themselves are appended by ``checks.check`` to the results file.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

import nbformat
from nbclient import NotebookClient
from nbclient.exceptions import DeadKernelError

PYTHON_KERNEL_NAMES = ("robocourse", "python3", "python", "python2")


class CappedClient(NotebookClient):
    """nbclient with a cap on stored output bytes (nbgrader limits output size the same way)."""

    def __init__(self, nb, max_output_bytes: int, **kw):
        super().__init__(nb, **kw)
        self.max_output_bytes = max_output_bytes
        self.output_bytes = 0
        self.output_truncated = False

    def output(self, outs, msg, display_id, cell_index):
        size = len(json.dumps(msg.get("content", {}), default=str))
        self.output_bytes += size
        if self.output_bytes > self.max_output_bytes:
            self.output_truncated = True
            return None
        return super().output(outs, msg, display_id, cell_index)


def choose_kernel(nb) -> tuple[str | None, str]:
    """(kernel name to run, reason). None when the notebook needs a kernel we cannot give it."""
    from jupyter_client.kernelspec import KernelSpecManager

    spec = nb.metadata.get("kernelspec", {}) or {}
    name = spec.get("name", "")
    language = (spec.get("language") or nb.metadata.get("language_info", {}).get("name") or "python").lower()
    installed = KernelSpecManager().find_kernel_specs()
    python_like = language == "python" or name in PYTHON_KERNEL_NAMES or name.startswith("python")
    if not python_like:
        return None, (f"the notebook asks for kernel {name or '?'!r} (language {language!r}), which cannot run "
                      "the exercise; open it in JupyterLab, pick 'Python (robocourse)' and save")
    for candidate in ("robocourse", "python3"):
        if candidate in installed:
            return candidate, f"ran with kernel {candidate!r} (notebook said {name or 'nothing'!r})"
    return None, f"no Python kernel is installed for grading (have: {sorted(installed)}); run `make setup`"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("notebook")
    ap.add_argument("results", help="JSON-lines file the checks append to")
    ap.add_argument("status", help="JSON file this runner writes its outcome to")
    ap.add_argument("--cell-timeout", type=float, default=60.0)
    ap.add_argument("--max-output-bytes", type=int, default=1_000_000)
    ap.add_argument("--checks", default="", help="comma-separated expected check names")
    args = ap.parse_args(argv)

    status = {"ok": False, "reason": "", "errors": [], "kernel_pid": None, "seconds": 0.0}

    def write_status():
        with open(args.status, "w", encoding="utf-8") as fh:
            json.dump(status, fh)

    start = time.monotonic()
    try:
        nb = nbformat.read(args.notebook, as_version=4)
    except Exception as exc:  # invalid JSON, wrong schema, unreadable file
        status["reason"] = f"the file is not a valid notebook ({type(exc).__name__}: {str(exc)[:200]}); re-download it or save it again from JupyterLab"
        write_status()
        return 0

    kernel, why = choose_kernel(nb)
    status["kernel"] = why
    if kernel is None:
        status["reason"] = why
        write_status()
        return 0

    names = [n for n in args.checks.split(",") if n]
    nb.cells.append(nbformat.v4.new_code_cell(
        "import robocourse.grading as _rc_grading\n"
        f"_rc_grading.run_pending(globals(), names={names!r})"
    ))
    os.environ["ROBOCOURSE_GRADING_RESULTS"] = os.path.abspath(args.results)
    os.environ.setdefault("ROBOCOURSE_TEST", "1")
    os.environ.setdefault("MPLBACKEND", "Agg")

    client = CappedClient(
        nb, args.max_output_bytes, kernel_name=kernel, timeout=int(max(1, args.cell_timeout)),
        allow_errors=True, interrupt_on_timeout=True,
        error_on_timeout={"ename": "CellTimeout", "evalue": f"cell exceeded {args.cell_timeout:g} s", "traceback": []},
        record_timing=False,
        resources={"metadata": {"path": os.path.dirname(os.path.abspath(args.notebook))}},
    )
    try:
        with client.setup_kernel():
            status["kernel_pid"] = getattr(client.km.provisioner, "pid", None) if client.km else None
            write_status()
            for index, cell in enumerate(client.nb.cells):
                client.execute_cell(cell, index)
                for out in cell.get("outputs", []):
                    if out.get("output_type") == "error":
                        ename, evalue = out.get("ename"), str(out.get("evalue"))[:200]
                        if ename == "KeyboardInterrupt":  # nbclient interrupts a cell at its timeout
                            ename, evalue = "CellTimeout", f"interrupted after the {args.cell_timeout:g} s cell time limit"
                        status["errors"].append(f"cell {index}: {ename}: {evalue}")
        status["ok"] = True
    except DeadKernelError:
        status["reason"] = "the kernel died (os._exit, a crash, or the memory limit); checks after that point did not run"
    except Exception as exc:
        status["reason"] = f"execution stopped: {type(exc).__name__}: {str(exc)[:300]}"
    status["output_truncated"] = client.output_truncated
    status["seconds"] = round(time.monotonic() - start, 3)
    write_status()
    return 0


if __name__ == "__main__":
    sys.exit(main())
