"""Dependency direction (DESIGN.md): foundation packages never import a chapter package, and a
chapter package imports no other chapter package but ``control`` (which imports none).

Foundations: rt, msgs, bus, sim, viz, grading, notebook, launch. Chapters: pendulum, mycar, control,
ethercat, drivers, rl. Imports are read from the source (absolute, relative, and the
``importlib.import_module("robocourse.<pkg>...")`` calls a loader makes), so an import inside a
function counts too.
"""

import ast
from pathlib import Path

import robocourse

FOUNDATIONS = ("rt", "msgs", "bus", "sim", "viz", "grading", "notebook", "launch")
CHAPTERS = ("pendulum", "mycar", "control", "ethercat", "drivers", "rl")
ROOT = Path(robocourse.__file__).parent

#: (importing package, imported module) edges tolerated for now, each with its issue.
KNOWN_EXCEPTIONS: set[tuple[str, str]] = set()  # none: grading finds checks via entry points

#: The one chapter package other chapters may build on (DESIGN.md).
SHARED_CHAPTER = "control"

#: (importing package, imported module) chapter -> chapter edges tolerated for now, with why. None:
#: chapter 6's deployment lives in rl (rl.deployment), its joint bridge in control (control.joint_bridge,
#: the shared chapter package) and the real-time thread set-up in rt (rt.realtime_thread).
KNOWN_CHAPTER_EXCEPTIONS: set[tuple[str, str]] = set()


def imported_modules(path: Path) -> set[str]:
    """Every robocourse module a file imports, as 'pkg.sub' without the 'robocourse.' prefix."""
    return modules_in(path.read_text(), list(path.relative_to(ROOT).parts[:-1]))


def modules_in(source: str, package: list[str]) -> set[str]:
    """Imports in ``source`` of a module inside robocourse/<package...>."""
    out = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[: len(package) - node.level + 1] if node.level > 1 else package
                mod = ".".join(base + ([node.module] if node.module else []))
                names = [mod] if node.module else [f"{mod}.{a.name}" if mod else a.name for a in node.names]
                names = [f"robocourse.{n}" for n in names]
            else:
                names = [node.module or ""]
        elif isinstance(node, ast.Call) and getattr(node.func, "attr", None) == "import_module" \
                and node.args:
            arg = node.args[0]
            if isinstance(arg, ast.Constant) and isinstance(arg.value, str):
                names = [arg.value]
            elif isinstance(arg, ast.JoinedStr):
                # f"robocourse.{name}.checks": a loader that may import any package's module
                text = "".join(v.value if isinstance(v, ast.Constant) else "*" for v in arg.values)
                names = [text]
            else:
                continue
        else:
            continue
        for n in names:
            if n.startswith("robocourse."):
                out.add(n[len("robocourse."):])
    return out


def foundation_edges():
    for pkg in FOUNDATIONS:
        for path in sorted((ROOT / pkg).rglob("*.py")):
            for mod in imported_modules(path):
                yield pkg, path.relative_to(ROOT), mod


def test_foundation_packages_import_no_chapter_package():
    # (grading's checks loader, f"robocourse.{name}.checks", is by design: DESIGN.md puts each
    # chapter's checks next to its code; the loader's cycle with rt is checked below)
    bad = [f"{path} imports robocourse.{mod}" for pkg, path, mod in foundation_edges()
           if mod.split(".")[0] in CHAPTERS and (pkg, mod) not in KNOWN_EXCEPTIONS]
    assert bad == [], "foundation -> chapter imports:\n" + "\n".join(bad)


