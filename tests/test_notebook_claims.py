"""robocourse.notebook.claim: sentences worded from the numbers, verdicts only the numbers support."""

from __future__ import annotations

import importlib.util
import json
import math
from pathlib import Path

import pytest

from robocourse.bus.logging import LoggingSeverity, get_console_level
from robocourse.notebook import claim, log_level, progress, say
from robocourse.notebook.claims import (
    METADATA_KEY,
    Claim,
    chance_apart,
    fewest_rounds,
    recorded_claims,
    write_claims,
)

ROOT = Path(__file__).resolve().parents[1]


def test_chance_that_two_sets_come_apart_by_luck():
    assert chance_apart(1, 1) == 1.0
    assert chance_apart(2, 2) == pytest.approx(1 / 3)
    assert chance_apart(3, 3) == pytest.approx(0.1)
    assert chance_apart(5, 5) == pytest.approx(2 / 252)
    assert fewest_rounds() == 3 and fewest_rounds(0.01) == 5


def test_lower_only_when_every_round_is_below_every_round_of_the_other():
    c = claim("wake-up p50", {"hybrid": [12e3, 11e3, 13e3], "sleep": [80e3, 95e3, 88e3]}, unit="us", scale=1e-3,
              each="5000 iterations")
    assert c.verdict == "lower" and c.kind == "comparison"
    assert c.text == ("**wake-up p50** (median [lowest–highest] of 3 rounds, each 5000 iterations): "
                      "hybrid 12.0 us [11.0–13.0], sleep 88.0 us [80.0–95.0]; "
                      "**hybrid lower than sleep** in every round (the ranges do not overlap).")
    assert claim("p50", {"a": [5, 6, 7], "b": [1, 2, 3]}).verdict == "higher"


def test_overlapping_ranges_cannot_tell_and_say_how_the_rounds_went():
    c = claim("p99", {"a": [10, 30, 12, 14, 11], "b": [20, 21, 22, 19, 25]})
    assert c.verdict == "cannot tell"
    assert "**this run cannot tell** a from b: their ranges overlap; a was lower in 4 of 5 rounds" in c.text


@pytest.mark.parametrize("na,nb", [(1, 1), (2, 2), (2, 3), (1, 8)])
def test_too_few_rounds_cannot_tell_even_when_apart(na, nb):
    c = claim("p50", {"a": [1.0 + i / 100 for i in range(na)], "b": [100.0 + i for i in range(nb)]})
    assert c.verdict == "cannot tell"
    assert "too few" in c.text and "it takes 3 rounds of each" in c.text
    if na == nb == 1:
        assert "one run of each is too few" in c.text and "come out apart always by chance" in c.text
    if (na, nb) == (2, 2):
        assert "2 rounds of each are too few" in c.text and "33% of the time" in c.text


def test_one_run_against_many_rounds_is_enough_when_it_is_beyond_all_of_them():
    # one value outside 30 others of the same distribution: chance 2/31 < 0.1
    assert claim("p50", {"a": [1.0], "b": [100.0 + i for i in range(30)]}).verdict == "lower"


def test_equal_when_every_value_is_the_same():
    c = claim("overruns", {"a": [0, 0, 0], "b": [0, 0, 0]}, digits=0)
    assert c.verdict == "equal" and "a and b **equal** in every round" in c.text


def test_limit_within_above_and_mixed():
    within = claim("max", [30e3, 40e3, 20e3], unit="us", scale=1e-3, limit=50e3, limit_name="the 5 % budget")
    assert within.verdict == "within" and "**within the 5 % budget** (50.0 us) in every round" in within.text
    above = claim("max", 1.2e6, unit="us", scale=1e-3, limit=50e3, limit_name="the budget",
                  each="one run of 5000 iterations")
    assert above.verdict == "above"
    assert above.text == "**max** (one run of 5000 iterations): 1200.0 us; **above the budget** (50.0 us)."
    mixed = claim("max", [60e3, 40e3, 70e3], unit="us", scale=1e-3, limit=50e3)
    assert mixed.verdict == "mixed" and "above the limit (50.0 us) in 2 of 3 rounds, within it in the rest" in mixed.text
    assert claim("max", [50.0], limit=50.0).verdict == "within"   # at the limit is within it


