"""Probe helpers: turn what the student's code produced into plain data, and nothing more.

A probe runs where the student's code runs (their kernel, or the grading sandbox). It may
only *gather*: call the student's objects on the grader's inputs and return the outcomes as
plain data (None, bool, int, float, str, lists, dicts with string keys). Whatever it returns
is judged by the grader's own process, so a probe never decides anything.

``call(f, *args)`` records one call as ``{"value": ...}`` or ``{"raised": "ValueError",
"message": "..."}``, so a judge can check both answers and refusals, and list every mistake.
``calls`` is a ready-made probe for checks that are plain function calls (an instructor's
hidden check usually needs nothing else).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

MAX_ITEMS = 200_000  # a probe's output is bounded: longer sequences are cut and marked


def plain(value: Any, depth: int = 0) -> Any:
    """JSON-safe copy of ``value``: numpy scalars/arrays become Python numbers/lists.

    Non-finite floats are kept as the strings "nan", "inf", "-inf" (JSON has no NaN);
    :func:`number` reads them back. Anything else becomes ``{"type": name, "repr": ...}``.
    """
    if depth > 20:
        return {"type": "too deep", "repr": ""}
    if value is None or isinstance(value, (bool, str)):
        return value
    if isinstance(value, (np.bool_,)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        v = float(value)
        return v if math.isfinite(v) else ("nan" if math.isnan(v) else ("inf" if v > 0 else "-inf"))
    if isinstance(value, np.ndarray):
        if value.dtype.kind in "biuf":
            return [plain(v, depth + 1) for v in value.ravel()[:MAX_ITEMS].tolist()]
        return [plain(v, depth + 1) for v in list(value.ravel()[:MAX_ITEMS])]
    if isinstance(value, (list, tuple)):
        return [plain(v, depth + 1) for v in list(value)[:MAX_ITEMS]]
    if isinstance(value, dict):
        return {str(k): plain(v, depth + 1) for k, v in list(value.items())[:MAX_ITEMS]}
    return {"type": type(value).__name__, "repr": repr(value)[:200]}


def number(value: Any) -> float:
    """A judge's reading of one plain number (raises TypeError on anything else)."""
    if isinstance(value, bool) or value is None:
        raise TypeError(f"expected a number, got {value!r}")
    if isinstance(value, str) and value in ("nan", "inf", "-inf"):
        return float(value)
    if isinstance(value, (int, float)):
        return float(value)
    raise TypeError(f"expected a number, got {type(value).__name__} {str(value)[:60]}")


def call(func, *args, **kwargs) -> dict:
    """One call of the student's ``func``: ``{"value": plain}`` or ``{"raised": name, "message": text}``.

    NotImplementedError is re-raised: the whole check is then "not implemented yet".
    """
    try:
        value = func(*args, **kwargs)
    except NotImplementedError:
        raise
    except Exception as exc:
        return {"raised": type(exc).__name__, "bases": [c.__name__ for c in type(exc).__mro__],
                "message": str(exc)[:300]}
    return {"value": plain(value), "type": type(value).__name__}


def raised(record, exception_name: str) -> bool:
    """True if a :func:`call` record shows an exception of that class or a subclass of it."""
    if not isinstance(record, dict) or "raised" not in record:
        return False
    bases = record.get("bases")
    return exception_name in (bases if isinstance(bases, list) else [record["raised"]])


def calls(inputs, *objects):
    """Generic probe: ``inputs`` is a list of ``[object index, args list, kwargs dict]``.

    Returns one :func:`call` record per entry, in order. Example (a hidden check)::

        @register("ch00.hidden_budget", uses=("latency_budget_ns",), probe=calls,
                  inputs=lambda rng: [[0, [2_000_000], {}]])
        def judge(inputs, outputs):
            if outputs[0].get("value") != 100_000:
                raise CheckFailed("5 % of 2 ms is 100 us")
    """
    out = []
    for index, args, kwargs in inputs:
        out.append(call(objects[index], *args, **kwargs))
    return out
