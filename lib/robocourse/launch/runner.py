"""``ros2 launch`` as a call: resolve the arguments, start each Node action, one executor.

``launch(description, launch_arguments={...})`` runs the description's actions in order:
``DeclareLaunchArgument`` sets its configuration (the given value, else the default, else the
launch fails naming the argument), a ``Node`` whose condition holds is started by calling its
executable's factory with the ``--ros-args`` launch_ros would pass. ``show_args`` prints what
``ros2 launch --show-args`` prints.
"""

from __future__ import annotations

import importlib
import importlib.metadata
import json
import tempfile
import weakref
from dataclasses import dataclass, field
from pathlib import Path

from robocourse.bus import Context, SingleThreadedExecutor
from robocourse.bus import Node as BusNode

from .actions import DeclareLaunchArgument, LaunchDescription, Node, is_substitution, substitute

ENTRY_POINTS = "robocourse.executables"


class LaunchError(RuntimeError):
    """A launch that cannot go on: the action, the value and the fix."""


def _packages() -> dict:
    return {e.name: e for e in importlib.metadata.entry_points(group=ENTRY_POINTS)}


def executables(package: str) -> dict:
    """{executable name: factory(context=, cli_args=) -> Node} of ``package`` (its entry point)."""
    found = _packages()
    if package not in found:
        known = ", ".join(sorted(found)) or "none (reinstall the course: make setup)"
        raise LaunchError(f"package '{package}' not found; packages with executables: {known}")
    module = importlib.import_module(found[package].value)
    table = getattr(module, "EXECUTABLES", None)
    if not isinstance(table, dict):
        raise LaunchError(f"package '{package}' ({found[package].value}) has no EXECUTABLES table")
    return table


def show_args(description: LaunchDescription) -> str:
    """The text of ``ros2 launch <file> --show-args``."""
    lines = ["Arguments (pass arguments as '<name>:=<value>'):"]
    for arg in description.launch_arguments:
        lines.append(f"\n    '{arg.name}':")
        lines.append(f"        {arg.description or 'no description given'}")
        if arg.choices:
            lines.append(f"        Valid choices are: {list(arg.choices)}")
        lines.append("        (default: " + (repr(substitute(arg.default_value, {})) if arg.default_value is not None and
                                             not is_substitution(arg.default_value) else
                                             "(substitution)" if arg.default_value is not None else "none") + ")")
    if not description.launch_arguments:
        lines.append("\n  No arguments.")
    return "\n".join(lines)


@dataclass
class LaunchedSystem:
    """What ``launch`` started: the nodes (in start order), their executor and context."""

    context: Context
    executor: SingleThreadedExecutor
    nodes: list = field(default_factory=list)
    configurations: dict = field(default_factory=dict)
    skipped: list = field(default_factory=list)      # Node actions whose condition was false
    warnings: list = field(default_factory=list)
    _tmp: object = None

    def node(self, name: str):
        """The launched node called ``name`` (a plain name or a fully qualified one)."""
        for n in self.nodes:
            if name in (n.get_name(), n.get_fully_qualified_name()):
                return n
        names = ", ".join(n.get_fully_qualified_name() for n in self.nodes) or "none"
        raise KeyError(f"no launched node named {name!r}; launched: {names}")

    def shutdown(self) -> None:
        for n in self.nodes:
            self.executor.remove_node(n)
            n.destroy_node()
        if self._tmp is not None:
            self._tmp.cleanup()
            self._tmp = None


def _flatten(prefix, values, out, configurations):
    for key, value in values.items():
        if not isinstance(key, str) or not key:
            raise LaunchError(f"parameter name {key!r} must be a non-empty str")
        name = f"{prefix}.{key}" if prefix else key
        if isinstance(value, dict):
            _flatten(name, value, out, configurations)
        elif isinstance(value, (list, tuple)) and value and not is_substitution(value):
            out[name] = [_param_value(v, configurations) for v in value]
        else:
            out[name] = _param_value(value, configurations)


def _param_value(value, configurations):
    import yaml

    if isinstance(value, (bool, int, float, str)) or (isinstance(value, list) and not is_substitution(value)):
        return value
    text = substitute(value, configurations)   # launch_ros's ParameterValue: a substitution's text is read as YAML
    try:
        return yaml.safe_load(text)
    except yaml.YAMLError:
        return text


def _label(action: Node, index: int) -> str:
    return f"{action.name or action.executable}-{index}"


