"""robocourse.rt: timing a periodic loop the way rttest and cyclictest do.

``capabilities`` tells what this machine allows for real-time work (and how to fix it).
"""

from .capabilities import Finding, probe, report

__all__ = ["Finding", "probe", "report"]
