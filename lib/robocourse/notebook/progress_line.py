"""A progress line that a saved notebook shows as it ended, never frozen at "0/15".

tqdm's notebook bar is a widget: a notebook saved (or executed headless) keeps the widget's
text fallback from the moment it was *created*, so a reopened notebook shows "0/15" forever.
``progress(total, desc)`` draws one output line, replaced in place as it advances (IPython's
``display_id``), and replaced a last time by its summary when closed, so what is saved is what
happened ("runs: 15 of 15 in 42.1 s"). Outside a Jupyter kernel it writes a ``\\r``-updated line to
stderr when stderr is a terminal, and nothing otherwise.

    with progress(len(jobs), "runs") as bar:
        for job in jobs:
            job()
            bar.update()
"""

from __future__ import annotations

import sys
import time


def _in_kernel() -> bool:
    ipython = sys.modules.get("IPython")
    shell = ipython.get_ipython() if ipython is not None else None
    return shell is not None and shell.__class__.__name__ == "ZMQInteractiveShell"


class progress:  # noqa: N801  (used like a function)
    """``progress(total, desc)``: call ``update(n=1)`` as work finishes; ``close()`` (or ``with``) at the end."""

    MIN_INTERVAL_S = 0.2   # redraw at most this often (each redraw is a message to the front end)

    def __init__(self, total: int, desc: str = "progress"):
        if isinstance(total, bool) or not isinstance(total, int) or total < 1:
            raise ValueError(f"progress(total={total!r}): total must be a positive int (the number of steps)")
        self.total, self.desc, self.n = total, desc, 0
        self._t0 = time.perf_counter()
        self._last = 0.0
        self._handle = None
        self._tty = False
        if _in_kernel():
            from IPython.display import display

            self._handle = display(self._bundle(), raw=True, display_id=True)
        else:
            self._tty = bool(getattr(sys.stderr, "isatty", lambda: False)())
            self._draw(force=True)

    def _text(self, done: bool = False) -> str:
        elapsed = time.perf_counter() - self._t0
        if done:
            return f"{self.desc}: {self.n} of {self.total} in {elapsed:.1f} s"
        return f"{self.desc}: {self.n} of {self.total} ({elapsed:.0f} s)"

    def _bundle(self, done: bool = False) -> dict:
        text = self._text(done)
        bar = "" if done else f'<progress value="{self.n}" max="{self.total}" style="width:12em"></progress> '
        return {"text/plain": text, "text/html": f"<div>{bar}{text}</div>"}

    def _draw(self, force: bool = False, done: bool = False) -> None:
        now = time.perf_counter()
        if not force and now - self._last < self.MIN_INTERVAL_S:
            return
        self._last = now
        if self._handle is not None:
            self._handle.update(self._bundle(done), raw=True)
        elif self._tty:
            sys.stderr.write("\r" + self._text(done) + ("\n" if done else ""))
            sys.stderr.flush()

    def update(self, n: int = 1) -> None:
        self.n = min(self.total, self.n + n)
        self._draw(force=self.n == self.total)

    def close(self) -> None:
        self._draw(force=True, done=True)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False