def test_figures_without_a_verdict():
    c = claim("CPU used", {"sleep": 1.24, "spin": 99.8, "hybrid": 20.0}, unit="%")
    assert c.verdict == "measured" and c.text == "**CPU used** (one run): sleep 1.2 %, spin 99.8 %, hybrid 20.0 %."
    two = claim("faults", {"loop": 4000, "pool": 3}, digits=0, compare=False)
    assert two.verdict == "measured" and "loop 4000, pool 3." in two.text
    uneven = claim("t", {"a": [1, 2], "b": [3, 4, 5]}, compare=False)
    assert "a 1.5 [1.0–2.0] (2 rounds), b 4.0 [3.0–5.0] (3 rounds)" in uneven.text


def test_a_record_rebuilds_the_same_sentence_and_verdict():
    for c in (claim("p50", {"a": [1, 2, 3], "b": [7, 8, 9]}, unit="us", scale=1e-3, each="x"),
              claim("max", [5, 60, 7], limit=50, limit_name="the budget"),
              claim("cpu", {"a": 1, "b": 2, "c": 3}, unit="%", digits=0)):
        rec = json.loads(json.dumps(c.record))          # what the notebook's metadata holds
        again = Claim.from_record(rec)
        assert (again.text, again.verdict) == (rec["text"], rec["verdict"]) == (c.text, c.verdict)


def test_a_doctored_record_is_caught():
    c = claim("p50", {"a": [1, 2, 3], "b": [7, 8, 9]})
    rec = json.loads(json.dumps(c.record))
    rec["values"]["a"] = [1, 8, 3]                      # the numbers no longer support "lower"
    assert Claim.from_record(rec).verdict == "cannot tell" != rec["verdict"]


def test_display_carries_the_records_in_metadata():
    c = claim("p50", {"a": [1, 2, 3], "b": [7, 8, 9]})
    data, meta = c._repr_mimebundle_()
    assert data["text/markdown"] == c.text and meta[METADATA_KEY] == [c.record]


def test_say_shows_claims_and_sentences_as_one_list(monkeypatch):
    shown = []
    import IPython.display

    monkeypatch.setattr(IPython.display, "display", lambda obj, **kw: shown.append(obj._repr_mimebundle_()))
    a, b = claim("x", [1.0]), claim("y", {"p": [1, 2, 3], "q": [4, 5, 6]})
    say(a, "because of the slack", b)
    (data, meta), = shown
    assert data["text/markdown"] == f"- {a.text}\n- because of the slack\n- {b.text}"
    assert [r["what"] for r in meta[METADATA_KEY]] == ["x", "y"]
    nb = {"cells": [{"cell_type": "code", "outputs": [{"output_type": "display_data", "data": data,
                                                        "metadata": meta}]}]}
    recs = recorded_claims(nb)
    assert [r["text"] for r in recs] == [a.text, b.text] and all(r["text"] in r["_shown"] for r in recs)


def _executed(*cells):
    """A notebook as nbclient leaves it: markdown cells and code cells whose outputs are claims."""
    nb = {"cells": []}
    for cell in cells:
        if isinstance(cell, str):
            nb["cells"].append({"cell_type": "markdown", "source": cell})
        else:
            data, meta = cell._repr_mimebundle_()
            nb["cells"].append({"cell_type": "code", "source": "", "outputs": [
                {"output_type": "display_data", "data": data, "metadata": meta}]})
    return nb


