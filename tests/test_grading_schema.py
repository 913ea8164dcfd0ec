"""Probe-output schemas: the judge side reads only what fits, and says where and what did not."""

from __future__ import annotations

import numpy as np
import pytest

from robocourse.grading.schema import (
    Any,
    Array,
    Bool,
    Call,
    Dict,
    Hex,
    Int,
    List,
    Map,
    Number,
    Opt,
    SchemaError,
    Str,
    validate,
    validate_parts,
)


@pytest.mark.parametrize("node, value, fragment", [
    (Number(), True, "got bool True"),
    (Number(), "3", "got str '3'"),
    (Number(), "nan", "finite number, got nan"),
    (Number(), float("inf"), "finite number, got inf"),
    (Number(lo=0, hi=1), 1.5, "in [0, 1], got 1.5"),
    (Int(), 2.0, "expected an int, got float 2.0"),
    (Bool(), 1, "True or False, got int 1"),
    (Str(max_len=5), "x" * 6, "6 characters; at most 5"),
    (Str(choices=("a", "b")), "c", "one of ['a', 'b']"),
    (List(Int(), length=3), [1, 2], "expected 3 item(s)"),
    (List(Int(), max_len=2), [1, 2, 3], "3 items; at most 2"),
    (List(Int()), [1, "2", 3], "[1]: expected an int, got str '2'"),
    (Dict(a=Int()), {"a": 1, "b": 2}, "unexpected key(s) ['b']"),
    (Dict(a=Int()), {}, "missing key(s) ['a']"),
    (Map(Int(), keys=("x",)), {"y": 1}, "unexpected key(s)"),
    (Array((None, 2)), [[1, 2], [3]], "rows of different lengths"),
    (Array((None, 2)), [[1, 2, 3]], "expected length 2 on axis 1"),
    (Array((None,)), [1, True], "found bool True"),
    (Array((None,), integer=True), [1, 2.5], "expected ints, found float 2.5"),
    (Array((None,)), [1.0, "nan"], "expected finite numbers, found nan"),
    (Hex(max_bytes=2), "aabbcc", "at most 2 bytes"),
    (Hex(), "zz", "not a hex string"),
    (Any(max_items=10), list(range(20)), "larger than the 10 items"),
    (Call(Int()), {"value": "5", "type": "str"}, "your function returned str '5': expected an int"),
    (Call(Int(), raises=False), {"raised": "ValueError", "message": "no", "bases": ["ValueError"]},
     "your code raised 'ValueError': 'no'"),
    (Call(Int()), {"value": 1, "type": "int", "points": 99}, "expected a call record"),
    (Opt(Int()), "x", "None or an int"),
])
def test_refusals_name_the_place_and_the_rule(node, value, fragment):
    checked, problems = validate(node, value)
    assert checked is None and problems and fragment in " ".join(problems), problems


def test_accepted_values_are_normalised():
    node = Dict(n=Number(finite=False), a=Array((None, 2)), ints=Array((None,), integer=True), h=Hex(),
                c=List(Call(Number()), length="cases"), o=Opt(Int()))
    value = {"n": "nan", "a": [[1, 2.5], [3, 4]], "ints": [1, 2], "h": "0a0b", "o": None,
             "c": [{"value": 2, "type": "int"}, {"raised": "ValueError", "message": "bad", "bases": ["ValueError"]}]}
    checked, problems = validate(node, value, {"cases": [1, 2]})
    assert problems == []
    assert np.isnan(checked["n"]) and checked["h"] == b"\n\x0b" and checked["o"] is None
    assert checked["a"].dtype == np.float64 and checked["a"].shape == (2, 2)
    assert checked["ints"].dtype == np.int64
    assert checked["c"][1] == {"raised": "ValueError", "message": "bad", "bases": ["ValueError"]}


def test_an_empty_list_where_cases_were_sent_is_refused_not_passed():
    # "a loop over an empty list passes": the length comes from the inputs the grader sent
    _, problems = validate(Dict(cases=List(Call(), length="cases")), {"cases": []}, {"cases": [1, 2, 3]})
    assert problems == ["cases: expected 3 item(s) (one per case the grader sent), got 0"]


def test_parts_are_validated_on_their_own():
    node = Dict(good=List(Int()), bad=List(Int()))
    parts, problems = validate_parts(node, {"good": [1], "bad": ["x"]})
    assert parts == {"good": [1]} and list(problems) == ["bad"]
    _, problems = validate_parts(node, [1, 2])
    assert list(problems) == [""]  # not a dict at all: every part is invalid


def test_deep_nesting_and_huge_lists_are_bounded_without_recursion():
    deep: list = []
    for _ in range(5000):
        deep = [deep]
    _, problems = validate(Any(max_depth=20), deep)
    assert "20 levels" in problems[0]
    _, problems = validate(Array((None,), max_items=1000), list(range(2000)))
    assert "more than 1000 numbers" in problems[0]


def test_bad_schemas_are_the_authors_error():
    with pytest.raises(SchemaError, match="inputs have no list 'cases'"):
        validate(List(Int(), length="cases"), [1], {"other": []})
    with pytest.raises(SchemaError, match="schema node"):
        Dict(a=5)
    with pytest.raises(SchemaError, match="a tuple of lengths"):
        Array([None])
