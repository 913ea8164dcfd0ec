"""The student edition of the course (``robocourse release DIR``): nbgrader's release step.

nbgrader releases the *generated* student notebooks (solutions replaced by stubs, hidden tests
removed) and keeps the source notebooks to the instructor; otter's ``assign`` does the same
with a ``student/`` and an ``autograder/`` folder. Here the edition is a whole course folder a
student clones: chapters, generated exercises, the library (with the checks behind the instant
feedback), README, Makefile, requirements, benchmarks and the tests that make sense for a
student, without solutions/, instructor-only tests and hidden checks.

What goes in is decided by :data:`MANIFEST`, an ordered list of include/exclude rules on paths
relative to the course folder: the first rule that matches a file decides, and a file no rule
matches stays out (so a new folder of the instructor's, a grades.csv, a submissions/ folder, is
never published by accident; it is listed as left out). Globs: ``*`` within a path part, ``**``
across parts. A rule may also look at content (:attr:`Rule.mentions`): a test or benchmark that
reads ``solutions/`` needs the instructor's notebooks and is left out.

Before anything is written, every ``### BEGIN SOLUTION ... ### END SOLUTION`` block of every
solution notebook is searched for in every file of the edition (:func:`find_leaks`): a file
holding most of a block's non-trivial lines, or two of them in a row, stops the release with the
file named, so a new test that carries a reference answer cannot slip through a rule.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from functools import cache
from pathlib import Path

from robocourse.grading import exercises

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10: the rewrite is still checked by its regex, not read back
    tomllib = None

MARKER_FILE = ".robocourse-edition.json"
EDITION_TESTPATHS = ("tests", "chapters", "exercises")
INSTRUCTOR_ONLY = re.compile(r"<!--\s*instructor-only\s*-->.*?<!--\s*/instructor-only\s*-->\n?", re.S)
# folders never walked: environments, caches, version control (nothing in them is course material)
PRUNE = {".git", ".venv", "venv", "__pycache__", ".ipynb_checkpoints", ".pytest_cache", ".ruff_cache",
         ".hypothesis", "node_modules", "build", "dist"}


@dataclass(frozen=True)
class Rule:
    """``include`` or ``exclude`` the paths matching ``pattern`` (and containing ``mentions``)."""

    action: str
    pattern: str
    why: str
    mentions: str | None = None  # a regex the file's text must contain for the rule to apply

    def __post_init__(self):
        if self.action not in ("include", "exclude"):
            raise ValueError(f"Rule action {self.action!r}: use 'include' or 'exclude'")

    def matches(self, rel: str, text: str | None) -> bool:
        if not _glob_regex(self.pattern).fullmatch(rel):
            return False
        return self.mentions is None or (text is not None and re.search(self.mentions, text) is not None)


READS_SOLUTIONS = r"""(?<![\w.])solutions(/|["'])|SOLUTIONS\b|solutions_dir"""

MANIFEST: tuple[Rule, ...] = (
    # never, wherever they are
    Rule("exclude", "solutions/**", "the instructor's notebooks, with the answers"),
    Rule("exclude", "**/hidden_checks/**", "instructor-only checks (robocourse grade --checks DIR)"),
    Rule("exclude", "**/*.egg-info/**", "build metadata of the editable install"),
    Rule("exclude", "**/*.pyc", "bytecode"),
    Rule("exclude", "**/*.mcap", "recordings made while running the course"),
    # what a student works with
    Rule("include", "README.md", "rewritten: 'For students' first, instructor sections removed"),
    Rule("include", "Makefile", "make lab / make test"),
    Rule("include", "requirements.txt", "the pinned stack"),
    Rule("include", "pyproject.toml", "rewritten: pytest collects tests, chapters and exercises"),
    Rule("include", ".gitignore", "keeps .venv and outputs out of the student's commits"),
    Rule("include", ".ci/run", "the same `make test` in CI"),
    Rule("include", "chapters/*.ipynb", "the lecture notebooks"),
    Rule("include", "exercises/*.ipynb", "generated from solutions/ (checked in sync first)"),
    Rule("include", "lib/**", "the library, with the checks behind the instant feedback"),
    Rule("exclude", "benchmarks/**", "benchmarks that read solutions/", mentions=READS_SOLUTIONS),
    Rule("include", "benchmarks/**", "measured figures a student can reproduce"),
    # tests: the library's unit tests and notebook execution, not the instructor's
    Rule("exclude", "tests/test_release.py", "builds an edition from solutions/"),
    Rule("exclude", "tests/banks/**", "answer banks: their correct answers are solutions"),
    Rule("exclude", "tests/banks_pending/**", "answer banks not yet in the suite: their correct answers are solutions"),
    Rule("exclude", "tests/test_banks.py", "grades the answer banks against solutions/"),
    Rule("exclude", "tests/test_notebooks_clean.py", "committed notebooks are stripped; a student's saved work is not"),
    Rule("exclude", "tests/test_chapters_under_load.py",
         "the course's one CI run of the chapters (under load); the edition's pytest runs them with nbmake"),
    Rule("exclude", "tests/**", "tests that read solutions/ (exercise sync, solutions grade, grader)",
         mentions=READS_SOLUTIONS),
    Rule("include", "tests/test_grading_checks.py", "the check machinery, on toy checks"),
    Rule("exclude", "tests/test_*_checks.py", "a chapter's checks fed reference answers"),
    Rule("include", "tests/**", "unit tests of the library, the lab"),
)


@cache
def _glob_regex(pattern: str) -> re.Pattern:
    out, i = [], 0
    while i < len(pattern):
        if pattern.startswith("**/", i):
            out.append("(?:.*/)?")
            i += 3
        elif pattern.startswith("/**", i) and i + 3 == len(pattern):
            out.append("/.*")
            i += 3
        elif pattern[i] == "*":
            out.append("[^/]*")
            i += 1
        elif pattern[i] == "?":
            out.append("[^/]")
            i += 1
        else:
            out.append(re.escape(pattern[i]))
            i += 1
    return re.compile("".join(out))


def _read_text(data: bytes) -> str:
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        return data.decode("latin-1")


@dataclass
class Selection:
    """The files of an edition (path -> bytes) and what was left out, with the rule's reason."""

    files: dict[str, bytes] = field(default_factory=dict)
    left_out: dict[str, str] = field(default_factory=dict)  # path -> why

    def left_out_summary(self) -> list[tuple[str, int, str]]:
        """(top-level entry, files, reason) for everything left out, grouped by entry and reason."""
        groups: dict[tuple[str, str], int] = {}
        for rel, why in self.left_out.items():
            top = rel.split("/")[0] + ("/" if "/" in rel else "")
            key = (rel if top.startswith(("tests/", "benchmarks/")) else top, why)
            groups[key] = groups.get(key, 0) + 1
        return sorted((k[0], n, k[1]) for k, n in groups.items())


def walk(root: Path) -> Iterable[str]:
    """Every file under ``root`` as a posix path relative to it, sorted, pruned folders skipped."""
    for dirpath, dirnames, filenames in os.walk(root):
        dirnames[:] = sorted(d for d in dirnames if d not in PRUNE)
        for name in sorted(f for f in filenames if f not in PRUNE):  # a worktree's .git is a file
            yield Path(dirpath, name).relative_to(root).as_posix()


def select(root: Path | str, manifest: Iterable[Rule] = MANIFEST) -> Selection:
    """Apply ``manifest`` to the course folder ``root`` (first matching rule wins)."""
    root = Path(root)
    rules = tuple(manifest)
    sel = Selection()
    for rel in walk(root):
        data = (root / rel).read_bytes()
        text = _read_text(data) if any(r.mentions for r in rules) else None
        rule = next((r for r in rules if r.matches(rel, text)), None)
        if rule is not None and rule.action == "include":
            sel.files[rel] = data
        else:
            sel.left_out[rel] = rule.why if rule else "no rule includes it"
    return sel


# --- solution blocks and the leak search -------------------------------------------------------

_TRIVIAL = re.compile(r"(?:return|raise|yield|pass|break|continue|else:|try:)(?: [\w.]+(?:\(\))?)?|[\s\W]*")


def normalize(line: str) -> str:
    """A code line as compared: comment and outer whitespace dropped, inner runs of spaces folded."""
    code = line.split("#", 1)[0] if "#" in line and not re.search(r"""["'][^"']*#""", line) else line
    return " ".join(code.split())


def significant(line: str) -> bool:
    """A line that says something about the answer (not ``return False``, ``}``, ``pass``)."""
    text = normalize(line)
    return len(text) >= 12 and not _TRIVIAL.fullmatch(text)


@dataclass(frozen=True)
class Block:
    """One solution block of a solution notebook."""

    notebook: str
    cell: int
    text: str

    @property
    def lines(self) -> tuple[str, ...]:
        return tuple(dict.fromkeys(normalize(x) for x in self.text.splitlines() if significant(x)))

    def __str__(self) -> str:
        return f"{self.notebook}, cell {self.cell} ({len(self.lines)} lines)"


def solution_blocks(solutions_dir: Path | str) -> list[Block]:
    """Every ``### BEGIN SOLUTION`` .. ``### END SOLUTION`` block of every ``*.ipynb`` in the folder."""
    import nbformat

    blocks = []
    for path in sorted(Path(solutions_dir).glob("*.ipynb")):
        nb = nbformat.read(path, as_version=4)
        for index, cell in enumerate(nb.cells):
            if cell.cell_type != "code":
                continue
            exercises.strip_solution(cell.source, f"{path.name}, cell {index}")  # balanced markers, or a clear error
            inside: list[str] | None = None
            for line in cell.source.splitlines():
                if line.strip() == exercises.BEGIN:
                    inside = []
                elif line.strip() == exercises.END:
                    blocks.append(Block(path.name, index, "\n".join(inside or [])))
                    inside = None
                elif inside is not None:
                    inside.append(line)
    return blocks


def searchable_lines(rel: str, data: bytes) -> list[str]:
    """The normalized lines of a file as a reader sees them (a notebook: its cells' sources and outputs)."""
    text = _read_text(data)
    if rel.endswith(".ipynb"):
        try:
            nb = json.loads(text)
        except json.JSONDecodeError:
            pass
        else:
            parts = []
            for cell in nb.get("cells", []):
                src = cell.get("source", "")
                parts.append("".join(src) if isinstance(src, list) else str(src))
                for out in cell.get("outputs", []):
                    parts.append(json.dumps(out))
            text = "\n".join(parts)
    return [normalize(x) for x in text.splitlines()]


@dataclass(frozen=True)
class Leak:
    path: str
    block: Block
    shared: tuple[str, ...]

    def __str__(self) -> str:
        return (f"{self.path} holds solution block {self.block}: {len(self.shared)} of its lines, "
                f"first {self.shared[0]!r}")


def find_leaks(files: Mapping[str, bytes], blocks: Iterable[Block]) -> list[Leak]:
    """Files that contain a solution block.

    A file contains a block when it holds more than half of the block's significant lines (all of
    it, for a one-line block) or two of them on consecutive lines. A single shared line is not
    enough: an attribute set to zero in a constructor, or an array conversion, also appears in the
    library's own code that the chapters teach.
    """
    blocks = [b for b in blocks if b.lines]
    leaks = []
    for rel, data in files.items():
        lines = searchable_lines(rel, data)
        present = set(lines)
        for block in blocks:
            shared = tuple(x for x in block.lines if x in present)
            if not shared:
                continue
            wanted = set(block.lines)
            adjacent = any(a in wanted and b in wanted and a != b for a, b in zip(lines, lines[1:]))
            if len(shared) * 2 > len(block.lines) or adjacent:
                leaks.append(Leak(rel, block, shared))
    return leaks


@dataclass(frozen=True)
class Overlap:
    """A file of the edition that shares lines with a solution block on purpose, and why."""

    path: str
    notebook: str
    cell: int
    why: str

    def covers(self, leak: Leak) -> bool:
        return (leak.path, leak.block.notebook, leak.block.cell) == (self.path, self.notebook, self.cell)


# Reported by every release (as a warning) instead of stopping it. Keep this list short and true.
KNOWN_OVERLAPS: tuple[Overlap, ...] = (
    Overlap("lib/robocourse/pendulum/pid.py", "02_pendulum_exercises.ipynb", 3,
            "the library's TextbookPID (chapter 2 imports and explains it) is an anti-windup PID like the one "
            "exercise 2.1 asks for; two lines coincide, the rest differs. A student can read it: the exercise "
            "relies on the grader refusing delegation to the library, not on secrecy"),
)


# --- rewritten files -----------------------------------------------------------------------------

def _sections(text: str) -> tuple[str, list[tuple[str, str]]]:
    """(text before the first ``## `` heading, [(heading line, section text)]), code fences respected."""
    head, sections, fence = [], [], False
    for line in text.splitlines(keepends=True):
        if line.lstrip().startswith("```"):
            fence = not fence
        if not fence and line.startswith("## "):
            sections.append((line.strip(), [line]))
        elif sections:
            sections[-1][1].append(line)
        else:
            head.append(line)
    return "".join(head), [(h, "".join(body)) for h, body in sections]


def edition_readme(text: str, present_dirs: set[str]) -> str:
    """README for students: "For students" right after the introduction, "For instructors..."
    sections and ``<!-- instructor-only -->`` spans removed, and layout lines naming a folder
    the edition does not have (``solutions/``) dropped."""
    head, sections = _sections(text)
    sections = [(h, body if body.endswith("\n\n") else body.rstrip("\n") + "\n\n") for h, body in sections]
    students = [s for h, s in sections if h[3:].lower().startswith("for students")]
    if not students:
        raise ValueError("README.md has no '## For students' section: the student edition opens with it; "
                         "add one (what to clone, make lab, where the exercises are, how to submit)")
    rest = [s for h, s in sections
            if not h[3:].lower().startswith(("for students", "for instructors"))]
    out = INSTRUCTOR_ONLY.sub("", head + "".join(students) + "".join(rest))
    lines, fence = [], False
    for line in out.splitlines(keepends=True):
        if line.lstrip().startswith("```"):
            fence = not fence
        first = line.split(maxsplit=1)[0] if line.strip() else ""
        if fence and re.fullmatch(r"[\w.-]+/", first) and first[:-1] not in present_dirs:
            continue
        lines.append(line)
    return "".join(lines)


def edition_pyproject(text: str) -> str:
    """pyproject.toml with pytest's testpaths set to the edition's folders (never solutions/)."""
    want = "testpaths = [" + ", ".join(f'"{p}"' for p in EDITION_TESTPATHS) + "]"
    new, n = re.subn(r"(?m)^(?:#.*\n)*testpaths\s*=\s*\[[^\]]*\]",
                     "# student edition: unit tests, and every chapter and exercise notebook executed by nbmake\n"
                     + want, text)
    if n != 1:
        raise ValueError("pyproject.toml: expected one `testpaths = [...]` under [tool.pytest.ini_options], "
                         f"found {n}; the edition rewrites it to {want}")
    if tomllib is None:
        return new
    got = tomllib.loads(new)["tool"]["pytest"]["ini_options"]["testpaths"]
    if got != list(EDITION_TESTPATHS):
        raise ValueError(f"pyproject.toml: rewritten testpaths read back as {got}, expected {list(EDITION_TESTPATHS)}")
    return new


# --- the release -----------------------------------------------------------------------------------

@dataclass
class Edition:
    target: Path
    files: dict[str, bytes]
    left_out: list[tuple[str, int, str]]
    removed: list[str]
    known_overlaps: list[tuple[Leak, Overlap]] = field(default_factory=list)


def _inside(path: Path, folder: Path) -> bool:
    return path == folder or folder in path.parents


def _source_commit(root: Path) -> str | None:
    try:
        out = subprocess.run(["git", "-C", str(root), "rev-parse", "HEAD"], capture_output=True, text=True, timeout=10)
    except (OSError, subprocess.TimeoutExpired):
        return None
    return out.stdout.strip() or None


def plan(root: Path | str = ".", manifest: Iterable[Rule] = MANIFEST,
         overlaps: Iterable[Overlap] = KNOWN_OVERLAPS) -> Edition:
    """Select and rewrite the edition's files in memory; refuse if it would hold a solution."""
    root = Path(root).resolve()
    if not (root / "solutions").is_dir():
        raise FileNotFoundError(f"{root / 'solutions'} not found: release runs on the instructor's course folder "
                                "(the one with solutions/); pass --root")
    problems = exercises.check(root)
    if problems:
        raise ValueError(f"exercises/ is out of sync with solutions/ ({problems[0]}); "
                         "run `robocourse exercises build` and commit, then release")
    sel = select(root, manifest)
    present_dirs = {rel.split("/")[0] for rel in sel.files if "/" in rel}
    for name, rewrite in (("README.md", lambda t: edition_readme(t, present_dirs)), ("pyproject.toml", edition_pyproject)):
        if name not in sel.files:
            raise FileNotFoundError(f"{root / name} is missing or not selected by the manifest; the edition needs it")
        sel.files[name] = rewrite(sel.files[name].decode("utf-8")).encode("utf-8")
    found, overlaps = find_leaks(sel.files, solution_blocks(root / "solutions")), tuple(overlaps)
    known = [(leak, o) for leak in found for o in overlaps if o.covers(leak)]
    leaks = [leak for leak in found if not any(o.covers(leak) for o in overlaps)]
    if leaks:
        raise ValueError(f"the edition would contain solution code: {leaks[0]}"
                         + (f" (and {len(leaks) - 1} more)" if len(leaks) > 1 else "")
                         + "; add an exclude rule for it to robocourse.release.MANIFEST")
    sel.files[MARKER_FILE] = (json.dumps({
        "built_by": "robocourse release", "source_commit": _source_commit(root),
        "files": sorted([*sel.files, MARKER_FILE])}, indent=1) + "\n").encode()
    return Edition(Path(), sel.files, sel.left_out_summary(), [], known)


def release(target: Path | str, root: Path | str = ".", force: bool = False,
            manifest: Iterable[Rule] = MANIFEST) -> Edition:
    """Write the student edition of the course at ``root`` into ``target``.

    ``target`` must be outside the course folder and empty, unless ``force``: then the files of
    the previous edition (listed in its ``.robocourse-edition.json``) are removed first and
    everything else in ``target`` (a ``.git`` folder, say) is kept. ``force`` on a folder that is
    not an edition (no marker file, entries besides ``.git``) is refused before anything is written.
    """
    root, target = Path(root).resolve(), Path(target).resolve()
    if not (root / "solutions").is_dir():   # the course folder first: every other rule is judged against it
        raise FileNotFoundError(f"{root / 'solutions'} not found: {root} is not the instructor's course folder "
                                "(the one with solutions/); run release from it, or pass --root")
    if _inside(target, root):
        raise ValueError(f"{target} is inside the course folder {root}: the next release would copy the "
                         f"edition into itself; choose a folder outside it, e.g. {root.parent / (root.name + '-student')}")
    if _inside(root, target):
        raise ValueError(f"{target} contains the course folder {root}; choose an empty folder beside it, "
                         f"e.g. {root.parent / (root.name + '-student')}")
    if target.exists() and not target.is_dir():
        raise ValueError(f"{target} is a file; give a folder")
    existing = sorted(p.name for p in target.iterdir()) if target.is_dir() else []
    if existing and not force:
        raise ValueError(f"{target} is not empty ({len(existing)} entries, e.g. {existing[0]!r}); "
                         "choose an empty folder, or pass --force to replace a previous edition there")
    foreign = [name for name in existing if name not in (MARKER_FILE, ".git")]
    if force and foreign and not (target / MARKER_FILE).is_file():
        raise ValueError(f"{target} holds {len(foreign)} entries (e.g. {foreign[0]!r}) but no {MARKER_FILE}: it is "
                         "not a previous edition, and --force only replaces one (its listed files); choose an "
                         "empty folder, or empty this one yourself if its contents can go")
    edition = plan(root, manifest)  # everything checked before anything is written
    edition.target = target
    marker = target / MARKER_FILE
    if marker.is_file():
        for rel in json.loads(marker.read_text(encoding="utf-8")).get("files", []):
            old = (target / rel).resolve()
            if _inside(old, target) and old.is_file() and rel not in edition.files:
                old.unlink()
                edition.removed.append(rel)
                for folder in old.parents:  # folders the old edition's files leave empty
                    if folder == target or any(folder.iterdir()):
                        break
                    folder.rmdir()
    for rel, data in edition.files.items():
        out = target / rel
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_bytes(data)
        src = root / rel
        if src.is_file():
            shutil.copymode(src, out)
    return edition
