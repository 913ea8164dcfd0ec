"""Chapter markdown holds no measured figure and no verdict about a measurement (issue 25).

A measured number or verdict is printed by a code cell from the measurement
(``robocourse.notebook.claim``); markdown holds definitions, settings and labelled quotes. The
rule and its allowed forms are in ``robocourse.notebook.markdown_rules``; in short, in markdown:

- a value the code sets, or a definition: write it as code or math (``a `1 kHz` loop``,
  ``$L = 0.5$ m``) or as an assignment (``dt = 1 ms``);
- a figure from elsewhere: label it with its source, ``(source: ROS 2 docs, ...)`` or
  ``quoted from ...``;
- anything measured on the student's machine: a code cell renders it (``claim(...)``).

KNOWN VIOLATIONS, READ THIS BEFORE EDITING THE LIST BELOW. ``KNOWN_VIOLATIONS`` lists, per
notebook, the exact sentences (as ``markdown_rules.sentences`` splits them, whitespace collapsed)
that broke the rule when the rule was introduced. The list may only SHRINK: when you fix a
sentence (rewrite it, render it from the data, mark a setting as code, label a quote), delete
its entry; the test fails on an entry that no longer breaks the rule, so a stale entry cannot
linger. Never add an entry to make a new sentence pass: fix the sentence.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from robocourse.notebook.markdown_rules import (
    check_markdown,
    check_sentence,
    notebook_violations,
    sentences,
)

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOKS = sorted(p.relative_to(ROOT).as_posix() for p in
                   [*ROOT.glob("chapters/*.ipynb"), *ROOT.glob("solutions/*.ipynb")])

KNOWN_VIOLATIONS: dict[str, list[str]] = {}


# -- the rule itself: what it catches and what it allows ------------------------------------------

@pytest.mark.parametrize("sentence,kind", [
    ("with a 10 µs median and a millisecond worst case, the distribution is one bar.", "figure"),
    ("The loop woke 88 us late on average.", "figure"),
    ("It took 2.5 ms.", "figure"),
    ("A ratio near 100% means nothing was lost.", "figure"),
    ("The arm moved 1.5 cm.", "figure"),
    ("The fingers rotated the box by 41° and pushed with 112 N.", "figure"),
    ("The gap was 2-3 ms.", "figure"),
    ("Inference in the thread made the loop 29.7x slower.", "figure"),
    ("Trusting the mean: the mean met the budget in 0 of 9 runs.", "run count"),
    ("spin is punctual, and it burns all the CPU time it gets.", "verdict"),
    ("The hybrid wait has a lower median latency than sleep.", "verdict"),
    ("Heavier filtering gives a larger final distance than light filtering.", "verdict"),
    ("SCHED_FIFO makes no difference to the tail here.", "verdict"),
])
def test_the_rule_catches_measured_figures_and_verdicts(sentence, kind):
    found = check_sentence(sentence)
    assert kind in [v.kind for v in found], (sentence, found)


@pytest.mark.parametrize("sentence", [
    "The loop holds the mutex for `2 ms` at a time in a `1 kHz` loop.",            # settings as code
    "Feed both a constant error at dt = 1 ms and period = 1 ms.",                  # assignments
    "The pendulum ($L = 0.5$ m, $m = 0.01$ kg) is linearised about upright.",      # math
    "A stock kernel reached 2.75 ms (source: ROS 2 docs, Real-time programming in ROS 2).",
    "PREEMPT_RT bounds it to about 130 us, quoted from the ROS 2 real-time benchmark page.",
    "Whether spin's p99 came out lower than sleep's here is printed above.",      # holds either way
    "If the hog catches the holder, the loop waits longer than the hold.",         # a condition
    "A real-time thread has no timer slack, so its sleep is not stretched.",       # no comparison
    "Chapter 2 builds on section 3 and exercise 4 (2 points).",                    # numbers without units
    "```\nrobocourse rttest -i 20000 -s fifo\n```",                                 # fenced code
])
def test_the_rule_allows_definitions_settings_quotes_and_hedged_prose(sentence):
    assert check_markdown(sentence) == [], check_markdown(sentence)


def test_sentences_split_on_sentence_ends_list_items_and_headings():
    md = "## 2.5 Heading\n\nFirst one. Second\none continues.\n- item `a. B` stays\n- next: e.g. this"
    assert sentences(md) == ["## 2.5 Heading", "First one.", "Second one continues.", "- item `a. B` stays",
                             "- next: e.g. this"]


def test_a_quote_label_needs_a_source():
    assert check_sentence("It took 2.75 ms (source: ).")             # an empty label is no label
    assert not check_sentence("It took 2.75 ms (source: ROS docs).")


# -- every chapter and solution notebook ----------------------------------------------------------

def test_the_known_list_names_only_existing_notebooks():
    assert set(KNOWN_VIOLATIONS) <= set(NOTEBOOKS), set(KNOWN_VIOLATIONS) - set(NOTEBOOKS)


@pytest.mark.parametrize("notebook", NOTEBOOKS)
def test_markdown_holds_no_measured_figure_or_verdict(notebook):
    found = notebook_violations(ROOT / notebook)
    known = KNOWN_VIOLATIONS.get(notebook, [])
    new = sorted({str(v) for v in found if v.sentence not in known})
    assert not new, (f"{notebook}: markdown states a measured figure or verdict (render it with "
                     "robocourse.notebook.claim, write a setting as `code` or `name = value`, or label a quote "
                     "'(source: ...)'):\n  " + "\n  ".join(new))
    fixed = [s for s in known if s not in {v.sentence for v in found}]
    assert not fixed, (f"{notebook}: these known violations are fixed (or reworded): delete them from "
                       "KNOWN_VIOLATIONS in tests/test_chapter_markdown.py:\n  " + "\n  ".join(fixed))
