"""Measured claims: a sentence rendered from its measurement, with the verdict the numbers support.

No ROS counterpart (rttest prints one run's statistics and leaves the reading to you). A chapter
never types a measured figure or a verdict about one into markdown; it calls :func:`claim` with
the numbers, and the sentence (the values, the comparison, the verdict, what was measured and
how often) is worded from them, including "this run cannot tell" when the numbers do not
separate two cases. The claim's inputs and verdict ride along in the output's display metadata
(key :data:`METADATA_KEY`), so a test can recompute every verdict a notebook printed
(``tests/test_chapters_under_load.py`` does, with chapter 1's CPU load running).

Three kinds, chosen by the arguments:

- **comparison**: two named cases, ``claim(what, {"a": [...], "b": [...]})``. One value per round
  of each. The verdict is ``"lower"`` or ``"higher"`` (for the first case) only when *every*
  round of one case lies on the same side of *every* round of the other (the ranges do not
  overlap) and there are enough rounds for that to mean something: two sets of ``n_a`` and
  ``n_b`` values from the same distribution come apart by chance with probability
  ``2 * n_a! * n_b! / (n_a + n_b)!`` (:func:`chance_apart`); it must be at most ``0.1``, so 3
  rounds of each is the least. ``"equal"`` when every value of both is the same number.
  Otherwise ``"cannot tell"``, with the reason (the ranges overlap, or too few rounds).
- **limit**: one case and ``limit=``: ``"within"`` (every value <= limit), ``"above"`` (every
  value > limit) or ``"mixed"`` (and in how many rounds).
- **figures**: one or more cases and no comparison (``compare=False``, or any number of cases
  but two): the values, no verdict (``"measured"``).

A scalar is one measurement (one run); a sequence is one value per round. Values are given in
the measurement's own unit and shown as ``value * scale`` with ``unit`` (``scale=1e-3,
unit="us"`` turns ns into us). ``each`` says what one round is ("5000 iterations at 1 kHz"); for
a single value it replaces "one run" and says what the value comes from ("one run of 5000
iterations", "9 runs, the last round of each setting").

Examples (what a notebook cell does; the last expression renders as Markdown)::

    >>> from robocourse.notebook import claim, say
    >>> c = claim("wake-up p50", {"hybrid": [12e3, 11e3, 13e3], "sleep": [80e3, 95e3, 88e3]},
    ...           unit="us", scale=1e-3, each="5000 iterations at 1 kHz")
    >>> c.verdict
    'lower'
    >>> print(c.text)
    **wake-up p50** (median [lowest–highest] of 3 rounds, each 5000 iterations at 1 kHz): hybrid 12.0 us [11.0–13.0], sleep 88.0 us [80.0–95.0]; **hybrid lower than sleep** in every round (the ranges do not overlap).
    >>> claim("wake-up p50", {"hybrid": [12e3, 11e3], "sleep": [80e3, 95e3]}, unit="us", scale=1e-3).verdict
    'cannot tell'
    >>> print(claim("max latency", 1.2e6, unit="us", scale=1e-3, limit=50e3, limit_name="the 5 % budget",
    ...             each="one run of 5000 iterations").text)
    **max latency** (one run of 5000 iterations): 1200.0 us; **above the 5 % budget** (50.0 us).
    >>> claim("faults", {"loop": 4000, "pool": 3}, digits=0, compare=False).verdict
    'measured'

In a notebook, ``say(c1, c2, "a sentence of your own")`` shows several claims (and plain
sentences) as one Markdown list; a :class:`Claim` shown on its own (the last line of a cell, or
``display(c)``) renders itself. Branch the prose that follows on ``c.verdict``, never on
numbers you re-derive, so the explanation matches the verdict printed.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

#: display-metadata key under which every rendered claim's record is stored (a list of records)
METADATA_KEY = "robocourse.claims"
#: the largest chance that two sets of rounds from the same distribution come apart by luck
#: alone for which a comparison still gives a verdict (3 rounds of each: 0.1)
MAX_CHANCE = 0.1
COMPARISON_VERDICTS = ("lower", "higher", "equal", "cannot tell")
LIMIT_VERDICTS = ("within", "above", "mixed")
RECORD_VERSION = 1


def chance_apart(n_a: int, n_b: int) -> float:
    """Probability that ``n_a`` and ``n_b`` values of one distribution fall into two ranges that do
    not overlap (either order): ``2 * n_a! * n_b! / (n_a + n_b)!``. 3 and 3: 0.1; 2 and 2: 1/3."""
    return 2.0 / math.comb(n_a + n_b, n_a)


def fewest_rounds(max_chance: float = MAX_CHANCE) -> int:
    """The fewest rounds of each case for which a comparison can give a verdict (3 at 0.1)."""
    n = 1
    while chance_apart(n, n) > max_chance:
        n += 1
    return n


def _as_values(name, value) -> list[float]:
    if isinstance(value, (str, bytes)) or value is None:
        raise ValueError(f"claim: values of {name!r} must be a number or a sequence of numbers, got {value!r}; "
                         "pass e.g. [12.1, 11.8, 12.4] (one per round) or 12.1 (one run)")
    arr = np.asarray(value, dtype=float).ravel() if not np.isscalar(value) else np.array([float(value)])
    if arr.size == 0:
        raise ValueError(f"claim: no values for {name!r}; a claim needs at least one measurement")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"claim: values of {name!r} contain NaN or inf ({arr.tolist()}); a sentence cannot be "
                         "worded from a missing measurement: drop or explain the failed rounds first")
    return [float(v) for v in arr]


def _fmt(v: float, scale: float, unit: str, digits: int) -> str:
    x = v * scale
    if digits == 0:
        x = round(x)
    text = f"{x:.{digits}f}"
    if unit in ("", "x"):
        return text + unit
    return f"{text} {unit}"


def _cell(vals: list[float], scale: float, unit: str, digits: int) -> str:
    med = _fmt(float(np.median(vals)), scale, unit, digits)
    if len(vals) == 1:
        return med
    lo, hi = (f"{min(vals) * scale:.{digits}f}", f"{max(vals) * scale:.{digits}f}")
    return f"{med} [{lo}–{hi}]"


def _rounds_word(n: int) -> str:
    return "one run" if n == 1 else f"{n} rounds"


@dataclass(frozen=True)
class Claim:
    """One rendered claim: ``text`` (Markdown), ``verdict``, and the ``record`` that rebuilds both."""

    text: str
    verdict: str
    kind: str
    record: dict = field(repr=False)

    # -- display ---------------------------------------------------------------------------
    def _repr_mimebundle_(self, include=None, exclude=None):
        return _bundle([self], self.text)

    def __str__(self) -> str:
        return self.text

    @staticmethod
    def from_record(record: dict) -> Claim:
        """Re-render a claim from its recorded inputs (what a test does to check a verdict)."""
        if record.get("version") != RECORD_VERSION:
            raise ValueError(f"claim record version {record.get('version')!r}: this robocourse reads version "
                             f"{RECORD_VERSION}; re-run the notebook with this robocourse")
        return claim(record["what"], record["values"], unit=record["unit"], scale=record["scale"],
                     digits=record["digits"], each=record["each"], limit=record["limit"],
                     limit_name=record["limit_name"], compare=record["compare"])


def _bundle(claims: list[Claim], markdown: str):
    data = {"text/markdown": markdown, "text/plain": markdown}
    return data, {METADATA_KEY: [c.record for c in claims]}


def claim(what: str, values, *, unit: str = "", scale: float = 1.0, digits: int = 1, each: str = "",
          limit: float | None = None, limit_name: str = "the limit", compare: bool = True) -> Claim:
    """A sentence about a measurement, worded from the numbers (see the module docstring).

    ``what``: the measured quantity ("wake-up p50"). ``values``: one case's value(s), or a dict
    ``{case name: value(s)}`` (insertion order is the order of the sentence; the first case is
    the subject of a comparison). ``unit``/``scale``/``digits``: how to show a value. ``each``:
    what one measurement is. ``limit``/``limit_name``: a threshold, in the values' own unit.
    ``compare=False``: two cases shown side by side without a verdict.
    """
    c = _render(what, values, unit=unit, scale=scale, digits=digits, each=each, limit=limit,
                limit_name=limit_name, compare=compare)
    c.record["verdict"] = c.verdict
    c.record["text"] = c.text
    return c


def _render(what, values, *, unit, scale, digits, each, limit, limit_name, compare) -> Claim:
    if not isinstance(what, str) or not what.strip():
        raise ValueError(f"claim: what={what!r} must name the measured quantity, e.g. claim('wake-up p50', ...)")
    if isinstance(digits, bool) or not isinstance(digits, int) or not 0 <= digits <= 6:
        raise ValueError(f"claim: digits={digits!r} must be an int from 0 to 6, e.g. digits=1")
    if not isinstance(scale, (int, float)) or isinstance(scale, bool) or not math.isfinite(scale) or scale <= 0:
        raise ValueError(f"claim: scale={scale!r} must be a positive number (1e-3 turns ns into us)")
    if isinstance(values, Mapping):
        if not values:
            raise ValueError("claim: values is an empty dict; give at least one case, e.g. {'sleep': [80.1, 79.5]}")
        cases = {str(k): _as_values(k, v) for k, v in values.items()}
    elif isinstance(values, (Sequence, np.ndarray, int, float, np.number)) and not isinstance(values, (str, bytes)):
        cases = {"": _as_values(what, values)}
    else:
        raise ValueError(f"claim: values={values!r} must be a number, a sequence of numbers or a dict "
                         "{case: numbers}")
    if limit is not None:
        if len(cases) != 1:
            raise ValueError(f"claim: limit= compares one case with a threshold, got {len(cases)} cases "
                             f"({', '.join(cases)}); make one claim per case")
        if not isinstance(limit, (int, float, np.number)) or not math.isfinite(float(limit)):
            raise ValueError(f"claim: limit={limit!r} must be a finite number in the values' own unit")
        limit = float(limit)
    record = {"version": RECORD_VERSION, "what": what, "values": cases, "unit": unit, "scale": float(scale),
              "digits": digits, "each": each, "limit": limit, "limit_name": limit_name, "compare": bool(compare)}
    counts = {len(v) for v in cases.values()}
    n = counts.pop() if len(counts) == 1 else None
    if n is not None:
        how = (each or "one run") if n == 1 else \
            f"median [lowest–highest] of {n} rounds" + (f", each {each}" if each else "")
    else:
        how = "median [lowest–highest] of each case's rounds" + (f", each {each}" if each else "")

    def shown(name, vals):
        body = _cell(vals, scale, unit, digits)
        if n is None:
            body += f" ({_rounds_word(len(vals))})"
        return f"{name} {body}" if name else body

    figures = ", ".join(shown(k, v) for k, v in cases.items())
    head = f"**{what}** ({how}): {figures}"
    if limit is not None:
        (vals,) = cases.values()
        above = sum(v > limit for v in vals)
        lim = _fmt(limit, scale, unit, digits)
        if above == 0:
            verdict, tail = "within", f"**within {limit_name}** ({lim})"
        elif above == len(vals):
            verdict, tail = "above", f"**above {limit_name}** ({lim})"
        else:
            verdict, tail = "mixed", f"above {limit_name} ({lim}) in {above} of {len(vals)} rounds, within it in the rest"
        if len(vals) > 1 and verdict != "mixed":
            tail += " in every round"
        return Claim(f"{head}; {tail}.", verdict, "limit", record)
    if len(cases) != 2 or not compare:
        return Claim(f"{head}.", "measured", "figures", record)
    (a, va), (b, vb) = cases.items()
    if len(set(va) | set(vb)) == 1:
        return Claim(f"{head}; {a} and {b} **equal** in every round.", "equal", "comparison", record)
    paired = ""
    if len(va) == len(vb) and len(va) > 1:
        lower = sum(x < y for x, y in zip(va, vb))
        paired = f"; {a} was lower in {lower} of {len(va)} rounds"
    if max(va) < min(vb):
        verdict, word = "lower", "lower"
    elif min(va) > max(vb):
        verdict, word = "higher", "higher"
    else:
        verdict = "cannot tell"
    p = chance_apart(len(va), len(vb))
    if verdict != "cannot tell" and p > MAX_CHANCE:
        need = fewest_rounds()
        if len(va) == len(vb):
            few = "one run of each is" if len(va) == 1 else f"{len(va)} rounds of each are"
        else:
            few = f"{len(va)} and {len(vb)} rounds are"
        odds = "always" if p >= 1 else f"{p:.0%} of the time"
        text = (f"{head}; **this run cannot tell** whether {a} is {word} than {b}: {few} too few (two identical "
                f"set-ups measured this often come out apart {odds} by chance alone; it takes {need} rounds of "
                "each).")
        return Claim(text, "cannot tell", "comparison", record)
    if verdict == "cannot tell":
        text = f"{head}; **this run cannot tell** {a} from {b}: their ranges overlap{paired}."
        return Claim(text, "cannot tell", "comparison", record)
    return Claim(f"{head}; **{a} {word} than {b}** in every round (the ranges do not overlap).",
                 verdict, "comparison", record)


class _Said:
    def __init__(self, parts):
        self.parts = parts

    def _repr_mimebundle_(self, include=None, exclude=None):
        claims = [p for p in self.parts if isinstance(p, Claim)]
        lines = "\n".join(f"- {p.text if isinstance(p, Claim) else p}" for p in self.parts)
        return _bundle(claims, lines)


def say(*parts) -> None:
    """Show claims (and sentences of your own, ``str``) as one Markdown list, claims' records attached."""
    if not parts:
        raise ValueError("say() needs at least one claim or sentence, e.g. say(claim(...), 'why it matters')")
    for p in parts:
        if not isinstance(p, (Claim, str)):
            raise ValueError(f"say: {p!r} is neither a claim nor a sentence (str); pass claim(...) results or text")
    from IPython.display import display

    display(_Said(list(parts)))


