"""Headless Chromium screenshots of a robocourse.viz scene, and what tests measure on them.

Shared by the viz tests: one way to start Chromium (swiftshader WebGL, a fresh profile, no
network), an optional seek of the recorded animation to a given time, and the measurements
(the largest blob of a colour, where a world point lands on the screenshot).
"""

from __future__ import annotations

import math
import shutil
import subprocess

import numpy as np
import pytest

from robocourse.viz import framing

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
needs_chromium = pytest.mark.skipif(CHROMIUM is None,
                                    reason="Chromium is not installed (apt-get install chromium; .ci/run installs it)")

#: default screenshot size: the 4:3 view that Scene.html() frames for by default (framing.ASPECT)
SIZE = (640, 480)


def notebook_size(height: int) -> tuple[int, int]:
    """(width, height) px of a scene shown in a notebook cell ``height`` px tall (Scene.static's view)."""
    from robocourse.viz.scene import CELL_WIDTH_PX

    return CELL_WIDTH_PX, int(height)


def screenshot(scene, tmp_path, name: str = "scene", at_s: float | None = None, budget_ms: int = 2000,
               size: tuple[int, int] = SIZE) -> np.ndarray:
    """The scene's static page, framed for a ``size`` (width, height) px view as Scene.static frames
    a notebook cell, rendered by headless Chromium: an RGB float image (height x width x 3).

    ``at_s``: pause the recorded animation and show it at that time (s; past the end clamps to
    the last frame); ``None`` lets it play for ``budget_ms`` of virtual time."""
    import matplotlib.image

    width, height = size
    page = scene.html(aspect=width / height)
    if at_s is not None:
        page = page.replace("</body>", f"<script>viewer.animator.pause(); viewer.animator.seek({float(at_s)!r});"
                                       "</script></body>")
    html = tmp_path / f"{name}.html"
    html.write_text(page, encoding="utf-8")
    shot = tmp_path / f"{name}.png"
    subprocess.run([CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                    "--disable-background-networking", "--disable-component-update", "--disable-sync",
                    f"--user-data-dir={tmp_path / 'profile'}", "--use-gl=swiftshader", "--enable-unsafe-swiftshader",
                    f"--window-size={width},{height}", f"--virtual-time-budget={int(budget_ms)}",
                    f"--screenshot={shot}", html.as_uri()],
                   capture_output=True, timeout=120, check=True)
    img = matplotlib.image.imread(shot)[..., :3]
    assert img.shape[:2] == (height, width), img.shape
    return img


def colour_mask(img, rgba, tol=0.1, darkest=0.3):
    """Pixels of a model colour ``rgba`` (its first three values) lit or in shade: the pixel's
    channels over its brightest channel match the colour's within ``tol`` (meshcat's Lambert
    shading scales all three alike), and the brightest channel is at least ``darkest``."""
    rgb = np.asarray(rgba, np.float64)[:3]
    top = img.max(axis=-1)
    chroma = img / np.maximum(top, 1e-6)[..., None]
    return (top >= darkest) & np.all(np.abs(chroma - rgb / rgb.max()) <= tol, axis=-1)


def largest_blob(mask):
    """(pixel count, (row0, row1, col0, col1) inclusive, (row, col) centroid) of the largest
    4-connected region of ``mask`` (thin lines of the same colour, e.g. an axis, are left out);
    (0, None, None) if the mask is empty."""
    from scipy import ndimage

    labels, n = ndimage.label(mask)
    if n == 0:
        return 0, None, None
    sizes = np.bincount(labels.ravel())[1:]
    rows, cols = np.nonzero(labels == 1 + int(np.argmax(sizes)))
    return int(sizes.max()), (int(rows.min()), int(rows.max()), int(cols.min()), int(cols.max())), \
        (float(rows.mean()), float(cols.mean()))


def pixel_of(scene, point, size=SIZE):
    """(row, col) where the world ``point`` (m) lands on a ``size`` screenshot of ``scene`` (its camera)."""
    width, height = size
    ndc, _depth = framing.project(np.asarray(point, np.float64)[None, :], *scene.camera, aspect=width / height)
    return float((1 - ndc[0, 1]) / 2 * height), float((ndc[0, 0] + 1) / 2 * width)


def screen_reach(scene, aspect=framing.ASPECT):
    """How far (normalised screen units, 1 = edge) the recorded motion reaches in the current
    camera's view (``aspect`` = width / height), robot size included: every recorded pose is on
    screen when this is below 1."""
    pts, pad = scene.motion_points()
    ndc, depth = framing.project(pts, *scene.camera, aspect=aspect)
    t = math.tan(math.radians(framing.FOV_DEG) / 2)
    return max(float((np.abs(ndc[:, 0]) + pad / (depth * t * aspect)).max()),
               float((np.abs(ndc[:, 1]) + pad / (depth * t)).max()))
