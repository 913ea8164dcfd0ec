"""``ros2 control ...`` as Python calls, over the manager's bus services, printing ros2controlcli's layout.

==================================================  ====================================================
ROS 2 command                                       robocourse call (``cm`` = a ControllerManager)
==================================================  ====================================================
``ros2 control list_controllers [-v]``              ``list_controllers(cm, verbose=False)``
``ros2 control list_hardware_interfaces``           ``list_hardware_interfaces(cm)``
``ros2 control list_hardware_components [-v]``      ``list_hardware_components(cm, verbose=False)``
``ros2 control load_controller NAME [--set-state]`` ``load_controller(cm, name, set_state=None)``
``ros2 control switch_controllers --activate ...``  ``switch_controllers(cm, activate=[...], ...)``
``ros2 control set_hardware_component_state N S``   ``set_hardware_component_state(cm, name, "active")``
``ros2 run controller_manager spawner NAME ...``    ``spawner(cm, [names], inactive=False, param_file=None)``
==================================================  ====================================================

Each call goes through the service a ``ros2 control`` verb calls (a hidden client node on the
manager's context, spun with the manager's executor), prints what the verb prints (no colours
unless ``RCUTILS_COLORIZED_OUTPUT=1``), and returns the response data; ``quiet=True`` only
returns. Formats: ros2_control:ros2controlcli/ros2controlcli/verb/*.py (rolling).
"""

from __future__ import annotations

import itertools
import os
import threading

from robocourse.bus.introspection import wait_for_future
from robocourse.msgs.builtin_interfaces import Duration

from .hardware.types import as_state
from .msgs import (
    ConfigureController,
    LifecycleState,
    ListControllers,
    ListHardwareComponents,
    ListHardwareInterfaces,
    LoadController,
    SetHardwareComponentState,
    SwitchController,
)

_ids = itertools.count()
_COLOURS = {"active": "\033[92m", "inactive": "\033[96m", "unconfigured": "\033[93m", "finalized": "\033[91m"}
_END = "\033[0m"


def _colour(text: str, key: str) -> str:
    if os.environ.get("RCUTILS_COLORIZED_OUTPUT") == "1" and key in _COLOURS:
        return f"{_COLOURS[key]}{text}{_END}"
    return text


def _out(text: str, quiet: bool) -> None:
    if not quiet:
        print(text)


def call(cm, srv_type, name: str, request=None, timeout_sec: float = 5.0):
    """Call ``/controller_manager/<name>`` over the bus and return the response."""
    node = cm.context.create_node(f"_ros2cli_{next(_ids)}")
    cm.node  # noqa: B018  (creates the manager's node and services on first use)
    try:
        client = node.create_client(srv_type, f"/{cm.node.get_name()}/{name}")
        if not client.wait_for_service(timeout_sec=timeout_sec):
            raise RuntimeError(f"Could not contact service /{cm.node.get_name()}/{name}")
        running = cm.bus_executor
        if running is not None:
            # run_realtime's thread spins the bus on the wall clock: join it and wait in wall time (spinning the
            # manager's own executor here would let a simulated clock jump to the timeout and give up at once;
            # spinning the bus executor would be refused, or refuse the bus thread: one spinner per executor)
            running.add_node(node)
            answered = threading.Event()
            future = client.call_async(request if request is not None else srv_type.Request())
            def wake(_f):
                answered.set()

            wake._immediate = True          # run in the thread that completes the future, not on an executor
            future.add_done_callback(wake)
            answered.wait(timeout_sec)
        else:
            # the manager's executor: spun here, or (when a notebook's thread already spins it) waited on there
            cm.executor.add_node(node)
            future = client.call_async(request if request is not None else srv_type.Request())
            wait_for_future(cm.executor, future, timeout_sec)
        if not future.done():
            raise RuntimeError(f"service /{cm.node.get_name()}/{name} did not answer within {timeout_sec} s")
        return future.result()
    finally:
        if node._executor is not None:
            node._executor.remove_node(node)
        node.destroy_node()


