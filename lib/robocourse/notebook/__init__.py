"""Helpers every notebook imports: am I under test, fixed seeds, measured claims, quiet logs.

Mirrors the pattern of MIT's course library (``running_as_notebook``): a notebook asks
``running_as_test()`` and shortens its simulations when it is executed by nbmake, CI or the
grader, so every notebook stays under the 60 s budget headless.

For chapter authors, the rest of the notebook-facing API (each module's docstring has more):

- ``claim(what, values, unit=..., scale=..., each=..., limit=...)`` (:mod:`.claims`): a measured
  sentence rendered from the numbers, never typed into markdown. Two cases -> a comparison
  (``"lower"``/``"higher"`` only when every round of one lies beyond every round of the other
  and there are at least 3 rounds of each, else ``"this run cannot tell"``); ``limit=`` -> within/
  above/mixed; otherwise the figures. A Claim renders itself as Markdown (last line of a cell, or
  ``display(c)``); ``say(c1, c2, "your own sentence")`` shows several as one list. Branch the
  prose that follows on ``c.verdict``. Each rendered claim carries its inputs in the output's
  metadata, and CI recomputes every verdict from them with chapter 1's CPU load running
  (``tests/test_chapters_under_load.py``). ``rt.repeat.Repeated.claim(a, b, metric)`` builds one
  from interleaved rounds.
- Markdown holds only definitions, settings and labelled quotes (:mod:`.markdown_rules`): write
  a value the code sets as code (``a `1 kHz` loop``) or as an assignment (``dt = 1 ms``), and a
  figure from elsewhere with ``(source: ...)`` or ``quoted from ...``. ``tests/test_chapter_markdown.py``
  enforces it, with a per-notebook list of known violations that may only shrink.
- ``log_level("WARN")`` (:mod:`.logs`): hide INFO floods (kept on the context, not lost).
- ``progress(total, desc)`` (:mod:`.progress_line`): a progress line that is saved as it ended.
- ``run.execute(path)`` (:mod:`.run`): run a notebook headless (kernel over IPC), timed.
"""

from __future__ import annotations

import os
import random
import sys

#: Environment variables that mean "executed by a machine, not read by a person".
TEST_ENV_VARS = ("ROBOCOURSE_TEST", "CI", "ROBOCOURSE_GRADING_RESULTS", "PYTEST_CURRENT_TEST")

DEFAULT_SEED = 20261121


def _truthy(value: str | None) -> bool:
    return value is not None and value.strip().lower() not in ("", "0", "false", "no", "off")


def running_as_test() -> bool:
    """True when the notebook runs under nbmake, pytest, CI or ``robocourse grade``.

    Set ``ROBOCOURSE_TEST=0`` to force the full, interactive-length runs even under CI.
    """
    explicit = os.environ.get("ROBOCOURSE_TEST")
    if explicit is not None:
        return _truthy(explicit)
    if any(_truthy(os.environ.get(name)) for name in TEST_ENV_VARS[1:]):
        return True
    # nbmake's kernel inherits PYTEST_CURRENT_TEST from the pytest process (checked above);
    # library code imported by pytest itself sees the pytest module.
    return "pytest" in sys.modules


def running_as_notebook() -> bool:
    """The opposite of :func:`running_as_test` (MIT manipulation's spelling)."""
    return not running_as_test()


def pick(interactive, test):
    """Return ``test`` under test, ``interactive`` otherwise: ``T = pick(10.0, 0.5)``."""
    return test if running_as_test() else interactive


def seed_everything(seed: int = DEFAULT_SEED):
    """Fix Python's and NumPy's global random generators; return a fresh ``np.random.Generator``.

    Use the returned generator for new code (``rng.normal(...)``); the global seeding covers
    libraries that still draw from ``np.random``.
    """
    if not isinstance(seed, int) or isinstance(seed, bool) or seed < 0:
        raise ValueError(f"seed must be a non-negative int, got {seed!r}; pass e.g. seed_everything(0)")
    import numpy as np

    random.seed(seed)
    np.random.seed(seed % (2**32))
    os.environ["PYTHONHASHSEED"] = str(seed)
    return np.random.default_rng(seed)


from robocourse.notebook.claims import Claim, claim, say  # noqa: E402  (the measured-claim API)
from robocourse.notebook.logs import log_level  # noqa: E402
from robocourse.notebook.progress_line import progress  # noqa: E402

__all__ = ["DEFAULT_SEED", "TEST_ENV_VARS", "Claim", "claim", "log_level", "pick", "progress", "running_as_notebook",
           "running_as_test", "say", "seed_everything"]
