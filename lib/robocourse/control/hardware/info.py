"""``HardwareInfo`` parsed from a URDF's ``<ros2_control>`` elements.

Counterpart: ``hardware_interface::HardwareInfo`` / ``ComponentInfo`` / ``InterfaceInfo`` and
``parse_control_resources_from_urdf`` (ros2_control:hardware_interface/src/component_parser.cpp).
The error texts are upstream's; robocourse appends the URDF line and a fix, so
``URDFError: Missing <plugin> tag of <hardware> element for 'rrbot' in your URDF. (line 12; fix: ...)``.

Differences: parameters stay strings as upstream (``parse_bool`` / ``float`` them yourself);
joint limits are read from the URDF ``<limit>`` into ``HardwareInfo.limits`` (not enforced
by robocourse, see the chapter); ``data_type`` other than ``double`` is kept as text.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from xml.parsers import expat


class URDFError(ValueError):
    """A URDF that cannot describe the hardware: upstream's text + the line + the fix."""

    def __init__(self, text: str, line: int | None = None, fix: str = ""):
        self.text, self.line, self.fix = text, line, fix
        where = f"line {line}" if line else "URDF"
        super().__init__(f"{text} ({where}; fix: {fix})" if fix else f"{text} ({where})")


# --- a tiny element tree that remembers line numbers (xml.etree does not) ---------------------
@dataclass
class _El:
    tag: str
    attrib: dict
    line: int
    children: list = field(default_factory=list)
    text: str = ""

    def findall(self, tag):
        return [c for c in self.children if c.tag == tag]

    def find(self, tag):
        for c in self.children:
            if c.tag == tag:
                return c
        return None


def parse_xml(text: str) -> _El:
    """Parse XML into :class:`_El` nodes with ``line``; malformed XML -> URDFError with the line."""
    root_holder: list[_El] = []
    stack: list[_El] = []
    parser = expat.ParserCreate()

    def start(tag, attrs):
        el = _El(tag, dict(attrs), parser.CurrentLineNumber)
        if stack:
            stack[-1].children.append(el)
        else:
            root_holder.append(el)
        stack.append(el)

    def end(tag):
        stack.pop()

    def chars(data):
        if stack:
            stack[-1].text += data

    parser.StartElementHandler = start
    parser.EndElementHandler = end
    parser.CharacterDataHandler = chars
    try:
        parser.Parse(text, True)
    except expat.ExpatError as exc:
        raise URDFError(f"invalid URDF passed in to robot parser: {expat.errors.messages[exc.code]}",
                        exc.lineno, "repair the XML at that line (an unclosed or mismatched tag, "
                        "a missing quote)") from None
    return root_holder[0]


# --- the info structures -----------------------------------------------------------------------
@dataclass
class InterfaceInfo:
    """One ``<command_interface>`` / ``<state_interface>`` (hardware_interface::InterfaceInfo)."""

    name: str
    min: str = ""
    max: str = ""
    initial_value: str = ""
    data_type: str = "double"
    size: int = 1
    enable_limits: bool = True
    parameters: dict[str, str] = field(default_factory=dict)
    line: int = 0

    def initial(self) -> float:
        """The interface's starting value: initial_value, else NaN (upstream's default)."""
        return float(self.initial_value) if self.initial_value != "" else math.nan


@dataclass
class ComponentInfo:
    """A ``<joint>``, ``<sensor>`` or ``<gpio>`` (hardware_interface::ComponentInfo)."""

    name: str
    type: str
    is_mimic: bool = False
    parameters: dict[str, str] = field(default_factory=dict)
    command_interfaces: list[InterfaceInfo] = field(default_factory=list)
    state_interfaces: list[InterfaceInfo] = field(default_factory=list)
    line: int = 0


@dataclass
class MimicJoint:
    """``<mimic joint=.. multiplier=.. offset=..>`` resolved to indices into ``joints``."""

    joint_index: int
    mimicked_joint_index: int
    multiplier: float = 1.0
    offset: float = 0.0


@dataclass
class TransmissionInfo:
    """A simple ``<transmission>``: plugin, joints and actuators with reduction and offset."""

    name: str
    type: str = ""
    joints: list[dict] = field(default_factory=list)
    actuators: list[dict] = field(default_factory=list)
    parameters: dict[str, str] = field(default_factory=dict)


@dataclass
class JointLimits:
    """From the URDF ``<joint><limit lower upper velocity effort/>`` (joint_limits::JointLimits)."""

    min_position: float = -math.inf
    max_position: float = math.inf
    max_velocity: float = math.inf
    max_effort: float = math.inf


