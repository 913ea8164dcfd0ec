"""What the instructor and the students read after a grading run.

Feedback per submission as text and HTML naming the cell and the check; a run summary table
(students, points, failures by reason, time, which rows were not sandboxed); late days from
the file time against ``--due`` with a stated policy; a manual overrides file merged in;
exports for a Canvas gradebook import and a Gradescope-style score upload.
"""

from __future__ import annotations

import csv
import datetime as dt
import html
import math
import re
import statistics
from collections import Counter
from pathlib import Path

REASONS = {"not_implemented": "not implemented", "timeout": "probe timed out", "raised": "student code raised",
           "delegated": "called the library's reference", "missing": "a required name is missing",
           "check_error": "CHECK ERROR (the check's fault)", "no_output": "did not run", "": "wrong answer",
           "override": "instructor override", "malformed": "output of the wrong form",
           "oversize": "output over the size budget", "tampered": "probe records tampered with"}


def _where(r: dict) -> str:
    return f" (check cell {r['cell']})" if isinstance(r.get("cell"), int) else " (no check cell: graded anyway)"


def check_lines(name: str, r: dict, where: str = "") -> list[str]:
    """One check's feedback: its mark, points and seed, then each sub-test (or its problems)."""
    from .checks import render

    return render(name, r, where)


def feedback_text(g) -> str:
    lines = [f"Student: {g.student}", f"Assignment: {g.assignment}", f"Submission: {Path(g.submission).name}",
             f"Score: {g.points:g}/{g.max_points:g}"]
    if g.late_days:
        lines.append(f"Late: {g.late_days} day(s); {g.penalty * 100:g} % of the points removed")
    if g.status:
        lines.append(f"Note: {g.status}")
    lines.append("")
    for name, r in g.results.items():
        lines += check_lines(name, r, _where(r))
    if g.errors:
        lines += ["", "Errors while running your notebook:"] + [f"  {e}" for e in g.errors]
    return for_terminal("\n".join(lines) + "\n")


def feedback_html(g) -> str:
    e = html.escape
    rows = []
    for name, r in g.results.items():
        color = "#1a7f37" if r["passed"] else "#cf222e"
        named = [x for x in r.get("subtests") or [] if x.get("name")]
        if named:
            msg = "<br>".join(
                f"<span style='color:{'#1a7f37' if x['passed'] else '#cf222e'}'>{'PASS' if x['passed'] else 'FAIL'}</span> "
                f"{e(x['name'])} ({x['points']:g}/{x['weight']:g})"
                + "".join(f"<br>&nbsp;&nbsp;&nbsp;&nbsp;{e(m)}" for m in str(x['message']).splitlines()) for x in named)
        else:
            msg = "<br>".join(e(m) for m in r["message"].splitlines())
        if r.get("seed") is not None:
            msg += f"<br><small>draws: seed {r['seed']}</small>"
        rows.append(f"<tr><td style='color:{color}'>{'PASS' if r['passed'] else 'FAIL'}</td><td><code>{e(name)}</code>"
                    f"</td><td>{e(_where(r).strip(' ()'))}</td><td>{r['points']:g}/{r['weight']:g}</td><td>{msg}</td></tr>")
    errors = "".join(f"<li><code>{e(x)}</code></li>" for x in g.errors)
    late = f"<p>Late: {g.late_days} day(s), {g.penalty * 100:g} % removed</p>" if g.late_days else ""
    note = f"<p><b>Note:</b> {e(g.status)}</p>" if g.status else ""
    return (f"<!doctype html><meta charset='utf-8'><title>{e(g.student)}: {e(g.assignment)}</title>"
            f"<h1>{e(g.assignment)}: {g.points:g}/{g.max_points:g}</h1><p>Student: {e(g.student)}; submission "
            f"{e(Path(g.submission).name)}</p>{late}{note}<table border=1 cellpadding=4 style='border-collapse:collapse'>"
            f"<tr><th></th><th>check</th><th>where</th><th>points</th><th>feedback</th></tr>{''.join(rows)}</table>"
            + (f"<h2>Errors while running your notebook</h2><ul>{errors}</ul>" if errors else "") + "\n")


def write_feedback(grades, directory) -> list[Path]:
    """``<student>__<assignment>.txt`` and ``.html``; a duplicate gets ``__2`` (nothing overwritten)."""
    from .grader import safe_name

    d = Path(directory)
    d.mkdir(parents=True, exist_ok=True)
    used: Counter = Counter()
    written = []
    for g in sorted(grades, key=lambda g: (g.student, g.assignment, str(g.submission))):
        base = f"{safe_name(g.student)}__{safe_name(g.assignment)}"
        used[base] += 1
        if used[base] > 1:
            base += f"__{used[base]}"
        for ext, text in ((".txt", feedback_text(g)), (".html", feedback_html(g))):
            (d / (base + ext)).write_text(text, encoding="utf-8")
            written.append(d / (base + ext))
    return written


