"""The description side: LaunchDescription, DeclareLaunchArgument, substitutions, conditions, Node.

Counterparts: ``launch.LaunchDescription``, ``launch.actions.DeclareLaunchArgument``,
``launch.substitutions.LaunchConfiguration``, ``launch.conditions.IfCondition`` /
``UnlessCondition`` and ``launch_ros.actions.Node``. Every constructor checks its arguments
at once (a typo'd keyword fails where it was written, not at launch time).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from robocourse.bus import names as _names


class LaunchConfiguration:
    """The value of a launch argument, resolved at launch time (a substitution)."""

    def __init__(self, variable_name: str, default=None):
        if not isinstance(variable_name, str) or not variable_name:
            raise TypeError(f"LaunchConfiguration({variable_name!r}): the name must be a non-empty str, "
                            "e.g. LaunchConfiguration('use_sim')")
        self.variable_name = variable_name
        self.default = default

    def perform(self, configurations: dict) -> str:
        if self.variable_name in configurations:
            return configurations[self.variable_name]
        if self.default is not None:
            return substitute(self.default, configurations)
        known = ", ".join(sorted(configurations)) or "none"
        raise LookupError(f"launch configuration '{self.variable_name}' does not exist (declared arguments: "
                          f"{known}); add DeclareLaunchArgument('{self.variable_name}', default_value=...)")

    def __repr__(self):
        return f"LaunchConfiguration({self.variable_name!r})"


def is_substitution(value) -> bool:
    return isinstance(value, LaunchConfiguration) or (
        isinstance(value, (list, tuple)) and value and all(isinstance(v, (str, LaunchConfiguration)) for v in value)
        and any(isinstance(v, LaunchConfiguration) for v in value))


def substitute(value, configurations: dict) -> str:
    """A str, a LaunchConfiguration or a list of both (concatenated, as launch does) -> str."""
    if isinstance(value, str):
        return value
    if isinstance(value, Path):
        return str(value)
    if isinstance(value, LaunchConfiguration):
        return value.perform(configurations)
    if isinstance(value, (list, tuple)):
        return "".join(substitute(v, configurations) for v in value)
    raise TypeError(f"{value!r} is not text or a substitution (str, LaunchConfiguration or a list of them)")


class Condition:
    """``condition=`` of an action: the action runs when ``evaluate`` is True."""

    def __init__(self, predicate):
        if not isinstance(predicate, (str, LaunchConfiguration, list, tuple)):
            raise TypeError(f"{type(self).__name__}({predicate!r}): the predicate must be a str or a substitution, "
                            "e.g. IfCondition(LaunchConfiguration('use_sim'))")
        self.predicate = predicate

    def _truth(self, configurations: dict) -> bool:
        text = substitute(self.predicate, configurations).strip().lower()
        if text in ("true", "1"):
            return True
        if text in ("false", "0"):
            return False
        raise ValueError(f"{type(self).__name__}: the predicate {self.predicate!r} came out {text!r}; a condition "
                         "takes 'true', 'false', '1' or '0' (launch's rule)")

    def evaluate(self, configurations: dict) -> bool:
        return self._truth(configurations)


class IfCondition(Condition):
    """launch.conditions.IfCondition: run when the predicate is 'true' or '1'."""


class UnlessCondition(Condition):
    """launch.conditions.UnlessCondition: run when the predicate is 'false' or '0'."""

    def evaluate(self, configurations: dict) -> bool:
        return not self._truth(configurations)


@dataclass
class DeclareLaunchArgument:
    """launch.actions.DeclareLaunchArgument(name, default_value=None, description='', choices=None)."""

    name: str
    default_value: object = None
    description: str = ""
    choices: list | None = None

    def __post_init__(self):
        if not isinstance(self.name, str) or not self.name:
            raise TypeError(f"DeclareLaunchArgument name={self.name!r} must be a non-empty str")
        if self.default_value is not None and not isinstance(self.default_value, (str, Path, LaunchConfiguration,
                                                                                   list, tuple)):
            raise TypeError(f"DeclareLaunchArgument('{self.name}', default_value={self.default_value!r}): launch "
                            f"arguments are text; write default_value='{self.default_value}'")
        if self.choices is not None and not all(isinstance(c, str) for c in self.choices):
            raise TypeError(f"DeclareLaunchArgument('{self.name}', choices={self.choices!r}): choices are str")


ParameterEntry = object   # a parameter-file path (str, Path, substitution) or a dict {name: value}


class Node:
    """launch_ros.actions.Node: start one node of ``package``'s ``executable``.

    ``name``/``namespace`` override the node's own (``-r __node:=``, ``-r __ns:=``); a relative
    namespace gets a leading '/'. ``parameters``: files and dicts, applied in order (later wins).
    ``remappings``: (from, to) pairs. ``arguments``: the executable's own arguments.
    """

    def __init__(self, *, package, executable, name=None, namespace=None, parameters=None, remappings=None,
                 arguments=None, ros_arguments=None, condition: Condition | None = None, output: str = "screen",
                 exec_name=None, **unknown):
        if unknown:
            raise TypeError(f"Node() got unknown keyword(s) {sorted(unknown)}; launch_ros's Node takes package, "
                            "executable, name, namespace, parameters, remappings, arguments, ros_arguments, "
                            "condition, output")
        for what, value in (("package", package), ("executable", executable)):
            if not isinstance(value, (str, LaunchConfiguration)) or value == "":
                raise TypeError(f"Node({what}={value!r}): give the {what} name as a str, e.g. package='mycar', "
                                "executable='driver_node'")
        if parameters is not None and (isinstance(parameters, (str, dict, Path)) or not isinstance(parameters, (list, tuple))):
            raise TypeError(f"Node(parameters={parameters!r}): parameters is a list of files and dicts, e.g. "
                            "parameters=[params_file, {'wheel_base': 0.15}]")
        for entry in parameters or []:
            if not isinstance(entry, (str, Path, dict, LaunchConfiguration)) and not is_substitution(entry):
                raise TypeError(f"Node(parameters=[... {entry!r} ...]): each entry is a parameter-file path or a "
                                "dict {name: value}")
        if remappings is not None and (not isinstance(remappings, (list, tuple)) or not all(
                isinstance(r, (list, tuple)) and len(r) == 2 for r in remappings)):
            raise TypeError(f"Node(remappings={remappings!r}): remappings is a list of (from, to) pairs, e.g. "
                            "remappings=[('cmd_vel', 'cmd_vel_safe')]")
        if condition is not None and not isinstance(condition, Condition):
            raise TypeError(f"Node(condition={condition!r}): use IfCondition(...) or UnlessCondition(...)")
        if isinstance(name, str):
            _names.validate_node_name(name)
        self.package, self.executable = package, executable
        self.name, self.namespace = name, namespace
        self.parameters = list(parameters or [])
        self.remappings = [tuple(r) for r in remappings or []]
        self.arguments = list(arguments or [])
        self.ros_arguments = list(ros_arguments or [])
        self.condition = condition
        self.output = output
        self.exec_name = exec_name

    def __repr__(self):
        return f"Node(package={self.package!r}, executable={self.executable!r}, name={self.name!r})"


class LaunchDescription:
    """launch.LaunchDescription(entities): the actions of a launch file, in order."""

    def __init__(self, initial_entities=None):
        entities = list(initial_entities or [])
        for e in entities:
            if not isinstance(e, (DeclareLaunchArgument, Node)):
                raise TypeError(f"LaunchDescription([... {e!r} ...]): entities here are DeclareLaunchArgument and "
                                "Node actions")
        self.entities = entities

    def add_action(self, action) -> None:
        if not isinstance(action, (DeclareLaunchArgument, Node)):
            raise TypeError(f"add_action({action!r}): add a DeclareLaunchArgument or a Node")
        self.entities.append(action)

    @property
    def launch_arguments(self) -> list[DeclareLaunchArgument]:
        return [e for e in self.entities if isinstance(e, DeclareLaunchArgument)]

    def get_launch_arguments(self) -> list[DeclareLaunchArgument]:
        """launch's name for ``launch_arguments`` (``ros2 launch --show-args``)."""
        return self.launch_arguments
