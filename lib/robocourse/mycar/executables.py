"""MyCar's executables, by the names a launch file uses: ``Node(package="mycar", executable=...)``.

The counterpart of an ament_python package's ``console_scripts`` (``ros2 run mycar driver_node``):
each entry makes one node from the arguments launch passes (``context``, ``cli_args`` with the
name, namespace, remappings and parameter files). Declared in pyproject.toml's
``robocourse.executables`` entry points as ``mycar``.
"""

from __future__ import annotations


def _simulator(**kwargs):
    from .nodes import SimulatorNode

    return SimulatorNode(**kwargs)


def _driver(**kwargs):
    from .nodes import DriverNode

    return DriverNode(**kwargs)


def _led(**kwargs):
    from .nodes import LedServiceServer

    return LedServiceServer(**kwargs)


def _navigation(**kwargs):
    from .navigation import NavigationActionServer

    return NavigationActionServer(**kwargs)


def _teleop(**kwargs):
    from .teleop import TeleopNode

    return TeleopNode(**kwargs)


#: executable name -> factory(context=..., cli_args=[...]) -> Node
EXECUTABLES = {
    "simulator": _simulator,                  # MuJoCo car + /ground_truth
    "driver_node": _driver,                   # /cmd_vel -> motors; /odom, /tf, /diagnostics, watchdog
    "led_service": _led,                      # /set_led
    "navigation_server": _navigation,         # /navigate_to_pose
    "teleop": _teleop,                        # keys -> /cmd_vel
}
