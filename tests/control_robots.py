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


# --- test controllers (upstream's TestController / TestChainableController, in Python) ----------------------
from robocourse.control import (  # noqa: E402
    CallbackReturn,
    ChainableControllerInterface,
    ControllerInterface,
    InterfaceConfiguration,
    interface_configuration_type,
    return_type,
)

INDIVIDUAL = interface_configuration_type.INDIVIDUAL


class TestController(ControllerInterface):
    """Claims the given interfaces, counts updates, writes ``value`` to its commands; scripted results."""

    __test__ = False

    def __init__(self, commands=(), states=(), value=1.0):
        super().__init__()
        self.commands, self.states, self.value = list(commands), list(states), value
        self.updates: list[tuple[float, float]] = []
        self.record = True
        self.result = return_type.OK
        self.raise_in_update: Exception | None = None
        self.sleep_s = 0.0
        self.script: dict[str, CallbackReturn] = {}

    def command_interface_configuration(self):
        return InterfaceConfiguration(INDIVIDUAL, self.commands)

    def state_interface_configuration(self):
        return InterfaceConfiguration(INDIVIDUAL, self.states)

    def on_configure(self, s):
        return self.script.get("on_configure", CallbackReturn.SUCCESS)

    def on_activate(self, s):
        return self.script.get("on_activate", CallbackReturn.SUCCESS)

    def update(self, time, period):
        if self.record:
            self.updates.append((time, period))
        if self.sleep_s:
            import time as _t
            _t.sleep(self.sleep_s)
        if self.raise_in_update is not None:
            raise self.raise_in_update
        for loan in self.command_interfaces:
            loan.set_value(self.value)
        return self.result


class TestChainable(ChainableControllerInterface):
    """Exports reference interfaces ``<name>/<joint>/position``; forwards reference + 10 to its commands."""

    __test__ = False

    def __init__(self, commands=(), states=(), references=()):
        super().__init__()
        self.commands, self.states, self.references = list(commands), list(states), list(references)
        self.updates = 0
        self.from_subscribers = 0
        self.chained_calls: list[bool] = []

    def command_interface_configuration(self):
        return InterfaceConfiguration(INDIVIDUAL, self.commands)

    def state_interface_configuration(self):
        return InterfaceConfiguration(INDIVIDUAL, self.states)

    def on_export_reference_interfaces(self):
        return self.references

    def on_set_chained_mode(self, chained_mode):
        self.chained_calls.append(chained_mode)
        return True

    def update_reference_from_subscribers(self, time, period):
        self.from_subscribers += 1
        return return_type.OK

    def update_and_write_commands(self, time, period):
        self.updates += 1
        for k, loan in enumerate(self.command_interfaces):
            ref = self.reference_interfaces[k] if k < len(self.reference_interfaces) else 0.0
            loan.set_value(ref + 10.0)
        return return_type.OK
