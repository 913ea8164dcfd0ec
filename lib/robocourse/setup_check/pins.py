"""The versions this robocourse release was tested with, shipped inside the package.

``robocourse doctor`` compares the installed packages with these, so it needs no
requirements.txt (a wheel or a copied ``lib/`` has none). They mirror requirements.txt's pins
line for line; ``tests/test_setup_check.py`` fails the moment the two disagree.
"""

from __future__ import annotations

#: (distribution name, pinned version, python_version condition or "") as in requirements.txt
PINS: tuple[tuple[str, str, str], ...] = (
    ("numpy", "2.4.6", '>= "3.11"'),
    ("numpy", "2.2.6", '< "3.11"'),
    ("scipy", "1.17.1", '>= "3.11"'),
    ("scipy", "1.15.3", '< "3.11"'),
    ("control", "0.10.2", ""),
    ("matplotlib", "3.11.2", ""),
    ("mujoco", "4.0.0", ""),
    ("meshcat", "0.3.2", ""),
    ("pyzmq", "27.3.0", ""),
    ("ipywidgets", "8.1.9", ""),
    ("jupyterlab", "4.6.6", ""),
    ("nbclient", "0.11.0", ""),
    ("pytest", "9.2.0", ""),
    ("nbmake", "1.5.5", ""),
    ("mcap", "1.6.0", ""),
)