# --- text layouts (pure functions: tests compare them line by line) ------------------------------------
def format_controllers(controllers, verbose: bool = False) -> str:
    if not controllers:
        return "No controllers are currently loaded!"
    wn = max(len(c.name) for c in controllers)
    wt = max(len(c.type) for c in controllers)
    ws = max(len(c.state) for c in controllers)
    lines = []
    for c in controllers:
        state = _colour(f"{c.state:<{ws}}", c.state)
        lines.append(f"{c.name:<{wn}} {c.type:<{wt}}  {state}")
        if verbose:
            lines.append(f"\tupdate_rate: {c.update_rate} Hz")
            lines.append(f"\tis_async: {c.is_async}")
            blocks = [("claimed interfaces", c.claimed_interfaces),
                      ("required command interfaces", c.required_command_interfaces),
                      ("required state interfaces", c.required_state_interfaces)]
            if c.is_chainable:
                blocks.append(("chained to interfaces", [r for cc in c.chain_connections
                                                         for r in cc.reference_interfaces]))
                blocks += [("exported reference interfaces", c.reference_interfaces),
                           ("exported state interfaces", c.exported_state_interfaces)]
            elif c.chain_connections:
                blocks.append(("chained to interfaces", [r for cc in c.chain_connections
                                                         for r in cc.reference_interfaces]))
            for title, items in blocks:
                lines.append(f"\t{title}:")
                lines += [f"\t\t{i}" for i in items]
    return "\n".join(lines)


def _marks(itf) -> str:
    avail = _colour("[available]", "inactive") if itf.is_available else _colour("[unavailable]", "unconfigured")
    claimed = _colour("[claimed]", "active") if itf.is_claimed else "[unclaimed]"
    return f"{avail} {claimed}"


def format_hardware_interfaces(command_interfaces, state_interfaces, verbose: bool = False) -> str:
    lines = ["command interfaces"]
    for i in sorted(command_interfaces, key=lambda x: x.name):
        dtype = f" [{i.data_type}]" if verbose else ""
        lines.append(f"\t{i.name}{dtype} {_marks(i)}")
    lines.append("state interfaces")
    for i in sorted(state_interfaces, key=lambda x: x.name):
        dtype = f" [{i.data_type}]" if verbose else ""
        lines.append(f"\t{i.name}{dtype}")
    return "\n".join(lines)


def format_hardware_components(components, verbose: bool = False) -> str:
    lines = []
    for idx, c in enumerate(components):
        lines += [f"Hardware Component {idx + 1}", f"\tname: {c.name}", f"\ttype: {c.type}",
                  f"\tplugin name: {c.plugin_name}",
                  f"\tstate: id={c.state.id} label={_colour(c.state.label, c.state.label)}",
                  f"\tread/write rate: {c.rw_rate} Hz", f"\tis_async: {c.is_async}", "\tcommand interfaces"]
        for i in c.command_interfaces:
            dtype = f" [{i.data_type}]" if verbose else ""
            lines.append(f"\t\t{i.name}{dtype} {_marks(i)}")
        if verbose:
            lines.append("\tstate interfaces")
            for i in c.state_interfaces:
                lines.append(f"\t\t{i.name} [{i.data_type}] {_marks(i)}")
    return "\n".join(lines)


# --- the verbs ------------------------------------------------------------------------------------------------
def list_controllers(cm, verbose: bool = False, quiet: bool = False):
    controllers = call(cm, ListControllers, "list_controllers").controller
    _out(format_controllers(controllers, verbose), quiet)
    return controllers


def list_hardware_interfaces(cm, verbose: bool = False, quiet: bool = False):
    resp = call(cm, ListHardwareInterfaces, "list_hardware_interfaces")
    _out(format_hardware_interfaces(resp.command_interfaces, resp.state_interfaces, verbose), quiet)
    return resp.command_interfaces, resp.state_interfaces


def list_hardware_components(cm, verbose: bool = False, quiet: bool = False):
    comps = call(cm, ListHardwareComponents, "list_hardware_components").component
    _out(format_hardware_components(comps, verbose), quiet)
    return comps


