"""Small URDFs for the control tests (upstream's test descriptions, rebuilt as text)."""

from __future__ import annotations


def urdf(*blocks: str, joints=("joint1", "joint2"), extra: str = "") -> str:
    """A robot with a chain of revolute ``joints`` and the given ``<ros2_control>`` blocks."""
    links = "".join(f'<link name="link{i}"/>' for i in range(len(joints) + 1))
    js = "".join(
        f'<joint name="{j}" type="revolute"><parent link="link{i}"/><child link="link{i + 1}"/>'
        f'<limit lower="-3.14" upper="3.14" effort="10" velocity="2"/>{extra if j == "joint2" else ""}</joint>'
        for i, j in enumerate(joints))
    return f'<robot name="test">\n{links}{js}\n' + "\n".join(blocks) + "\n</robot>"


def generic(name: str = "GenericSystem2dof", params: dict | None = None, body: str = "", group: str = "",
            rw_rate: int | None = None) -> str:
    """A mock_components/GenericSystem block with ``<param>`` values and joint/sensor/gpio ``body``."""
    p = "".join(f'<param name="{k}">{v}</param>' for k, v in (params or {}).items())
    g = f"<group>{group}</group>" if group else ""
    rate = f' rw_rate="{rw_rate}"' if rw_rate is not None else ""
    return (f'<ros2_control name="{name}" type="system"{rate}>\n<hardware><plugin>mock_components/GenericSystem'
            f'</plugin>{g}{p}</hardware>\n{body}\n</ros2_control>')


def joint(name: str, commands=(), states=(), initial: dict | None = None) -> str:
    """``<joint>`` with command and state interfaces; ``initial`` maps state name -> initial_value."""
    initial = initial or {}
    c = "".join(f'<command_interface name="{i}"/>' for i in commands)
    s = "".join(f'<state_interface name="{i}"><param name="initial_value">{initial[i]}</param></state_interface>'
                if i in initial else f'<state_interface name="{i}"/>' for i in states)
    return f'<joint name="{name}">{c}{s}</joint>'


# upstream's hardware_system_2dof_standard_interfaces (test_generic_system.cpp): pos+vel, 3.45 / 2.78
STANDARD_2DOF = (joint("joint1", ("position", "velocity"), ("position", "velocity"), {"position": 3.45})
                 + joint("joint2", ("position", "velocity"), ("position", "velocity"), {"position": 2.78}))
