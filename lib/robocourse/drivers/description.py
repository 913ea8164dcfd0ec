"""The URDFs and controller parameters of the arms behind the driver boxes (UR5e, FR3).

Counterpart: ur_description's / franka_description's ``*.ros2_control.xacro``: the same robot
description with the driver's plugin and parameters in ``<ros2_control>``. Ours takes the
shipped UR5e URDF, keeps the six arm joints (the boxes do not drive the gripper or expose the
F/T sensor), keeps the command interfaces the driver serves, and sets the plugin and params.
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from collections.abc import Mapping
from pathlib import Path

from .arm import ARM_JOINTS

CONFIG = Path(__file__).with_name("config")
CONTROLLERS_YAML = CONFIG / "arm_controllers.yaml"
FR3_CONTROLLERS_YAML = CONFIG / "fr3_controllers.yaml"
_ROS2_CONTROL = re.compile(r"<ros2_control\s[^>]*>.*?</ros2_control>", re.S)


def arm_urdf(plugin: str, params: Mapping[str, object] | None = None,
             command_interfaces=("position", "effort")) -> str:
    """The UR5e URDF whose ``<ros2_control>`` has ``plugin``, ``params`` and the six arm joints."""
    from robocourse.sim.robots import urdf_text

    text = urdf_text("ur5e", plugin=plugin, params=dict(params or {}))
    m = _ROS2_CONTROL.search(text)
    element = ET.fromstring(m.group(0))
    for child in list(element):
        if child.tag == "sensor" or (child.tag == "joint" and child.get("name") not in ARM_JOINTS):
            element.remove(child)
        elif child.tag == "joint":
            for itf in child.findall("command_interface"):
                if itf.get("name") not in command_interfaces:
                    child.remove(itf)
    ET.indent(element, space="  ", level=1)
    return text[:m.start()] + ET.tostring(element, encoding="unicode") + text[m.end():]


def fr3_urdf(plugin: str = "robocourse/FrankaStyleSystem", params: Mapping[str, object] | None = None,
             command_interfaces=("position", "velocity", "effort")) -> str:
    """The FR3 URDF (robocourse.sim.robots "fr3", the file the Franka box serves to libfranka)
    whose ``<ros2_control>`` has ``plugin``, ``params`` and only ``command_interfaces``: what
    franka_description's ``fr3.ros2_control.xacro`` gives franka_hardware."""
    from robocourse.sim.robots import urdf_text

    text = urdf_text("fr3", plugin=plugin, params=dict(params or {}))
    m = _ROS2_CONTROL.search(text)
    element = ET.fromstring(m.group(0))
    for joint in element.findall("joint"):
        for itf in joint.findall("command_interface"):
            if itf.get("name") not in command_interfaces:
                joint.remove(itf)
    ET.indent(element, space="  ", level=1)
    return text[:m.start()] + ET.tostring(element, encoding="unicode") + text[m.end():]
