"""Execute a notebook headless, as nbmake does, and time it (``benchmarks/notebook_times.py``, the
under-load test).

jupyter_client / nbclient counterpart: ``NotebookClient(nb).execute()``, with one difference: the
kernel talks to us over IPC sockets in a private temporary folder instead of TCP on loopback.
A TCP kernel logs "Kernel is running over TCP without encryption" at every start; an IPC
socket is a file only this user can open, so there is nothing to warn about (``make lab`` sets
the same transport for the lab, ``robocourse.cli.lab``).
"""

from __future__ import annotations

import os
import shutil
import tempfile
import time
from pathlib import Path


def kernel_manager(kernel_name: str, folder: str):
    """A KernelManager whose kernel listens on IPC sockets under ``folder`` (a private temp dir)."""
    from jupyter_client import KernelManager

    return KernelManager(kernel_name=kernel_name, transport="ipc", ip=os.path.join(folder, "kernel"),
                         connection_file=os.path.join(folder, "kernel.json"))


def execute(path, *, timeout: float = 600, env: dict | None = None, kernel_name: str | None = None):
    """Run every cell of the notebook at ``path`` (in its own folder); return ``(notebook, seconds)``.

    ``env``: extra environment variables for the kernel (the kernel inherits this process's
    environment). A cell that raises raises ``nbclient.exceptions.CellExecutionError`` here,
    naming the cell. ``timeout`` is per cell, as nbmake's.
    """
    import nbclient
    import nbformat

    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"notebook {path} not found: pass the path of a .ipynb file")
    nb = nbformat.read(path, as_version=4)
    name = kernel_name or nb.metadata.get("kernelspec", {}).get("name") or "python3"
    folder = tempfile.mkdtemp(prefix="rc-kernel-")
    saved = dict(os.environ)
    try:
        if env:
            os.environ.update({k: str(v) for k, v in env.items()})
        km = kernel_manager(name, folder)
        client = nbclient.NotebookClient(nb, km=km, timeout=timeout, kernel_name=name,
                                         resources={"metadata": {"path": str(path.parent.resolve())}})
        t0 = time.perf_counter()
        try:
            client.execute()
        finally:
            if km.has_kernel:   # nbclient leaves a kernel it was given running: ask it to exit
                # (shutdown_kernel() interrupts it first, and an idle kernel logs that as an ERROR line)
                km.request_shutdown()
                km.finish_shutdown()
                km.cleanup_resources()
        return nb, time.perf_counter() - t0
    finally:
        os.environ.clear()
        os.environ.update(saved)
        shutil.rmtree(folder, ignore_errors=True)