def recorded_claims(notebook) -> list[dict]:
    """Every claim record in an executed notebook's outputs (a dict loaded by nbformat/json).

    Each record also carries ``_shown`` (the Markdown the output showed), ``_cell`` (the cell's
    index) and ``_section`` (the last Markdown heading above it, "" before the first)."""
    out = []
    section = ""
    for i, cell in enumerate(notebook.get("cells", [])):
        if cell.get("cell_type") == "markdown":
            src = cell.get("source", "")
            for line in ("".join(src) if isinstance(src, list) else src).splitlines():
                if line.startswith("#"):
                    section = line.lstrip("#").strip()
            continue
        for o in cell.get("outputs", []) if cell.get("cell_type") == "code" else []:
            recs = (o.get("metadata") or {}).get(METADATA_KEY)
            if recs:
                md = o.get("data", {}).get("text/markdown", "")
                out.extend({**r, "_shown": "".join(md) if isinstance(md, list) else md, "_cell": i,
                            "_section": section} for r in recs)
    return out


def claim_keys(records: list[dict]) -> list[str]:
    """A key per record that names the same claim in another run of the notebook: its ``what`` and
    its cases (``wake-up p50 [hybrid / sleep]``), with ``#2``, ``#3``... on a later claim of the
    same key (the sentence itself changes with the numbers; the name, the cases and their order
    do not)."""
    seen: dict[str, int] = {}
    keys = []
    for r in records:
        cases = [c for c in r.get("values", {}) if c]
        base = r["what"] + (f" [{' / '.join(cases)}]" if cases else "")
        seen[base] = seen.get(base, 0) + 1
        keys.append(base if seen[base] == 1 else f"{base} #{seen[base]}")
    return keys


def write_claims(folder, notebook_name: str, condition: str, notebook: dict, **about) -> Path:
    """Write the claims an executed notebook rendered to ``folder/<notebook_name>.<condition>.json``.

    One object: ``about`` (e.g. the load average and the run's seconds) and ``claims``, a row per
    claim (key, what, verdict, text, cell, section). ``benchmarks/notebook_times.py --claims`` and
    ``tests/test_chapters_under_load.py`` (``ROBOCOURSE_CLAIMS_OUT``) write these; the script's
    ``--list`` turns a folder of them into a per-chapter list, quiet beside loaded."""
    records = recorded_claims(notebook)
    rows = [{"key": k, "what": r["what"], "verdict": r["verdict"], "text": r["text"], "cell": r["_cell"],
             "section": r["_section"]} for k, r in zip(claim_keys(records), records)]
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    out = folder / f"{notebook_name}.{condition}.json"
    out.write_text(json.dumps({"notebook": notebook_name, "condition": condition, "about": about,
                               "claims": rows}, indent=1, ensure_ascii=False) + "\n", encoding="utf-8")
    return out
