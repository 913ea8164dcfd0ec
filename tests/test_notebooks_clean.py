"""Committed notebooks carry no outputs or execution counts, and use the course kernel."""

from __future__ import annotations

import json

import pytest

from conftest import ROOT

NOTEBOOKS = sorted(p for d in ("chapters", "solutions", "exercises") for p in (ROOT / d).glob("*.ipynb"))


def test_there_are_notebooks():
    assert any(p.parent.name == "chapters" for p in NOTEBOOKS)


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: f"{p.parent.name}/{p.name}")
def test_notebook_is_stripped(path):
    nb = json.loads(path.read_text())
    dirty = [i for i, c in enumerate(nb["cells"]) if c["cell_type"] == "code" and (c.get("outputs") or c.get("execution_count"))]
    assert not dirty, f"{path.name}: cells {dirty} carry outputs or execution counts; clear them before committing"
    assert nb["metadata"]["kernelspec"]["name"] == "robocourse", f"{path.name}: use the 'Python (robocourse)' kernel"


@pytest.mark.parametrize("path", [p for p in NOTEBOOKS if p.parent.name == "chapters"], ids=lambda p: p.name)
def test_chapter_names_follow_the_map(path):
    assert path.name[:2].isdigit() and path.name[2] == "_", f"{path.name}: chapters are named NN_topic.ipynb"