def test_claims_written_with_keys_cells_and_sections_then_listed_quiet_beside_loaded(tmp_path):
    spec = importlib.util.spec_from_file_location("notebook_times", ROOT / "benchmarks/notebook_times.py")
    times = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(times)
    quiet = _executed("# Chapter\n## 1. Waiting", claim("p50", {"a": [1, 2, 3], "b": [7, 8, 9]}),
                      "## 2. Again", claim("p50", {"a": [1, 2, 3], "b": [2, 3, 4]}), claim("max", 5.0),
                      claim("p50", {"c": [1, 2, 3], "b": [2, 3, 4]}))
    loaded = _executed("# Chapter\n## 1. Waiting", claim("p50", {"a": [1, 2, 3], "b": [2, 8, 9]}),
                       "## 2. Again", claim("p50", {"a": [1, 2, 3], "b": [2, 3, 4]}))
    out = write_claims(tmp_path, "01_x", "quiet", quiet, loadavg_before=0.5, loadavg_after=0.7, seconds=3.0)
    rows = json.loads(out.read_text())["claims"]
    assert [(r["key"], r["cell"], r["section"], r["verdict"]) for r in rows] == [
        ("p50 [a / b]", 1, "1. Waiting", "lower"), ("p50 [a / b] #2", 3, "2. Again", "cannot tell"),
        ("max", 4, "2. Again", "measured"), ("p50 [c / b]", 5, "2. Again", "cannot tell")]
    write_claims(tmp_path, "01_x", "loaded", loaded, loadavg_after=2.5)
    (tmp_path / "old.json").write_text("[]")          # a file of the older list format is skipped
    text = times.write_list(tmp_path).read_text()
    assert "- quiet run: 3.0 s, load average 0.5 before, 0.7 after, 4 claims" in text
    assert "- loaded run: load average 2.5 after, 2 claims" in text
    assert "### `p50 [a / b]` (cell 1, 1. Waiting): lower / cannot tell  **(verdict differs)**" in text
    assert "### `p50 [a / b] #2` (cell 3, 2. Again): cannot tell / cannot tell\n" in text
    assert f"- quiet: {claim('max', 5.0).text}\n- loaded: (not rendered in this run)" in text


@pytest.mark.parametrize("args,kwargs,fragment", [
    (("", [1.0]), {}, "what='' must name the measured quantity"),
    (("p50", []), {}, "no values for 'p50'"),
    (("p50", {"a": [1.0, math.nan]}), {}, "contain NaN or inf"),
    (("p50", {}), {}, "empty dict"),
    (("p50", "12 us"), {}, "must be a number"),
    (("p50", {"a": [1.0], "b": [2.0]}), {"limit": 3.0}, "limit= compares one case"),
    (("p50", [1.0]), {"digits": 9}, "digits=9"),
    (("p50", [1.0]), {"scale": 0}, "scale=0"),
    (("p50", [1.0]), {"limit": math.inf}, "limit=inf"),
])
def test_bad_input_names_the_value_and_the_fix(args, kwargs, fragment):
    with pytest.raises(ValueError, match=fragment.replace("(", r"\(").replace(")", r"\)")):
        claim(*args, **kwargs)


def test_say_refuses_what_it_cannot_show():
    with pytest.raises(ValueError, match="at least one claim"):
        say()
    with pytest.raises(ValueError, match="neither a claim nor a sentence"):
        say(3.5)


def test_log_level_hides_quieter_lines_but_keeps_them(capsys):
    from robocourse.bus import Context
    from robocourse.bus.node import Node

    ctx = Context(use_sim_time=True)
    node = Node("talker", context=ctx)
    before = get_console_level()
    with log_level("WARN"):
        node.get_logger().info("loading controller")
        node.get_logger().warning("deadline missed")
    node.get_logger().info("after")
    out = capsys.readouterr()
    printed = out.out + out.err
    assert "loading controller" not in printed and "deadline missed" in printed and "after" in printed
    assert [r.msg for r in ctx.log_records] == ["loading controller", "deadline missed", "after"]
    assert get_console_level() == before
    with pytest.raises(ValueError, match="log level 'LOUD'"):
        log_level("LOUD")
    log_level("ERROR").restore()
    assert get_console_level() == before == LoggingSeverity.UNSET
    ctx.shutdown()


def test_progress_line_ends_as_a_summary_not_a_frozen_bar(progress_updates):
    updates = progress_updates
    with progress(3, "runs") as bar:
        for _ in range(3):
            bar.update()
    assert updates[-1]["text/plain"].startswith("runs: 3 of 3 in ") and "<progress" not in updates[-1]["text/html"]
    with pytest.raises(ValueError, match="total must be a positive int"):
        progress(0)
