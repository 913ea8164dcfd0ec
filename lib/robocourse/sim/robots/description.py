"""The shipped URDF files: where they are, their joint limits, and xacro-like substitution.

Counterpart of a ``*_description`` package plus ``xacro``: ``urdf_text(name, plugin=...,
params=...)`` returns the robot's URDF with the ``<hardware>`` of its ``<ros2_control>`` element
replaced, as ``xacro ur.urdf.xacro use_mock_hardware:=true`` picks a hardware plugin. Only the
``<ros2_control>`` element is rewritten; links, joints and the ``<mujoco>`` block stay byte for
byte as in the file.
"""

from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET
from collections.abc import Mapping
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

ROBOTS = ("rrbot", "ur5e", "fr3")
"""Names accepted by ``urdf_path``, ``urdf_text``, ``joint_limits`` and ``RobotSim``."""

VARIANTS = {"rrbot": ("modular_fts",), "ur5e": (), "fr3": ()}
"""Other ``<ros2_control>`` wirings of the same robot, for ``urdf_text(name, variant=...)``:
``"modular_fts"`` is RRBot as one actuator per joint plus an external force/torque sensor
(ros2_control_demos' examples 6 and 5), from ``rrbot_modular_fts.ros2_control.xml``."""

_PLUGIN = re.compile(r"[A-Za-z_][A-Za-z0-9_]*((/|::)[A-Za-z_][A-Za-z0-9_]*)+")
_PARAM_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_.\-]*")
_ROS2_CONTROL = re.compile(r"<ros2_control\s[^>]*>.*?</ros2_control>", re.S)


def _check_name(name) -> str:
    if name not in ROBOTS:
        raise ValueError(f"unknown robot {name!r}: the shipped robots are {', '.join(ROBOTS)}; "
                         f"e.g. urdf_path('ur5e')")
    return name


def urdf_path(name: str) -> Path:
    """Path of the shipped URDF file for robot ``name`` (one of ``ROBOTS``)."""
    return Path(str(resources.files(__package__) / f"{_check_name(name)}.urdf"))


@dataclass(frozen=True)
class JointLimits:
    """One joint's URDF ``<limit>``: position in rad (m for prismatic), velocity in rad/s (m/s),
    effort in N m (N). ``lower``/``upper`` are -inf/+inf for a continuous joint."""

    name: str
    type: str
    lower: float
    upper: float
    velocity: float
    effort: float
    mimic: str | None = None


def joint_limits(name: str) -> dict[str, JointLimits]:
    """Every movable joint of robot ``name`` in URDF order, with its limits."""
    root = ET.parse(urdf_path(name)).getroot()
    out: dict[str, JointLimits] = {}
    for j in root.findall("joint"):
        kind = j.get("type")
        if kind == "fixed":
            continue
        lim = j.find("limit")
        lim_attrs = lim.attrib if lim is not None else {}
        continuous = kind == "continuous"
        mimic = j.find("mimic")
        out[j.get("name")] = JointLimits(
            name=j.get("name"), type=kind,
            lower=-math.inf if continuous else float(lim_attrs["lower"]),
            upper=math.inf if continuous else float(lim_attrs["upper"]),
            velocity=float(lim_attrs.get("velocity", "inf")), effort=float(lim_attrs.get("effort", "inf")),
            mimic=None if mimic is None else mimic.get("joint"))
    return out


def _param_text(key, value) -> str:
    if not isinstance(key, str) or not _PARAM_NAME.fullmatch(key):
        raise ValueError(f"hardware param name {key!r} is not a plain name: use letters, digits, "
                         "'_', '.' or '-', e.g. params={'calculate_dynamics': True}")
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if not math.isfinite(value):
            raise ValueError(f"hardware param {key!r} = {value!r} is not finite: give a finite number")
        return repr(value)
    if isinstance(value, str):
        if any(c in value for c in "<>&\n") or value != value.strip():
            raise ValueError(f"hardware param {key!r} = {value!r}: a value may not contain '<', '>', '&', "
                             "newlines or surrounding spaces (ros2_control reads it as one plain string)")
        return value
    raise ValueError(f"hardware param {key!r} = {value!r} ({type(value).__name__}): ros2_control params are "
                     "strings; give a str, int, float or bool")