def _listed(title: str, items: list[str], most: int = 200) -> list[str]:
    """A titled list, one item per line; past ``most`` the rest is counted, never dropped unsaid."""
    if not items:
        return []
    out = ["", f"{title} ({len(items)}):"] + [f"  {x}" for x in items[:most]]
    if len(items) > most:
        out.append(f"  ... and {len(items) - most} more")
    return out


def summary(grades, *, ignored=(), unknown=(), refused=(), regraded=(), seconds=0.0, mode="", jobs=1, due=None,
            late_penalty=0.0, limits_line: str = "") -> str:
    """The run summary table an instructor reads first (terminal-safe: a submission's text is escaped)."""
    lines = [f"Graded {len(grades)} submission(s) of {len({g.student for g in grades})} student(s) in {seconds:.1f} s "
             f"with -j {jobs}; sandbox: {mode}" + ("" if mode == "bwrap" else "  *** NOT SANDBOXED ***")]
    if limits_line:
        lines.append(limits_line)
    by_assignment: dict[str, list] = {}
    for g in grades:
        by_assignment.setdefault(g.assignment, []).append(g)
    lines.append("")
    lines.append(f"{'assignment':<28}{'n':>4}{'full':>6}{'zero':>6}{'median':>9}{'max':>6}{'s/sub':>8}"
                 f"{'judge s':>9}")
    for name, gs in sorted(by_assignment.items()):
        pts = [g.points for g in gs]
        top = max(g.max_points for g in gs)
        lines.append(f"{name:<28}{len(gs):>4}{sum(g.points == g.max_points > 0 for g in gs):>6}"
                     f"{sum(p == 0 for p in pts):>6}{statistics.median(pts):>9g}{top:>6g}"
                     f"{statistics.median(g.seconds for g in gs):>8.1f}"
                     f"{statistics.median(getattr(g, 'judge_seconds', 0.0) for g in gs):>9.2f}")
    judge_total = sum(getattr(g, "judge_seconds", 0.0) for g in grades)
    lines.append(f"judging took {judge_total:.2f} s in all (the grader's own time, outside the sandboxes)")
    reasons = Counter(REASONS.get(r.get("reason", ""), r.get("reason", "")) for g in grades
                      for r in g.results.values() if not r["passed"])
    if reasons:
        lines += ["", "failed checks by reason: " + ", ".join(f"{k} {v}" for k, v in reasons.most_common())]
    statuses = Counter(g.status for g in grades if g.status)
    lines += _listed("runs with a note, each distinct note once", [f"{v} x {k}" for k, v in statuses.most_common()])
    resumed = sum(g.resumed for g in grades)
    if resumed:
        lines += ["", f"reused from the journal, not run again (same notebook, same options, same checks; --restart "
                      f"grades them again): {resumed}"]
    lines += _listed("graded again although journaled, because what grades them changed",
                     [f"{path}: {'; '.join(changed)}" for path, changed in regraded])
    unsandboxed = [g for g in grades if g.sandbox == "process"]
    if unsandboxed:
        lines.append(f"*** NOT SANDBOXED ({len(unsandboxed)}): " + ", ".join(
            f"{g.student}/{g.assignment}" for g in unsandboxed) + " (install bubblewrap) ***")
    check_errors = sorted({e for g in grades for e in g.instructor})
    lines += _listed("CHECK ERRORS (the check's fault, not the students')", check_errors)
    lines += _listed("identity and run notes", [f"{g.student}: {n}" for g in grades for n in g.notes])
    lines += _listed("refused, never read", list(refused))
    lines += _listed("unknown assignment", [str(u) for u in unknown])
    lines += _listed("not notebooks, ignored", [str(i) for i in ignored])
    if due is not None:
        late = [g for g in grades if g.late_days]
        lines += ["", f"late policy: due {due.isoformat()}; file modification time decides; "
                      f"{late_penalty:g} % of the points removed per started day late (at most 100 %); "
                      f"{len(late)} late submission(s)"]
    return for_terminal("\n".join(lines) + "\n")


_UNSAFE = re.compile("[\x00-\x08\x0b-\x1f\x7f-\x9f\u2028\u2029\u202a-\u202e\u2066-\u2069]")