@dataclass
class HardwareInfo:
    """One ``<ros2_control>`` element (hardware_interface::HardwareInfo)."""

    name: str
    type: str
    hardware_plugin_name: str
    hardware_parameters: dict[str, str] = field(default_factory=dict)
    group: str = ""
    rw_rate: int = 0
    is_async: bool = False
    joints: list[ComponentInfo] = field(default_factory=list)
    mimic_joints: list[MimicJoint] = field(default_factory=list)
    sensors: list[ComponentInfo] = field(default_factory=list)
    gpios: list[ComponentInfo] = field(default_factory=list)
    transmissions: list[TransmissionInfo] = field(default_factory=list)
    limits: dict[str, JointLimits] = field(default_factory=dict)
    original_xml: str = ""
    line: int = 0
    plugin_line: int = 0

    @property
    def hardware_class_type(self) -> str:  # the humble name of the same field
        return self.hardware_plugin_name


_COMPONENT_TYPES = ("system", "actuator", "sensor")
_FIX_TAGS = ("allowed children of <ros2_control> are <hardware>, <joint>, <sensor>, <gpio>, "
             "<transmission>; of <joint>/<sensor>/<gpio>: <command_interface>, <state_interface>, "
             "<param>, <limits>")


def _bool(text: str) -> bool:
    """hardware_interface::parse_bool: 'true'/'True' -> True, anything else False."""
    return text.strip().lower() == "true"


def _params(el: _El, where: str) -> dict[str, str]:
    out = {}
    for p in el.findall("param"):
        if "name" not in p.attrib:
            raise URDFError(f"no parameter name attribute set in param tag{where}", p.line,
                            'write <param name="my_param">value</param>')
        out[p.attrib["name"]] = p.text.strip()
    return out


def _interface(el: _El) -> InterfaceInfo:
    if "name" not in el.attrib:
        raise URDFError(f"no attribute 'name' in '{el.tag}' tag with name ''", el.line,
                        f'give the interface a name: <{el.tag} name="position"/>')
    info = InterfaceInfo(name=el.attrib["name"], data_type=el.attrib.get("data_type", "double"),
                         size=int(el.attrib.get("size", "1")), line=el.line)
    for p in el.children:
        if p.tag == "param":
            pname = p.attrib.get("name")
            if pname is None:
                raise URDFError(f"no parameter name attribute set in param tag of {el.tag} "
                                f"'{info.name}'", p.line, 'write <param name="min">-1.0</param>')
            value = p.text.strip()
            if pname == "min":
                info.min = value
            elif pname == "max":
                info.max = value
            elif pname == "initial_value":
                info.initial_value = value
            else:
                info.parameters[pname] = value
            if pname in ("min", "max", "initial_value"):
                try:
                    float(value)
                except ValueError:
                    raise URDFError(f"param '{pname}' of {el.tag} '{info.name}' is '{value}', not a number",
                                    p.line, f'write a number, e.g. <param name="{pname}">0.0</param>') from None
        elif p.tag == "limits":
            info.enable_limits = _bool(p.attrib.get("enable", "true"))
        else:
            raise URDFError(f"invalid tag name '{p.tag}'", p.line,
                            f"<{el.tag}> may contain <param> and <limits> only")
    return info


def _component(el: _El, kind: str) -> ComponentInfo:
    if "name" not in el.attrib:
        raise URDFError(f"no attribute 'name' in '{kind}' tag with name ''", el.line,
                        f'name it as in the URDF: <{kind} name="joint1">')
    comp = ComponentInfo(name=el.attrib["name"], type=kind, line=el.line,
                         is_mimic=_bool(el.attrib.get("mimic", "false")))
    comp.parameters = _params(el, f" of {kind} '{comp.name}'")
    seen: dict[tuple[str, str], int] = {}
    for c in el.children:
        if c.tag in ("command_interface", "state_interface"):
            itf = _interface(c)
            key = (c.tag, itf.name)
            if key in seen:
                raise URDFError(f"duplicate {c.tag} '{itf.name}' in {kind} '{comp.name}' "
                                f"(first declared on line {seen[key]})", c.line,
                                "declare each interface once per joint, sensor or gpio")
            seen[key] = c.line
            (comp.command_interfaces if c.tag == "command_interface" else comp.state_interfaces).append(itf)
        elif c.tag in ("param", "limits", "ec_module"):
            continue     # <ec_module>: ethercat_driver_ros2's per-joint slave; its plugin reads original_xml
        else:
            raise URDFError(f"invalid tag name '{c.tag}'", c.line, _FIX_TAGS)
    if kind == "sensor" and comp.command_interfaces:
        raise URDFError(f"sensor '{comp.name}' has command interfaces", comp.command_interfaces[0].line,
                        "a <sensor> only has <state_interface> children")
    return comp