def urdf_text(name: str, plugin: str | None = None, params: Mapping[str, object] | None = None,
              initial_positions: Mapping[str, float] | None = None, variant: str | None = None) -> str:
    """The URDF of robot ``name`` with a chosen hardware plugin, params and initial positions.

    ``variant`` (one of ``VARIANTS[name]``) swaps the file's ``<ros2_control>`` element for the
    variant's elements, as a demo's xacro includes another ``*.ros2_control.xacro``; it cannot be
    combined with ``plugin``/``params``/``initial_positions`` (each of its components names its own).

    ``plugin`` replaces the ``<hardware><plugin>`` text (e.g. ``"robocourse/MujocoSystem"``);
    ``params`` replaces all ``<hardware><param>`` entries (bools become ``true``/``false``);
    ``initial_positions`` sets ``initial_value`` of the named joints' position state interface.
    With no arguments the file's text is returned unchanged. Bad input raises ``ValueError``
    naming the value and the rule before anything is built.
    """
    text = urdf_path(name).read_text()
    if variant is not None:
        return _variant_text(name, text, variant, plugin, params, initial_positions)
    if plugin is None and params is None and initial_positions is None:
        return text
    if plugin is not None and (not isinstance(plugin, str) or not _PLUGIN.fullmatch(plugin)):
        raise ValueError(f"plugin {plugin!r} is not a pluginlib class name '<package>/<Class>': "
                         "e.g. 'mock_components/GenericSystem' or 'robocourse/MujocoSystem'")
    if params is not None and not isinstance(params, Mapping):
        raise ValueError(f"params must be a mapping of name -> value, got {type(params).__name__}: "
                         "e.g. params={'calculate_dynamics': True}")
    param_texts = {k: _param_text(k, v) for k, v in (params or {}).items()}
    spans = [m.span() for m in _ROS2_CONTROL.finditer(text)]
    if len(spans) != 1:  # the shipped files have exactly one; guard against a broken edit
        raise RuntimeError(f"{urdf_path(name)} must hold exactly one <ros2_control> element, found {len(spans)}")
    start, end = spans[0]
    element = ET.fromstring(text[start:end])
    hardware = element.find("hardware")
    if plugin is not None:
        hardware.find("plugin").text = plugin
    if params is not None:
        for p in hardware.findall("param"):
            hardware.remove(p)
        for k, v in param_texts.items():
            ET.SubElement(hardware, "param", name=k).text = v
    if initial_positions is not None:
        _set_initial_positions(name, element, initial_positions)
    ET.indent(element, space="  ", level=1)
    return text[:start] + ET.tostring(element, encoding="unicode") + text[end:]


def _variant_text(name: str, text: str, variant, plugin, params, initial_positions) -> str:
    if variant not in VARIANTS[name]:
        raise ValueError(f"unknown variant {variant!r} of {name}: its variants are "
                         f"{list(VARIANTS[name]) or 'none'}; e.g. urdf_text('rrbot', variant='modular_fts')")
    if plugin is not None or params is not None or initial_positions is not None:
        raise ValueError(f"variant={variant!r} names its own plugins and params: leave plugin, params and "
                         "initial_positions unset (or edit the returned text)")
    source = resources.files(__package__) / f"{name}_{variant}.ros2_control.xml"
    elements = _ROS2_CONTROL.findall(source.read_text())
    span = _ROS2_CONTROL.search(text).span()
    return text[:span[0]] + "\n  ".join(elements) + text[span[1]:]


def _set_initial_positions(name: str, element: ET.Element, positions: Mapping[str, float]) -> None:
    if not isinstance(positions, Mapping):
        raise ValueError(f"initial_positions must be a mapping of joint -> position, got "
                         f"{type(positions).__name__}: e.g. {{'elbow_joint': 1.57}}")
    limits = joint_limits(name)
    states = {j.get("name"): j.find("state_interface[@name='position']") for j in element.findall("joint")
              if j.find("command_interface") is not None}
    for joint, value in positions.items():
        if joint not in states:
            raise ValueError(f"initial_positions: {joint!r} is not a commanded joint of {name}; "
                             f"the joints are {', '.join(states)}")
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise ValueError(f"initial_positions[{joint!r}] = {value!r} must be a finite number (rad or m)")
        lim = limits[joint]
        if not lim.lower <= value <= lim.upper:
            raise ValueError(f"initial_positions[{joint!r}] = {value} is outside the joint's limits "
                             f"[{lim.lower}, {lim.upper}]")
        state = states[joint]
        init = state.find("param[@name='initial_value']")
        if init is None:
            init = ET.SubElement(state, "param", name="initial_value")
        init.text = repr(float(value))