def launch(description, *, context: Context | None = None, launch_arguments: dict | None = None,
           use_sim_time: bool = True, executor=None) -> LaunchedSystem:
    """Run ``description`` (a LaunchDescription) like ``ros2 launch``; returns the LaunchedSystem."""
    if callable(description) and not isinstance(description, LaunchDescription):
        raise TypeError("launch() takes a LaunchDescription: call your function, launch(generate_launch_description())")
    if not isinstance(description, LaunchDescription):
        raise TypeError(f"launch({description!r}): give a LaunchDescription([...])")
    given = dict(launch_arguments or {})
    for key, value in given.items():
        if not isinstance(value, str):
            raise TypeError(f"launch argument {key}:={value!r}: launch arguments are text, as on the command line; "
                            f"pass '{str(value).lower() if isinstance(value, bool) else value}'")
    ctx = context or Context(use_sim_time=use_sim_time)
    ex = executor or SingleThreadedExecutor(context=ctx)
    system = LaunchedSystem(ctx, ex)
    configurations = dict(given)     # ros2 launch sets undeclared name:=value pairs too
    declared = {a.name for a in description.launch_arguments}
    for key in given:
        if key not in declared:
            system.warnings.append(f"launch argument '{key}' is not declared by this description (ros2 launch "
                                   "accepts it silently; a typo?)")
    tmp = tempfile.TemporaryDirectory(prefix="robocourse_launch_")
    system._tmp = tmp
    weakref.finalize(system, tmp.cleanup)
    started = 0
    before = set(map(id, ctx.nodes))
    try:
        for action in description.entities:
            if isinstance(action, DeclareLaunchArgument):
                if action.name not in configurations:
                    if action.default_value is None:
                        raise LaunchError(f"launch argument '{action.name}' is required (it has no default) and was "
                                          f"not given; pass launch_arguments={{'{action.name}': ...}}"
                                          + (f" ({action.description})" if action.description else ""))
                    configurations[action.name] = substitute(action.default_value, configurations)
                if action.choices is not None and configurations[action.name] not in action.choices:
                    raise LaunchError(f"Argument '{action.name}' provided value '{configurations[action.name]}' is not "
                                      f"valid. Valid options are: {list(action.choices)}")
                continue
            started += 1
            label = _label(action, started)
            try:
                if action.condition is not None and not action.condition.evaluate(configurations):
                    system.skipped.append(label)
                    continue
                package = substitute(action.package, configurations)
                executable = substitute(action.executable, configurations)
                table = executables(package)
                if executable not in table:
                    raise LaunchError(f"package '{package}' has no executable '{executable}'; its executables: "
                                      f"{', '.join(sorted(table))}")
                cli = [substitute(a, configurations) for a in action.arguments] + ["--ros-args"]
                if action.name is not None:
                    cli += ["-r", f"__node:={substitute(action.name, configurations)}"]
                if action.namespace is not None:
                    ns = substitute(action.namespace, configurations)
                    cli += ["-r", f"__ns:={ns if ns.startswith('/') else '/' + ns}"]
                for frm, to in action.remappings:
                    cli += ["-r", f"{substitute(frm, configurations)}:={substitute(to, configurations)}"]
                for k, entry in enumerate(action.parameters):
                    if isinstance(entry, dict):
                        values: dict = {}
                        _flatten("", entry, values, configurations)
                        path = Path(tmp.name) / f"{label}_{k}.yaml"
                        path.write_text(json.dumps({"/**": {"ros__parameters": values}}))
                    else:
                        path = Path(substitute(entry, configurations)).expanduser()
                        if not path.is_file():
                            raise LaunchError(f"parameter file '{path}' not found (from parameters[{k}]); give the "
                                              "path of a ROS 2 parameter file")
                    cli += ["--params-file", str(path)]
                cli += [substitute(a, configurations) for a in action.ros_arguments]
                node = table[executable](context=ctx, cli_args=cli)
            except LaunchError as err:
                raise LaunchError(f"[{label}] {err}") from None
            except Exception as err:
                raise LaunchError(f"[{label}] {action.package}/{action.executable} failed to start: "
                                  f"{type(err).__name__}: {err}") from err
            if not isinstance(node, BusNode):
                raise LaunchError(f"[{label}] executable '{executable}' returned {node!r}, not a Node")
            system.nodes.append(node)
            ex.add_node(node)
    except BaseException:
        for n in [n for n in ctx.nodes if id(n) not in before]:   # half-built ones too (the one that raised)
            ex.remove_node(n)
            n.destroy_node()
        tmp.cleanup()
        raise
    system.configurations = configurations
    return system
