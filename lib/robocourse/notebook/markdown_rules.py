"""The rule for chapter markdown: no measured figure and no verdict about a measurement.

A measured number or verdict is rendered by a code cell from the measurement
(:func:`robocourse.notebook.claim`); markdown holds what does not depend on the run. This module
finds, sentence by sentence, what markdown must not hold (``tests/test_chapter_markdown.py``
applies it to every chapter and solution notebook):

- a **figure**: a number with a unit (us, µs, ns, ms, s, min, Hz, kHz, %, x, m, cm, mm, km, N, Nm,
  rad, mrad, deg, °, kg, g, V, W, B, kB, KiB, MiB, GiB, px, fps, m/s, rad/s, ...), ranges included
  ("2-3 ms");
- a **count of runs**: "0 of 9 runs", "3 out of 5 rounds";
- a **verdict**: a comparison ("lower than", "faster ... than", "x slower") or a verdict word
  ("punctual", "negligible", "outperforms", "no difference") in a sentence about a measured
  quantity (latency, jitter, median, p99, max, overruns, error, drift, time, ...), unless the
  sentence is worded to hold whichever way it comes out (it contains one of :data:`HEDGES`:
  "if", "whether", "when", "may", "expect", "printed", "either way", ...).

Allowed forms (the marking convention; grep for them):

1. **a value the code sets, or a definition, written as code or math**: ``holding it `2 ms` at a
   time``, ``a `1 kHz` loop``, ``$L = 0.5\\,\\mathrm{m}$``. Inline code spans and ``$...$`` math are
   not scanned. Use them only for settings and definitions, never for a measured result.
2. **an assignment**: ``dt = 1 ms``, ``period = 1 ms``: a name, ``=``, the figure.
3. **a labelled quote**: the sentence says where the figure comes from, as ``(source: ...)`` or
   ``quoted from ...``: "a stock kernel's max of 2.75 ms (source: ROS 2 docs, Real-time
   programming)". The whole sentence is then exempt, verdicts included.

Fenced code blocks and HTML comments are not scanned either.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass
from pathlib import Path

_NUM = r"[-+−±]?\d[\d,]*(?:\.\d+)?"
UNITS = ("µs", "μs", "us", "ns", "ms", "s", "sec", "secs", "seconds", "second", "milliseconds", "microseconds",
         "nanoseconds", "min", "minutes", "hours", "Hz", "kHz", "MHz", "GHz", "%", "x", "m", "cm", "mm", "km",
         "N", "Nm", "N·m", "N m", "rad", "mrad", "deg", "degrees", "°", "kg", "g", "V", "W", "B", "bytes",
         "kB", "KB", "MB", "GB", "KiB", "MiB", "GiB", "px", "pixels", "fps", "m/s", "mm/s", "rad/s", "rad/s²",
         "m/s²", "deg/s")
_UNIT = "|".join(sorted((re.escape(u) for u in UNITS), key=len, reverse=True))
#: a number (or a range of two) followed by a unit, not followed by more word characters
FIGURE = re.compile(rf"(?<![\w.]){_NUM}(?:\s?(?:-|–|to|and)\s?{_NUM})?\s?(?:{_UNIT})(?![\w/²])")
#: "3 of 5 rounds": a count of repeated measurements
RUN_COUNT = re.compile(r"\b\d+\s+(?:of|out of)\s+\d+\s+(?:runs?|rounds?|trials?|seeds?|repeats?|attempts?)\b", re.I)
#: a comparison or verdict word
COMPARATIVE = re.compile(
    r"\b(?:faster|slower|lower|higher|smaller|larger|bigger|shorter|longer|better|worse|fewer|less|more)"
    r"(?:\s+\S+){0,4}?\s+than\b"
    r"|\b\d+(?:\.\d+)?\s?x\s+(?:faster|slower|more|less|lower|higher)\b"
    r"|\b(?:punctual|negligible|outperforms?|no (?:measurable |visible |real |significant )?(?:difference|effect)"
    r"|always (?:late|on time)|never (?:late|misses))\b", re.I)
#: what a verdict would be about
MEASURED_NOUN = re.compile(
    r"\b(?:latenc(?:y|ies)|jitter|p\d{2}(?:\.\d)?|median|mean|average|max(?:imum)?|min(?:imum)?|tail|overruns?"
    r"|wake-?ups?|throughput|error|drift|faults?|(?<!-)times?|duration|delay|cost|CPU|overshoot|settl\w*|distance"
    r"|speed|rate|loss|spread|fall probability|round trip)\b", re.I)
#: words that make a sentence hold whichever way the run comes out (a condition, a prediction, a pointer
#: to the rendered result)
HEDGES = re.compile(r"\b(?:if|whether|when|unless|may|might|would|should|expect\w*|predict\w*|prints?|printed|rendered"
                    r"|shown (?:above|below)|depends?|either way|whichever|hypothes\w+)\b", re.I)
#: the labelled-quote forms
QUOTE = re.compile(r"\(source:\s*[^)\s][^)]*\)|\bquoted from\s+\S", re.I)
_ASSIGNMENT = re.compile(rf"\b[A-Za-z_][\w.]*\s*=\s*{_NUM}\s?(?:{_UNIT})(?![\w/²])")
_CODE_SPAN = re.compile(r"(`+)(?:(?!\1).)+?\1", re.S)
_MATH = re.compile(r"\$\$.+?\$\$|\$[^$\n]+\$", re.S)
_FENCE = re.compile(r"^(```|~~~).*?^\1[^\n]*$", re.S | re.M)
_COMMENT = re.compile(r"<!--.*?-->", re.S)
_LINK_TARGET = re.compile(r"\]\([^)]*\)")
_HTML_TAG = re.compile(r"<[^>]+>")
_BLOCK_START = re.compile(r"^\s*(?:[-*+]\s|\d+\.\s|#{1,6}\s|\||>)")
_SENTENCE_END = re.compile(r"(?<=[.!?])\s+(?=[A-Z*_`(\[\"'])")


@dataclass(frozen=True)
class Violation:
    sentence: str  # the sentence as written (whitespace collapsed): the key of a known-violation entry
    kind: str      # "figure", "run count" or "verdict"
    found: str     # the text that matched

    def __str__(self):
        return f"{self.kind} {self.found!r} in: {self.sentence}"


def sentences(markdown: str) -> list[str]:
    """The sentences of a markdown cell (list items, headings and table rows are their own blocks)."""
    text = _COMMENT.sub(" ", _FENCE.sub(" ", markdown))
    blocks: list[list[str]] = []
    for line in text.splitlines():
        if not line.strip():
            blocks.append([])
            continue
        if _BLOCK_START.match(line) or not blocks:
            blocks.append([])
        blocks[-1].append(line.strip())
    out = []
    for block in blocks:
        joined = " ".join(block).strip()
        if joined:
            # a sentence never ends inside a code span or math: mask their dots and spaces while splitting
            masked = _MATH.sub(_mask, _CODE_SPAN.sub(_mask, joined))
            out.extend(_unmask(s.strip()) for s in _SENTENCE_END.split(masked) if s.strip())
    return out


_MASKS = {".": "\ue000", "!": "\ue001", "?": "\ue002", " ": "\ue003"}


def _mask(m: re.Match) -> str:
    return "".join(_MASKS.get(ch, ch) for ch in m.group(0))


def _unmask(text: str) -> str:
    for ch, sub in _MASKS.items():
        text = text.replace(sub, ch)
    return text


def _scannable(sentence: str) -> str:
    s = _CODE_SPAN.sub(" ", sentence)
    s = _MATH.sub(" ", s)
    s = _LINK_TARGET.sub("]", s)
    s = _HTML_TAG.sub(" ", s)
    return _ASSIGNMENT.sub(" ", s)


def check_sentence(sentence: str) -> list[Violation]:
    """What in ``sentence`` breaks the rule (empty when it is allowed)."""
    if QUOTE.search(sentence):
        return []
    s = _scannable(sentence)
    found = [Violation(sentence, "figure", m.group(0).strip()) for m in FIGURE.finditer(s)]
    found += [Violation(sentence, "run count", m.group(0)) for m in RUN_COUNT.finditer(s)]
    comp = COMPARATIVE.search(s)
    if comp and MEASURED_NOUN.search(s) and not HEDGES.search(s):
        found.append(Violation(sentence, "verdict", comp.group(0)))
    return found


def check_markdown(markdown: str) -> list[Violation]:
    return [v for s in sentences(markdown) for v in check_sentence(s)]


def notebook_violations(path) -> list[Violation]:
    """Every violation in the markdown cells of the notebook at ``path``."""
    nb = json.loads(Path(path).read_text(encoding="utf-8"))
    out = []
    for cell in nb.get("cells", []):
        if cell.get("cell_type") == "markdown":
            src = cell.get("source", "")
            out.extend(check_markdown("".join(src) if isinstance(src, list) else src))
    return out
