"""What the instructor gets: identity rule, journal, CSV guard, late policy, overrides, LMS exports, summary.

Built on Grade objects directly (no notebook runs), so every rule is checked with exact numbers.
"""

from __future__ import annotations

import csv
import datetime as dt
import os
from pathlib import Path

import pytest

from robocourse.grading import report, sandbox
from robocourse.grading.grader import (
    Assignment,
    Grade,
    GradeList,
    Journal,
    expand,
    identify,
    write_csv,
)

ASSIGNMENTS = {"00_setup_exercises": Assignment("00_setup_exercises", Path("s.ipynb"), ["ch00.a"]),
               "01_realtime_exercises": Assignment("01_realtime_exercises", Path("r.ipynb"), ["ch01.a"])}


def _grade(student, assignment="00_setup_exercises", points=(2.0, 1.0), weights=(2.0, 3.0), path=None, **kw):
    g = Grade(student, Path(path or f"/subs/{student}/{assignment}.ipynb"), assignment, **kw)
    for i, (p, w) in enumerate(zip(points, weights, strict=True)):
        g.results[f"ch00.c{i}"] = {"points": p, "weight": w, "passed": p == w, "message": "m", "reason": "",
                                   "cell": 3 + i}
    return g


@pytest.mark.parametrize("rel, given, student, assignment, note", [
    ("carol/00_setup_exercises_dave.ipynb", "subs", "carol", "00_setup_exercises", "folder wins"),
    ("erin/00_setup_exercises_v2_final.ipynb", "subs", "erin", "00_setup_exercises", "suggests 'v2_final'"),
    ("ana/00_setup_exercises.ipynb", "subs", "ana", "00_setup_exercises", None),
    ("ana/deep/er/01_realtime_exercises.ipynb", "subs", "ana", "01_realtime_exercises", None),
    ("00_setup_exercises_dan.ipynb", "subs", "dan", "00_setup_exercises", None),
    ("solutions/00_setup_exercises.ipynb", None, "solutions", "00_setup_exercises", None),
    ("ana/homework.ipynb", "subs", "ana", None, None),
])
def test_identity_rule(rel, given, student, assignment, note):
    base = Path("/class")
    path = base / (given or "") / rel if given else base / rel
    got = identify(path, base / given if given else None, ASSIGNMENTS, None)
    assert got[:2] == (student, assignment)
    assert (note is None and got[2] == []) or any(note in n for n in got[2])


def test_expand_lists_non_notebooks_and_skips_checkpoints(tmp_path):
    (tmp_path / "a").mkdir()
    (tmp_path / "a" / "x.ipynb").write_text("{}")
    (tmp_path / "a" / "x.py").write_text("")
    (tmp_path / "a" / ".ipynb_checkpoints").mkdir()
    (tmp_path / "a" / ".ipynb_checkpoints" / "x-checkpoint.ipynb").write_text("{}")
    found, ignored = expand([tmp_path])
    assert [p.name for p, _ in found] == ["x.ipynb"] and [p.name for p in ignored] == ["x.py"]


def test_journal_survives_a_half_written_line_and_reloads(tmp_path):
    j = Journal(tmp_path / "g.csv.journal.jsonl")
    j.append("k1", _grade("ana"), {"time_limit": 60})
    with open(j.path, "a") as fh:
        fh.write('{"key": "k2", "grade": {"stud')  # the grader was killed mid-line
    again = Journal(j.path)
    assert list(again.done) == ["k1"]
    options, saved = again.done["k1"]
    assert options == {"time_limit": 60}
    g = Grade.from_json(saved)
    assert (g.student, g.points, g.max_points) == ("ana", 3.0, 5.0)


def test_csv_is_never_shrunk_without_force(tmp_path):
    out = tmp_path / "grades.csv"
    write_csv([_grade("ana"), _grade("ben")], out)
    with pytest.raises(ValueError, match="already holds 2 graded row.*only 1.*--force"):
        write_csv([_grade("ana")], out)
    assert len(list(csv.DictReader(out.open()))) == 2
    write_csv([_grade("ana")], out, force=True)
    assert [r["student"] for r in csv.DictReader(out.open())] == ["ana"]


def test_points_are_capped_at_the_weight():
    g = _grade("ana", points=(200.0, 1.0))
    assert g.points == 3.0 and g.max_points == 5.0


def test_late_policy_counts_started_days_from_file_time(tmp_path):
    due = dt.datetime(2026, 11, 20, 23, 59, tzinfo=dt.timezone.utc)
    files = {}
    for name, offset_h in (("early", -5), ("hour_late", 1), ("three_days", 49)):
        f = tmp_path / f"{name}.ipynb"
        f.write_text("{}")
        t = due.timestamp() + offset_h * 3600
        os.utime(f, (t, t))
        files[name] = _grade(name, path=f)
    report.apply_late(list(files.values()), due, 10.0)
    assert {n: (g.late_days, g.penalty) for n, g in files.items()} == {
        "early": (0, 0.0), "hour_late": (1, 0.1), "three_days": (3, 0.3)}
    assert files["three_days"].points == pytest.approx(3.0 * 0.7)
    text = report.summary(list(files.values()), due=due, late_penalty=10.0)
    assert "10 % of the points removed per started day late" in text and "2 late submission(s)" in text


