"""``--ros-args``: remapping, node name/namespace overrides, parameters and parameter files.

rcl counterpart: ``rcl_parse_arguments`` (rcl/arguments.c), ``rcl_remap_*`` (rcl/remap.c) and
the parameter-file rules of rcl_yaml_param_parser as rclcpp/rclpy apply them. What a node gets
from ``Node(..., cli_args=[...])``, and what ``launch_ros``'s ``Node`` action passes to a node
(robocourse.launch builds exactly these arguments):

- ``-r``/``--remap [node:]from:=to``: ``from`` and ``to`` are expanded with the node's name and
  namespace (``~``, relative names); the first rule whose ``from`` equals a name resolves it.
  ``rostopic://`` / ``rosservice://`` prefixes limit a rule to topics or services.
  ``__node:=`` (or ``__name:=``) renames the node, ``__ns:=`` sets its namespace; a ``node:``
  prefix limits a rule to one node (for ``__node``/``__ns`` its name as written in the code,
  for other rules its name after renaming, as rcl matches them).
- ``-p``/``--param [node:]name:=value``: the value is read as YAML (``1`` an int, ``1.0`` a double).
- ``--params-file FILE``: a ROS 2 parameter file (below).
- ``--log-level``, ``-e``/``--enclave`` and the other rcl flags are accepted and ignored.
  Anything outside ``--ros-args ... [--]`` is the program's own (``remove_ros_args`` returns it).

Parameter files: top-level keys are node names, nested keys are namespaces, ``ros__parameters``
holds the values; nested dicts below it become dotted names (``pid: {p: 1.0}`` is ``pid.p``).
A name without a leading ``/`` is taken from the root; ``*`` matches one token and ``**`` any
number (``/**`` is every node). Entries apply in file order, files in argument order, ``-p``
after files; parameters passed to ``Node(parameter_overrides=...)`` win over all of them
(rclpy's order). Differences: PyYAML reads YAML 1.1, so ``1e-3`` without a dot is a string
(write ``1.0e-3``), as it is in ROS 2 YAML written for rcl's parser to be safe anyway.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

from robocourse.bus import names as _names

_IGNORED_WITH_VALUE = ("--log-level", "--log-config-file", "-e", "--enclave", "--log-file-name")
_IGNORED_FLAGS = ("--enable-rosout-logs", "--disable-rosout-logs", "--enable-stdout-logs",
                  "--disable-stdout-logs", "--enable-external-lib-logs", "--disable-external-lib-logs")


class RosArgumentError(ValueError):
    """A ``--ros-args`` argument rcl would refuse (rcl's RCL_RET_INVALID_ROS_ARGS)."""


@dataclass(frozen=True)
class RemapRule:
    """One ``[node:]from:=to`` rule; ``kind`` is 'any', 'topic', 'service', 'node' or 'namespace'."""

    from_name: str
    to_name: str
    node: str | None = None
    kind: str = "any"

    def __str__(self):
        prefix = f"{self.node}:" if self.node else ""
        scheme = {"topic": "rostopic://", "service": "rosservice://"}.get(self.kind, "")
        return f"{prefix}{scheme}{self.from_name}:={self.to_name}"


@dataclass
class RosArguments:
    """Everything a node takes from its ``--ros-args`` (rcl_arguments_t)."""

    remaps: list[RemapRule] = field(default_factory=list)
    params_files: list[str] = field(default_factory=list)
    params: list[tuple[str | None, str, object]] = field(default_factory=list)  # (node, name, value)
    unparsed: list[str] = field(default_factory=list)   # the program's own arguments

    def node_name(self, original: str) -> str | None:
        for r in self.remaps:
            if r.kind == "node" and r.node in (None, original):
                return r.to_name
        return None

    def namespace(self, original_name: str) -> str | None:
        for r in self.remaps:
            if r.kind == "namespace" and r.node in (None, original_name):
                return r.to_name
        return None


def _yaml_value(text: str, where: str):
    import yaml

    try:
        return yaml.safe_load(text) if text != "" else ""
    except yaml.YAMLError as err:
        raise RosArgumentError(f"{where}: the value {text!r} is not valid YAML ({err.__class__.__name__}); "
                               "quote strings, e.g. -p name:='\"text\"'") from None


def _split_rule(text: str, flag: str) -> tuple[str | None, str, str]:
    if ":=" not in text:
        raise RosArgumentError(f"{flag} {text!r}: a rule is 'from:=to' (or 'node:from:=to'), e.g. "
                               f"{flag} cmd_vel:=/mycar/cmd_vel")
    lhs, rhs = text.split(":=", 1)
    node = None
    scheme = ""
    for s in ("rostopic://", "rosservice://"):
        if s in lhs:
            before, lhs = lhs.split(s, 1)
            scheme = s
            if before:
                node = before.rstrip(":")
    if node is None and ":" in lhs:
        node, lhs = lhs.split(":", 1)
    if node is not None:
        _names.validate_node_name(node)
    if not lhs or (not rhs and flag != "-p"):
        raise RosArgumentError(f"{flag} {text!r}: both sides of ':=' must be non-empty")
    return node, scheme + lhs, rhs


def parse_ros_args(args) -> RosArguments:
    """Parse a ``cli_args`` list (rcl_parse_arguments); a bad rule raises RosArgumentError."""
    if args is None:
        return RosArguments()
    if isinstance(args, str) or not all(isinstance(a, str) for a in args):
        raise TypeError(f"cli_args={args!r} must be a list of str, e.g. ['--ros-args', '-r', 'chatter:=talk']")
    out = RosArguments()
    in_ros = False
    i = 0
    args = list(args)

    def value_after(flag):
        nonlocal i
        if i + 1 >= len(args):
            raise RosArgumentError(f"{flag} needs a value after it, e.g. {flag} "
                                   + ("cmd_vel:=/mycar/cmd_vel" if flag in ("-r", "--remap") else
                                      "params.yaml" if flag == "--params-file" else "name:=1.0"))
        i += 1
        return args[i]

    while i < len(args):
        a = args[i]
        if a == "--ros-args":
            in_ros = True
        elif not in_ros:
            out.unparsed.append(a)
        elif a == "--":
            in_ros = False
        elif a in ("-r", "--remap"):
            node, lhs, rhs = _split_rule(value_after(a), a)
            if lhs in ("__node", "__name"):
                _names.validate_node_name(rhs)
                out.remaps.append(RemapRule(lhs, rhs, node, "node"))
            elif lhs == "__ns":
                out.remaps.append(RemapRule(lhs, _names.normalize_namespace(rhs), node, "namespace"))
            else:
                kind = "any"
                for scheme, k in (("rostopic://", "topic"), ("rosservice://", "service")):
                    if lhs.startswith(scheme):
                        lhs, kind = lhs[len(scheme):], k
                _names.validate_topic_name(lhs)
                _names.validate_topic_name(rhs)
                out.remaps.append(RemapRule(lhs, rhs, node, kind))
        elif a in ("-p", "--param"):
            node, name, text = _split_rule(value_after(a), "-p")
            out.params.append((node, name, _yaml_value(text, f"{a} {name}")))
        elif a == "--params-file":
            path = value_after(a)
            if not Path(path).is_file():
                raise RosArgumentError(f"--params-file {path!r}: no such file; give the path of a ROS 2 "
                                       "parameter file (node: ros__parameters: {...})")
            out.params_files.append(path)
        elif a in _IGNORED_WITH_VALUE:
            value_after(a)
        elif a in _IGNORED_FLAGS:
            pass
        else:
            raise RosArgumentError(f"unknown ROS argument {a!r} after --ros-args; known: -r/--remap, "
                                   "-p/--param, --params-file, --log-level, -e/--enclave (end the ROS part "
                                   "with '--' to pass your own arguments)")
        i += 1
    return out


def remove_ros_args(args) -> list[str]:
    """rclpy.utilities.remove_ros_args: the arguments that are not ROS's."""
    return parse_ros_args(args).unparsed


def remap_name(rules, name: str, node_name: str, namespace: str, *, is_service: bool) -> str:
    """The resolved ``name`` (already expanded) after the first matching rule (rcl_remap_topic_name)."""
    for r in rules:
        if r.kind in ("node", "namespace"):
            continue
        if r.kind == ("topic" if is_service else "service"):
            continue
        if r.node is not None and r.node != node_name:
            continue
        if _names.expand_topic_name(r.from_name, node_name, namespace) == name:
            return _names.expand_topic_name(r.to_name, node_name, namespace, is_service=is_service)
    return name


# ---------------------------------------------------------------------- parameter files

def _flatten(prefix: str, values: dict, out: dict, where: str) -> None:
    for key, value in values.items():
        name = f"{prefix}.{key}" if prefix else str(key)
        if isinstance(value, dict):
            _flatten(name, value, out, where)
        else:
            out[name] = value


def param_file_entries(data, where: str = "parameter file") -> list[tuple[str, dict]]:
    """[(node pattern, {parameter: value})] in file order from a loaded parameter file."""
    if data is None:
        return []
    if not isinstance(data, dict):
        raise RosArgumentError(f"{where}: the top level must map node names to 'ros__parameters:' blocks, got "
                               f"{type(data).__name__}")
    out = []

    def walk(prefix: str, block: dict):
        for key, value in block.items():
            if key == "ros__parameters":
                if not prefix:
                    raise RosArgumentError(f"{where}: 'ros__parameters' must sit under a node name "
                                           "(e.g. driver_node: ros__parameters: ...)")
                params: dict = {}
                if value is not None:
                    if not isinstance(value, dict):
                        raise RosArgumentError(f"{where}: {prefix}: ros__parameters must hold 'name: value' lines")
                    _flatten("", value, params, where)
                out.append(((prefix if prefix.startswith("/") else "/" + prefix), params))
            elif isinstance(value, dict):
                walk(f"{prefix}/{key}" if prefix else str(key), value)
            else:
                raise RosArgumentError(
                    f"{where}: {(prefix + '/' if prefix else '') + str(key)}: {value!r} is not inside a "
                    "'ros__parameters:' block (ROS 2 layout: node_name: ros__parameters: name: value)")

    walk("", data)
    return out


def load_param_file(path) -> list[tuple[str, dict]]:
    import yaml

    p = Path(path)
    try:
        data = yaml.safe_load(p.read_text())
    except yaml.YAMLError as err:
        raise RosArgumentError(f"parameter file {str(p)!r} is not valid YAML: {err}") from None
    return param_file_entries(data, f"parameter file {str(p)!r}")


def node_pattern_matches(pattern: str, fqn: str) -> bool:
    """rclcpp's rule: ``*`` is one name token, ``**`` any number, leading '/' implied."""
    if not pattern.startswith("/"):
        pattern = "/" + pattern
    regex = ""
    for token in pattern[1:].split("/"):
        if token == "**":
            regex += r"(/[^/]+)*"
        elif token == "*":
            regex += r"/[^/]+"
        else:
            regex += "/" + re.escape(token)
    return re.fullmatch(regex, fqn) is not None


def parameters_for(args: RosArguments, fqn: str) -> dict:
    """{name: value} this node gets from its parameter files, then its ``-p`` arguments."""
    values: dict = {}
    for path in args.params_files:
        for pattern, params in load_param_file(path):
            if node_pattern_matches(pattern, fqn):
                values.update(params)
    for node, name, value in args.params:
        if node is None or node_pattern_matches(node, fqn):
            values[name] = value
    return values