def _transmission(el: _El) -> TransmissionInfo:
    t = TransmissionInfo(name=el.attrib.get("name", ""))
    for c in el.children:
        if c.tag == "plugin":
            t.type = c.text.strip()
        elif c.tag == "param":
            t.parameters[c.attrib.get("name", "")] = c.text.strip()
        elif c.tag in ("joint", "actuator"):
            entry = {"name": c.attrib.get("name", ""), "role": c.attrib.get("role", ""),
                     "mechanical_reduction": 1.0, "offset": 0.0, "interfaces": []}
            for g in c.children:
                if g.tag in ("mechanical_reduction", "offset"):
                    entry[g.tag] = float(g.text.strip())
                elif g.tag == "interface":
                    entry["interfaces"].append(g.attrib.get("name", ""))
            (t.joints if c.tag == "joint" else t.actuators).append(entry)
        else:
            raise URDFError(f"invalid tag name '{c.tag}'", c.line,
                            "<transmission> may contain <plugin>, <param>, <joint>, <actuator>")
    return t


def _hardware(el: _El, urdf_joints: dict[str, _El], text_lines: list[str]) -> HardwareInfo:
    name = el.attrib.get("name")
    if name is None:
        raise URDFError("no attribute 'name' in 'ros2_control' tag with name ''", el.line,
                        'name the component: <ros2_control name="RRBotSystem" type="system">')
    kind = el.attrib.get("type")
    if kind is None:
        raise URDFError(f"no attribute 'type' in 'ros2_control' tag with name '{name}'", el.line,
                        'add type="system" (or "actuator" / "sensor")')
    if kind.lower() not in _COMPONENT_TYPES:
        raise URDFError(f"unknown ros2_control type '{kind}' for '{name}'", el.line,
                        "use type=\"system\", \"actuator\" or \"sensor\"")
    rw = el.attrib.get("rw_rate", "0")
    try:
        rw_rate = int(rw)
        if rw_rate < 0:
            raise ValueError
    except ValueError:
        raise URDFError(f'Could not parse rw_rate tag in "{name}". Got "{rw}", but expected a positive integer.',
                        el.line, 'write rw_rate="100" (Hz) or leave it out to run at the manager rate') from None
    hw = el.find("hardware")
    if hw is None or hw.find("plugin") is None or not hw.find("plugin").text.strip():
        raise URDFError(f"Missing <plugin> tag of <hardware> element for '{name}' in your URDF.",
                        (hw or el).line, "add <hardware><plugin>mock_components/GenericSystem</plugin></hardware>")
    info = HardwareInfo(name=name, type=kind.lower(), hardware_plugin_name=hw.find("plugin").text.strip(),
                        rw_rate=rw_rate, is_async=_bool(el.attrib.get("is_async", "false")), line=el.line,
                        plugin_line=hw.find("plugin").line)
    info.hardware_parameters = _params(hw, f" of hardware '{name}'")
    if hw.find("group") is not None:
        info.group = hw.find("group").text.strip()
    for c in hw.children:
        if c.tag not in ("plugin", "param", "group"):
            raise URDFError(f"invalid tag name '{c.tag}'", c.line,
                            "<hardware> may contain <plugin>, <param> and <group>")
    seen_joints: dict[str, int] = {}
    for c in el.children:
        if c.tag == "hardware":
            continue
        if c.tag in ("joint", "sensor", "gpio"):
            comp = _component(c, c.tag)
            if c.tag == "joint":
                if comp.name in seen_joints:
                    raise URDFError(f"Joint '{comp.name}' is declared twice in <ros2_control> '{name}' "
                                    f"(first on line {seen_joints[comp.name]})", c.line,
                                    "list each joint once and put all its interfaces inside that <joint>")
                seen_joints[comp.name] = c.line
                info.joints.append(comp)
            else:
                (info.sensors if c.tag == "sensor" else info.gpios).append(comp)
        elif c.tag == "transmission":
            info.transmissions.append(_transmission(c))
        elif c.tag in ("properties", "param"):
            continue
        else:
            raise URDFError(f"invalid tag name '{c.tag}'", c.line, _FIX_TAGS)
    # joints must exist in the URDF; mimic information and limits come from there
    index = {j.name: i for i, j in enumerate(info.joints)}
    for i, joint in enumerate(info.joints):
        uj = urdf_joints.get(joint.name) if urdf_joints is not None else None
        if urdf_joints is not None and uj is None:
            raise URDFError(f"Joint '{joint.name}' not found in URDF", joint.line,
                            f"add <joint name=\"{joint.name}\" type=\"revolute\"> to the robot or fix the spelling "
                            f"(URDF joints: {sorted(urdf_joints)})")
        mimic = uj.find("mimic") if uj is not None else None
        wants_mimic = "mimic" in _attr_of(el, joint) and joint.is_mimic
        if wants_mimic and mimic is None:
            raise URDFError(f"Joint '{joint.name}' has no mimic information in the URDF", joint.line,
                            f"add <mimic joint=\"...\" multiplier=\"1\"/> inside the URDF joint '{joint.name}'")
        explicit_off = "mimic" in _attr_of(el, joint) and not joint.is_mimic
        if mimic is not None and not explicit_off:
            target = mimic.attrib.get("joint", "")
            if target not in index:
                raise URDFError(f"Mimic joint '{target}' not found in <ros2_control> tag", joint.line,
                                f"add <joint name=\"{target}\"> to <ros2_control> '{name}' or set mimic=\"false\"")
            joint.is_mimic = True
            info.mimic_joints.append(MimicJoint(i, index[target], float(mimic.attrib.get("multiplier", "1")),
                                                float(mimic.attrib.get("offset", "0"))))
        if uj is not None and uj.find("limit") is not None:
            lim = uj.find("limit").attrib
            info.limits[joint.name] = JointLimits(float(lim.get("lower", "-inf")) if uj.attrib.get("type") != "continuous" else -math.inf,
                                                  float(lim.get("upper", "inf")) if uj.attrib.get("type") != "continuous" else math.inf,
                                                  float(lim.get("velocity", "inf")), float(lim.get("effort", "inf")))
    end = _last_line(el)    # the last child's line; the element closes at the next </ros2_control>
    end = next((i + 1 for i in range(end - 1, len(text_lines)) if "</ros2_control>" in text_lines[i]), end)
    info.original_xml = "\n".join(text_lines[el.line - 1:end])
    return info


