"""robocourse: real-time robot control the ROS 2 way, as a small Python library.

Packages, one idea each (see README): ``rt`` timing, ``msgs`` message types, ``bus`` the
in-process ROS 2 middleware, ``viz`` the Meshcat viewer, ``grading`` checks and bulk grading,
``notebook`` helpers for notebooks run by students, CI and the grader.
"""

__version__ = "0.1.0"
