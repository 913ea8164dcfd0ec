"""Chapter 0: is this machine ready for the course? (``robocourse doctor``)

Reports Python and package versions against requirements.txt's pins, checks that the 3D
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

PACKAGES = ("numpy", "scipy", "control", "matplotlib", "mujoco", "meshcat", "pyzmq", "ipywidgets",
            "jupyterlab", "nbclient", "pytest", "nbmake", "mcap", "robocourse")


def pinned_versions(requirements: Path | None = None) -> dict[str, str]:
    """{package: pinned version} read from the course's requirements.txt (markers honoured)."""
    path = requirements or Path(__file__).resolve().parents[3] / "requirements.txt"
    pins: dict[str, str] = {}
    if not path.exists():
        return pins
    for line in path.read_text().splitlines():
        m = re.match(r"^\s*([A-Za-z0-9_.\-]+)==([^\s;]+)\s*(?:;\s*(.*))?$", line)
        if not m:
            continue
        name, version, marker = m.groups()
        if marker:
            vm = re.match(r'python_version\s*(>=|<)\s*"(\d+)\.(\d+)"', marker)
            if vm:
                want = (int(vm.group(2)), int(vm.group(3)))
                ok = sys.version_info[:2] >= want if vm.group(1) == ">=" else sys.version_info[:2] < want
                if not ok:
                    continue
        pins[name.lower()] = version
    return pins


def versions() -> list[Finding]:
    out = [Finding("python", f"{platform.python_version()} ({sys.executable})", sys.version_info >= (3, 10),
                   "robocourse needs Python 3.10 or newer: install one and run `make clean lab`")]
    pins = pinned_versions()
    for name in PACKAGES:
        try:
            have = metadata.version(name)
        except metadata.PackageNotFoundError:
            out.append(Finding(name, "not installed", False, "run `make lab` (or `make setup`) from the course folder"))
            continue
        want = pins.get(name.lower())
        ok = want is None or want == have
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
