"""Chapter 0: is this machine ready for the course? (``robocourse doctor``)

Reports Python and package versions against the pins shipped in the package (``pins.py``,
kept equal to requirements.txt by a test), checks that the 3D
viewer can build a scene, and says what the machine allows for real-time work with the exact
fix for each missing permission (``robocourse.rt.capabilities``).
"""

from __future__ import annotations

import platform
import re
import sys
import time
from importlib import metadata
from pathlib import Path

from ..rt.capabilities import Finding, probe
from .pins import PINS

PACKAGES = ("numpy", "scipy", "control", "matplotlib", "mujoco", "meshcat", "pyzmq", "ipywidgets",
            "jupyterlab", "nbclient", "pytest", "nbmake", "mcap", "robocourse")


def _applies(marker: str) -> bool:
    """Does a ``python_version >= "3.11"``-style condition hold for this interpreter?"""
    vm = re.match(r'(?:python_version\s*)?(>=|<)\s*"(\d+)\.(\d+)"', marker.strip())
    if not vm:
        return True
    want = (int(vm.group(2)), int(vm.group(3)))
    return sys.version_info[:2] >= want if vm.group(1) == ">=" else sys.version_info[:2] < want


def shipped_pins() -> dict[str, str]:
    """{package: version} this release was tested with (``pins.PINS``, shipped in the package)."""
    return {name: version for name, version, marker in PINS if _applies(marker)}


def pinned_versions(requirements: Path | None = None) -> dict[str, str]:
    """{package: pinned version} read from a requirements.txt (markers honoured).

    Without an argument: the shipped pins (:func:`shipped_pins`). A file that does not exist
    is an error, never "no pins" (which would make every installed version look right).
    """
    if requirements is None:
        return shipped_pins()
    path = Path(requirements)
    if not path.exists():
        raise FileNotFoundError(f"{path}: no such requirements file; call pinned_versions() for the pins "
                                "robocourse ships with")
    pins: dict[str, str] = {}
    for line in path.read_text().splitlines():
        m = re.match(r"^\s*([A-Za-z0-9_.\-]+)==([^\s;]+)\s*(?:;\s*(.*))?$", line)
        if m and _applies(m.group(3) or ""):
            pins[m.group(1).lower()] = m.group(2)
    return pins


def versions(pins: dict[str, str] | None = None) -> list[Finding]:
    """Python and each course package against the pins (default: those shipped with robocourse)."""
    out = [Finding("python", f"{platform.python_version()} ({sys.executable})", sys.version_info >= (3, 10),
                   "robocourse needs Python 3.10 or newer: install one and run `make clean lab`")]
    pins = shipped_pins() if pins is None else pins
    for name in PACKAGES:
        try:
            have = metadata.version(name)
        except metadata.PackageNotFoundError:
            out.append(Finding(name, "not installed", False, "run `make lab` (or `make setup`) from the course folder"))
            continue
        if name == "robocourse":
            out.append(Finding(name, f"{have} (this course)", True))
            continue
        want = pins.get(name.lower())
        if want is None:
            out.append(Finding(name, f"{have} (no pin known to this robocourse)", False,
                               "robocourse ships a pin for every package it checks: reinstall it with `make setup`"))
            continue
        ok = want == have
        out.append(Finding(name, have + ("" if ok else f" (course pins {want})"), ok,
                           "the course was tested with the pinned version: run `make setup` to reinstall"))
    return out


def viewer_check() -> list[Finding]:
    """Build a small scene offline and measure its static HTML; say how live mode will work."""
    from ..viz import Scene

    start = time.perf_counter()
    try:
        scene = Scene(live=False)
        scene.box("check/box", (0.2, 0.2, 0.2), (0.1, 0.6, 0.9, 1.0))
        page = scene.html()
    except Exception as exc:  # report, do not crash the setup notebook
        return [Finding("3D viewer (meshcat)", f"failed: {type(exc).__name__}: {exc}", False,
                        "run `make setup`; meshcat must be 0.3.2 with pyzmq installed")]
    ms = (time.perf_counter() - start) * 1e3
    ok = "MeshCat.Viewer" in page and len(page) > 100_000
    return [Finding("3D viewer (meshcat)", f"static scene built in {ms:.0f} ms ({len(page) / 1e3:.0f} kB HTML)", ok,
                    "the viewer JavaScript is missing from the meshcat package: `make clean setup`")]


def report(try_calls: bool = True) -> str:
    sections = [("Python and packages", versions()), ("3D viewer", viewer_check()),
                ("Real-time permissions on this machine", probe(try_calls))]
    lines = []
    for title, findings in sections:
        lines.append(f"== {title} ==")
        lines += [f.line() for f in findings]
        lines.append("")
    return "\n".join(lines)