def test_foundation_packages_form_no_import_cycle_except_known_ones():
    graph: dict[str, set[str]] = {p: set() for p in FOUNDATIONS}
    for pkg, _path, mod in foundation_edges():
        first = mod.split(".")[0]
        if first == "*":
            # the loader may import '<any foundation>.checks' that exists
            for other in FOUNDATIONS:
                target = mod.replace("*", other)
                if other != pkg and (ROOT / other / "checks.py").exists() \
                        and (pkg, target) not in KNOWN_EXCEPTIONS:
                    graph[pkg].add(other)
        elif first in graph and first != pkg and (pkg, mod) not in KNOWN_EXCEPTIONS:
            graph[pkg].add(first)

    def reaches(src, dst, seen=()):
        return any(n == dst or (n not in seen and reaches(n, dst, seen + (n,))) for n in graph[src])

    cycles = sorted(f"{a} <-> {b}" for a in graph for b in graph[a] if reaches(b, a))
    assert cycles == []


def chapter_edges():
    for pkg in CHAPTERS:
        for path in sorted((ROOT / pkg).rglob("*.py")):
            for mod in imported_modules(path):
                yield pkg, path.relative_to(ROOT), mod


def bad_chapter_edges(edges) -> list[str]:
    """Chapter -> chapter imports other than into ``control`` (and any import from ``control``)."""
    bad = []
    for pkg, path, mod in edges:
        first = mod.split(".")[0]
        if first not in CHAPTERS or first == pkg or (pkg, mod) in KNOWN_CHAPTER_EXCEPTIONS:
            continue
        if first != SHARED_CHAPTER or pkg == SHARED_CHAPTER:
            bad.append(f"{path} imports robocourse.{mod}")
    return bad


def test_chapter_packages_import_only_control_among_chapters():
    # e.g. drivers importing ethercat: the ros2_control adapter lives in robocourse.ethercat, and a
    # chapter's checks are found through entry points, never imported by another chapter
    bad = bad_chapter_edges(chapter_edges())
    assert bad == [], "chapter -> chapter imports (only control may be imported):\n" + "\n".join(bad)


def test_the_chapter_rule_catches_drivers_importing_ethercat_and_control_importing_anything():
    # guard the guard with the edges it exists to catch
    drivers = [("drivers", "drivers/x.py", m) for m in modules_in(
        "from ..ethercat.devices import drive_inputs\nfrom robocourse.control import pluginlib\n", ["drivers"])]
    assert bad_chapter_edges(drivers) == ["drivers/x.py imports robocourse.ethercat.devices"]
    control = [("control", "control/y.py", m) for m in modules_in("import robocourse.drivers\n", ["control"])]
    assert bad_chapter_edges(control) == ["control/y.py imports robocourse.drivers"]


def test_the_scanner_sees_relative_absolute_and_dynamic_imports():
    # guard the guard: what sim/car.py used to do, and the other spellings, are all seen
    source = ("from ..mycar.kinematics import DiffDriveGeometry\nfrom .. import pendulum\n"
              "import robocourse.control.hardware\nimport importlib\n"
              "def f():\n    importlib.import_module('robocourse.rl')\n"
              "    importlib.import_module(f'robocourse.{name}.checks')\n")
    mods = modules_in(source, ["sim"])
    assert {"mycar.kinematics", "pendulum", "control.hardware", "rl", "*.checks"} <= mods


#: Packages that are neither: the tools on top (DESIGN.md: notebooks, tests and the CLI may import anything).
TOOLS = ("cli", "setup_check")


def test_every_package_is_classified_so_none_escapes_the_rules():
    # a package missing from both lists would be scanned by neither rule (chapter 6's bridge package,
    # which became rl.deployment + control.joint_bridge + rt.realtime_thread, must not come back unlisted)
    packages = {p.name for p in ROOT.iterdir() if (p / "__init__.py").exists()}
    assert packages == set(FOUNDATIONS) | set(CHAPTERS) | set(TOOLS)


def test_chapter_six_pieces_live_where_rl_may_import_them():
    # the deployment (rl) uses the joint bridge and the real-time thread set-up: they live in the
    # shared chapter package and in a foundation, so rl imports neither another chapter nor bridge
    deployment = imported_modules(ROOT / "rl" / "deployment.py")
    assert {"control.joint_bridge", "rt.realtime_thread"} <= deployment
    assert not any(m.split(".")[0] in CHAPTERS and m.split(".")[0] not in ("rl", SHARED_CHAPTER) for m in deployment)
