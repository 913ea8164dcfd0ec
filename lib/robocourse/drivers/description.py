"""The URDF and controller parameters of the UR5e arm behind a driver box.

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


def ethercat_arm_urdf(io: bool = True, auto_fault_reset: bool = False, control_frequency: int = 1000) -> str:
    """The UR5e URDF for ``robocourse/EthercatSystem`` in ethercat_driver_ros2's layout: a coupler
    at bus position 0, one CiA 402 drive per arm joint (positions 1-6, CSP, ``position`` and
    ``reset_fault`` commands, a ``statusword`` state) and, with ``io``, an 8-channel input (7) and output (8) terminal
    as the gpio ``io`` (``dig_input.1..8`` states, ``dig_output.1..8`` commands)."""
    text = arm_urdf("robocourse/EthercatSystem", {"control_frequency": control_frequency},
                    command_interfaces=("position",))
    m = _ROS2_CONTROL.search(text)
    element = ET.fromstring(m.group(0))
    for i, joint in enumerate(element.findall("joint")):
        ET.SubElement(joint, "command_interface", name="reset_fault")
        ET.SubElement(joint, "state_interface", name="statusword")
        mod = ET.SubElement(joint, "ec_module", name=f"drive{i + 1}")
        ET.SubElement(mod, "plugin").text = "ethercat_generic_plugins/EcCiA402Drive"
        for k, v in (("position", i + 1), ("mode_of_operation", 8), ("auto_fault_reset", str(auto_fault_reset).lower())):
            ET.SubElement(mod, "param", name=k).text = str(v)
    if io:
        for name, device, pos, tag, itf in (("io_in", "RC1008", 7, "state_interface", "dig_input"),
                                            ("io_out", "RC2008", 8, "command_interface", "dig_output")):
            gpio = ET.SubElement(element, "gpio", name=name)
            for ch in range(1, 9):
                ET.SubElement(gpio, tag, name=f"{itf}.{ch}")
            mod = ET.SubElement(gpio, "ec_module", name=name)
            ET.SubElement(mod, "plugin").text = "ethercat_generic_plugins/GenericEcSlave"
            ET.SubElement(mod, "param", name="position").text = str(pos)
            ET.SubElement(mod, "param", name="device").text = device
    ET.indent(element, space="  ", level=1)
    return text[:m.start()] + ET.tostring(element, encoding="unicode") + text[m.end():]