def for_terminal(text: str) -> str:
    """``text`` with control characters (escape sequences, carriage returns, bidi overrides) shown
    as ``\\x1b``-style escapes: a submission's string cannot move the cursor or recolour a terminal."""
    return _UNSAFE.sub(lambda m: f"\\x{ord(m.group()):02x}" if ord(m.group()) < 0x100 else f"\\u{ord(m.group()):04x}",
                       str(text))


def for_csv(text) -> str:
    """A CSV cell that a spreadsheet shows as text: control characters escaped, newlines flattened,
    and a leading = + - @ (a formula) neutralised with a quote, as OWASP recommends."""
    cell = for_terminal(str(text).replace("\r\n", " ").replace("\n", " ").replace("\t", " "))
    return "'" + cell if cell[:1] in ("=", "+", "-", "@") else cell


def apply_late(grades, due: dt.datetime, penalty_percent: float) -> None:
    """Late days from each file's modification time against ``due`` (local time if naive)."""
    due_ts = due.timestamp()
    for g in grades:
        try:
            mtime = Path(g.submission).stat().st_mtime
        except OSError:
            continue
        late_s = mtime - due_ts
        g.late_days = max(0, math.ceil(late_s / 86400)) if late_s > 0 else 0
        g.penalty = min(1.0, g.late_days * penalty_percent / 100.0)


def read_overrides(path) -> list[dict]:
    """Rows of ``student,check,points,comment`` (optional ``assignment``) with their values checked."""
    with open(path, newline="", encoding="utf-8") as fh:
        reader = csv.DictReader(fh)
        need = {"student", "check", "points", "comment"}
        if not reader.fieldnames or not need <= set(reader.fieldnames):
            raise ValueError(f"overrides file {path}: the header must have columns {', '.join(sorted(need))} "
                             f"(optional: assignment); got {reader.fieldnames}")
        rows = []
        for n, row in enumerate(reader, start=2):
            try:
                row["points"] = float(row["points"])
            except (TypeError, ValueError):
                raise ValueError(f"overrides file {path}, line {n}: points {row['points']!r} is not a number") from None
            rows.append(row)
    return rows


def apply_overrides(grades, rows) -> None:
    """Set a check's points by hand (capped at its weight) and append the comment to its feedback."""
    problems = []
    for row in rows:
        hits = [g for g in grades if g.student == row["student"] and row["check"] in g.results
                and (not row.get("assignment") or g.assignment == row["assignment"])]
        if not hits:
            problems.append(f"{row['student']}/{row['check']}")
            continue
        for g in hits:
            r = g.results[row["check"]]
            r["points"] = max(0.0, min(row["points"], r["weight"]))
            r["passed"] = r["points"] == r["weight"]
            r["message"] += f"\n[instructor] {row['comment']}" if row["comment"] else ""
            r["reason"] = "override"
    if problems:
        raise ValueError(f"overrides name no graded submission/check: {', '.join(problems)}; "
                         "check the student ids and check names against grades.csv")


def _by_student(grades) -> dict:
    out: dict[str, dict] = {}
    for g in grades:
        best = out.setdefault(g.student, {})
        if g.assignment not in best or g.points > best[g.assignment].points:
            best[g.assignment] = g  # a duplicate submission: the better one is exported (both in grades.csv)
    return out


def write_canvas(grades, path) -> None:
    """Canvas gradebook import: Student, ID, SIS User ID, SIS Login ID, Section, one column per assignment.

    Canvas matches rows on SIS Login ID (the student id here, i.e. the folder name); it ignores
    ID when empty. The points possible row comes second, as Canvas' own export has it.
    """
    by = _by_student(grades)
    names = sorted({g.assignment for g in grades})
    maxes = {a: max(g.max_points for g in grades if g.assignment == a) for a in names}
    with open(path, "w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(["Student", "ID", "SIS User ID", "SIS Login ID", "Section", *names])
        w.writerow(["    Points Possible", "", "", "", "", *[f"{maxes[a]:g}" for a in names]])
        for student in sorted(by):
            w.writerow([for_csv(student), "", "", for_csv(student), "", *[f"{by[student][a].points:g}" if a in by[student] else ""
                                                        for a in names]])


def write_gradescope(grades, path) -> None:
    """Gradescope-style upload: Name, SID, Email, then ``<assignment> Score`` / ``Max Points`` columns."""
    by = _by_student(grades)
    names = sorted({g.assignment for g in grades})
    with open(path, "w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(["Name", "SID", "Email", *[c for a in names for c in (f"{a} Score", f"{a} Max Points")]])
        for student in sorted(by):
            cells = []
            for a in names:
                g = by[student].get(a)
                cells += [f"{g.points:g}", f"{g.max_points:g}"] if g else ["", ""]
            w.writerow([for_csv(student), for_csv(student), "", *cells])