def _attr_of(parent: _El, comp: ComponentInfo) -> dict:
    for c in parent.children:
        if c.tag == "joint" and c.attrib.get("name") == comp.name:
            return c.attrib
    return {}


def _last_line(el: _El) -> int:
    return max([el.line] + [_last_line(c) for c in el.children])


def parse_control_resources_from_urdf(urdf: str) -> list[HardwareInfo]:
    """Every ``<ros2_control>`` element of ``urdf`` (XML text) as a :class:`HardwareInfo`.

    Raises :class:`URDFError` with upstream's message, the line and a fix.
    """
    if not isinstance(urdf, str) or not urdf.strip():
        raise URDFError("empty URDF passed to robot", None,
                        "pass the URDF text (open(path).read()), not a path or None")
    root = parse_xml(urdf)
    if root.tag != "robot":
        raise URDFError("the robot tag is not root element in URDF or sdf tag is not root element in SDF",
                        root.line, "wrap the description in <robot name=\"...\"> ... </robot>")
    urdf_joints: dict[str, _El] = {}
    for j in root.findall("joint"):
        jname = j.attrib.get("name", "")
        if jname in urdf_joints:
            raise URDFError(f"joint '{jname}' is not unique.", j.line,
                            f"rename one of the two URDF joints called '{jname}' "
                            f"(the other is on line {urdf_joints[jname].line})")
        urdf_joints[jname] = j
    elements = root.findall("ros2_control")
    if not elements:
        raise URDFError("no 'ros2_control' tag found in the URDF", root.line,
                        "add a <ros2_control name=\"...\" type=\"system\"> element inside <robot>")
    lines = urdf.splitlines()
    infos = [_hardware(el, urdf_joints if urdf_joints else None, lines) for el in elements]
    # a joint interface may be exported by one component only
    owner: dict[str, tuple[str, int]] = {}
    for hw in infos:
        for comp in hw.joints + hw.sensors + hw.gpios:
            for itf in comp.command_interfaces:
                key = f"{comp.name}/{itf.name}"
                if key in owner and owner[key][0] != hw.name:
                    raise URDFError(f"command interface '{key}' is exported by both '{owner[key][0]}' and "
                                    f"'{hw.name}'", itf.line,
                                    f"a joint's command interface belongs to one component; remove it from '{hw.name}'"
                                    f" (it is also on line {owner[key][1]})")
                owner[key] = (hw.name, itf.line)
    return infos
