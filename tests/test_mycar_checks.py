"""Chapter 3's checks: what the answer bank (tests/banks/ch03.py) does not show.

The bank grades right and wrong answers through the sandbox; here: the draws stay inside the
ranges the exercise text states and never hit a parameter's default, the quiz's feedback never
gives an answer away, malformed or hostile probe records are refused before a judge reads them,
and a constructor that raises is reported, not crashed on.
"""

from __future__ import annotations

import numpy as np
import pytest

from robocourse.grading.checks import get, judge, run_check
from robocourse.mycar import checks


@pytest.mark.parametrize("seed", range(30))
def test_draws_stay_in_the_stated_ranges_and_off_the_defaults(seed):
    rng = np.random.default_rng(seed)
    d = checks._drive_inputs(rng)
    assert 0.1 <= d["wheel_base"] <= 0.3 and d["publish_rate"] in (20.0, 40.0, 100.0)
    t = checks._teleop_inputs(rng)["params"]
    assert t["rate_hz"] in (8.0, 12.5, 20.0, 25.0) and t["hold_s"] in (0.4, 0.6, 0.8)
    assert 0.1 <= t["linear_speed"] <= 0.3 and 0.5 <= t["angular_speed"] <= 1.5
    n = checks._nav_inputs(rng)
    assert n["timeout"] in (1.5, 2.0, 2.5, 3.0) and 0.4 <= np.hypot(*n["reach"]) <= 0.8 + 1e-3
    assert 3 <= checks._led_inputs(rng)["led_count"] <= 7
    assert checks._dog_inputs(rng)["timeout"] in (0.125, 0.25, 0.5)


def test_quiz_partial_credit_and_feedback_never_reveals_an_answer():
    answers = {f: ("service" if a == "topic" else "topic") for f, a in checks.QUIZ.items()}
    answers.update(dict(list(checks.QUIZ.items())[:8]))        # 8 of 10 right
    r = run_check(get("ch03.quiz"), lambda: answers)
    assert r.points == pytest.approx(0.8 * r.weight)
    wrong = [f for f in checks.QUIZ if answers[f] != checks.QUIZ[f]]
    for feature in wrong:
        line = next(x for x in r.message.splitlines() if feature in x)
        assert "reconsider" in line and "(topic)" in line and "(service)" in line and "(action)" in line


@pytest.mark.parametrize("name, record, words", [
    ("ch03.teleop_node", {"built": True, "name": "teleop", "end": 5.0, "incompatible": [],
                          "messages": [[0.3, "nan", 0.0]] * 3, "events": [{"t": "soon", "key": "w"}]}, ""),
    ("ch03.drive_node", {"built": True, "end": 1.0, "sent": [], "wheels": [], "odom": [{"stamp": 1}],
                         "logs": [], "incompatible": []}, ""),
    ("ch03.launch_file", {"runs": {"true": {"nodes": "all of them"}}}, ""),
    ("ch03.navigation_action", {"built": True, "ready": True, "runs": {"reach": {"answered": 1}}}, ""),
    ("ch03.quiz", {"answers": {"camera images": "topic" * 100}, "given": "dict"}, "answers"),
])
def test_malformed_records_are_refused_before_judging(name, record, words):
    chk = get(name)
    r = judge(chk, chk.make_inputs(np.random.default_rng(0)), {"outputs": record})
    assert r.points == 0 and "does not have the form this check reads" in r.message and words in r.message


class Raises:
    def __init__(self, **kwargs):
        raise RuntimeError("my node is broken")


@pytest.mark.parametrize("name", ["ch03.drive_node", "ch03.led_service", "ch03.navigation_action", "ch03.teleop_node"])
def test_a_constructor_that_raises_is_reported(name):
    r = run_check(get(name), Raises, seed=0)
    assert r.points == 0 and "could not be created: RuntimeError: my node is broken" in r.message