def test_overrides_set_points_capped_and_comment_added(tmp_path):
    f = tmp_path / "overrides.csv"
    f.write_text("student,check,points,comment\nana,ch00.c1,2.5,regraded by hand: partial credit\n"
                 "ben,ch00.c0,99,typo in the checker\n")
    grades = [_grade("ana"), _grade("ben")]
    report.apply_overrides(grades, report.read_overrides(f))
    assert grades[0].results["ch00.c1"]["points"] == 2.5 and "partial credit" in grades[0].results["ch00.c1"]["message"]
    assert grades[1].results["ch00.c0"]["points"] == 2.0  # capped at the weight
    f.write_text("student,check,points,comment\nzed,ch00.c0,1,x\n")
    with pytest.raises(ValueError, match="zed/ch00.c0"):
        report.apply_overrides(grades, report.read_overrides(f))
    f.write_text("who,points\nana,1\n")
    with pytest.raises(ValueError, match="header must have columns"):
        report.read_overrides(f)
    f.write_text("student,check,points,comment\nana,ch00.c0,lots,x\n")
    with pytest.raises(ValueError, match="line 2: points 'lots'"):
        report.read_overrides(f)


def test_canvas_and_gradescope_exports(tmp_path):
    grades = [_grade("ana"), _grade("ana", "01_realtime_exercises", points=(2.0, 3.0)), _grade("ben", points=(0.0, 0.0)),
              _grade("ben", points=(2.0, 0.0), path="/subs/ben/00_setup_exercises_copy.ipynb")]
    report.write_canvas(grades, tmp_path / "canvas.csv")
    rows = list(csv.reader((tmp_path / "canvas.csv").open()))
    assert rows[0] == ["Student", "ID", "SIS User ID", "SIS Login ID", "Section", "00_setup_exercises",
                       "01_realtime_exercises"]
    assert rows[1][5:] == ["5", "5"] and rows[1][0].strip() == "Points Possible"
    assert rows[2] == ["ana", "", "", "ana", "", "3", "5"]
    assert rows[3] == ["ben", "", "", "ben", "", "2", ""]  # the better of two duplicates
    report.write_gradescope(grades, tmp_path / "gs.csv")
    rows = list(csv.DictReader((tmp_path / "gs.csv").open()))
    assert rows[0]["SID"] == "ana" and rows[0]["00_setup_exercises Score"] == "3"
    assert rows[0]["01_realtime_exercises Max Points"] == "5"


def test_feedback_names_cell_and_check_and_never_overwrites(tmp_path):
    grades = [_grade("ana"), _grade("ana", path="/subs/ana/00_setup_exercises_v2.ipynb")]
    grades[0].results["ch00.c1"]["message"] = "first problem\nsecond problem"
    written = report.write_feedback(grades, tmp_path)
    assert len(written) == 4
    text = (tmp_path / "ana__00_setup_exercises.txt").read_text()
    assert "[FAIL] ch00.c1 (check cell 4) (1/3): 2 problems" in text and "    - second problem" in text
    html = (tmp_path / "ana__00_setup_exercises.html").read_text()
    assert "<code>ch00.c1</code>" in html and "check cell 4" in html


def test_summary_table_counts_and_flags_unsandboxed():
    grades = GradeList([_grade("ana", sandbox="bwrap"), _grade("ben", points=(0.0, 0.0), sandbox="process"),
                        _grade("cho", points=(2.0, 3.0), sandbox="bwrap")])
    grades[1].results["ch00.c0"]["reason"] = "not_implemented"
    grades[1].results["ch00.c1"]["reason"] = "not_implemented"
    text = report.summary(grades, seconds=12.0, mode="bwrap", jobs=2)
    line = next(x for x in text.splitlines() if x.startswith("00_setup_exercises"))
    assert line.split() == ["00_setup_exercises", "3", "1", "1", "3", "5", "0.0", "0.00"]
    assert "not implemented 2" in text and "NOT SANDBOXED (1): ben/00_setup_exercises" in text


def test_sandbox_limits_refuse_bad_values():
    with pytest.raises(ValueError, match="time limit must be > 0"):
        sandbox.Limits(time_s=0)
    with pytest.raises(ValueError, match="process limit must be >= 4"):
        sandbox.Limits(max_processes=1)
    with pytest.raises(ValueError, match="sandbox mode must be"):
        sandbox.choose_mode("docker")


def test_bounded_reader_refuses_symlinks_and_caps_bytes(tmp_path):
    big = tmp_path / "big"
    big.write_bytes(b"x" * 10_000)
    assert sandbox.read_bounded(big, 100) == ("x" * 100, True)
    (tmp_path / "link").symlink_to("/etc/hostname")
    assert sandbox.read_bounded(tmp_path / "link", 100) == ("", False)


def test_a_grader_failure_is_reported_and_not_journaled(tmp_path, root, monkeypatch):
    from robocourse.grading import grader

    def broken(*a, **k):
        raise OSError("bwrap vanished")

    monkeypatch.setattr(grader, "probe_submission", broken)
    out = tmp_path / "g.csv"
    [g] = grader.grade([str(root / "solutions" / "00_setup_exercises.ipynb")], solutions_dir=root / "solutions",
                       out=out)
    assert "the grader failed (OSError: bwrap vanished)" in g.status and g.instructor
    assert not Path(f"{out}.journal.jsonl").exists() or Path(f"{out}.journal.jsonl").read_text() == ""