def load_controller(cm, name: str, set_state: str | None = None, quiet: bool = False) -> bool:
    """``ros2 control load_controller NAME [--set-state inactive|active]``."""
    if set_state not in (None, "inactive", "active"):
        raise ValueError(f"--set-state {set_state!r}: use 'inactive' or 'active'")
    ok = call(cm, LoadController, "load_controller", LoadController.Request(name=name)).ok
    if not ok:
        _out(f"Error loading controller {name}, check controller_manager logs", quiet)
        return False
    _out(f"Successfully loaded controller {name}", quiet)
    if set_state:
        if not call(cm, ConfigureController, "configure_controller", ConfigureController.Request(name=name)).ok:
            _out(f"Error configuring controller {name}", quiet)
            return False
        if set_state == "active" and not switch_controllers(cm, activate=[name], quiet=True):
            _out(f"Error activating controller {name}, check controller_manager logs", quiet)
            return False
        _out(f"Successfully loaded controller {name} into state {set_state}", quiet)
    return True


def switch_controllers(cm, activate=(), deactivate=(), strict: bool = False, activate_asap: bool = False,
                       switch_timeout: float = 5.0, quiet: bool = False) -> bool:
    """``ros2 control switch_controllers --activate A --deactivate B [--strict]`` (default BEST_EFFORT)."""
    sec = int(switch_timeout)
    req = SwitchController.Request(activate_controllers=list(activate), deactivate_controllers=list(deactivate),
                                   strictness=SwitchController.Request.STRICT if strict
                                   else SwitchController.Request.BEST_EFFORT,
                                   activate_asap=activate_asap,
                                   timeout=Duration(sec=sec, nanosec=int(round((switch_timeout - sec) * 1e9))))
    resp = call(cm, SwitchController, "switch_controller", req)
    _out("Successfully switched controllers" if resp.ok else
         "Error switching controllers, check controller_manager logs", quiet)
    return resp.ok


def set_hardware_component_state(cm, name: str, state: str, quiet: bool = False) -> bool:
    """``ros2 control set_hardware_component_state NAME unconfigured|inactive|active``."""
    target = as_state(state)
    req = SetHardwareComponentState.Request(name=name, target_state=LifecycleState(id=target.id, label=target.label))
    resp = call(cm, SetHardwareComponentState, "set_hardware_component_state", req)
    _out(f"Successfully set {name} to state {resp.state.label}" if resp.ok else
         f"Error setting {name} to state {target.label}, check controller_manager logs", quiet)
    return resp.ok


def spawner(cm, names, inactive: bool = False, param_file=None, controller_type: str | None = None,
            activate_as_group: bool = False, quiet: bool = False) -> bool:
    """``ros2 run controller_manager spawner NAMES [--inactive] [--param-file F] [-t TYPE]``.

    With ``param_file`` the file becomes the controllers' ``params_file`` on the manager (and
    its ``<name>.type``/``type`` entries give the type, as upstream's spawner reads them).
    Loads, configures, then activates (one switch for all with ``activate_as_group``), STRICT.
    """
    from .parameters import load_parameter_file, params_for

    names = [names] if isinstance(names, str) else list(names)
    files = load_parameter_file(param_file) if param_file is not None else {}
    for name in names:
        entry = cm.controller_entries.setdefault(name, {})
        if param_file is not None:
            entry["params_file"] = str(param_file)
            ctype = params_for(files, name).get("type")
            if ctype:
                entry["type"] = ctype
        if controller_type:
            entry["type"] = controller_type
        if name in cm.controllers:
            _out(f"Controller already loaded, skipping load_controller: {name}", quiet)
        elif not call(cm, LoadController, "load_controller", LoadController.Request(name=name)).ok:
            _out(f"Failed loading controller {name}", quiet)
            return False
        else:
            _out(f"Loaded {name}", quiet)
        if not call(cm, ConfigureController, "configure_controller", ConfigureController.Request(name=name)).ok:
            _out(f"Failed to configure controller {name}", quiet)
            return False
        if inactive:
            _out(f"Configured {name}", quiet)
        elif not activate_as_group:
            if not switch_controllers(cm, activate=[name], strict=True, quiet=True):
                _out(f"Failed to activate controller {name}", quiet)
                return False
            _out(f"Configured and activated {name}", quiet)
    if activate_as_group and not inactive:
        if not switch_controllers(cm, activate=names, strict=True, quiet=True):
            _out(f"Failed to activate the controllers {names}", quiet)
            return False
        _out(f"Configured and activated all the parsed controllers list : {names}", quiet)
    return True
