"""The controller manager: loads controllers, switches them, runs read -> update -> write.

Counterpart: ``controller_manager::ControllerManager`` (ros2_control:controller_manager/src/
controller_manager.cpp, rolling). What matches upstream, message for message:

- load / configure / cleanup / unload with the ``<name>.type`` parameter and pluginlib lookup; a
  chainable controller's reference and state interfaces are exported at configure, after its
  ``on_configure`` (names computed there exist), and removed at cleanup;
- ``switch_controller(activate, deactivate, strictness, activate_asap, timeout)``: STRICT aborts
  the whole request ("Aborting, no controller is switched! ('STRICT' switch)"), BEST_EFFORT drops
  the offending controllers; interface problems fail the request whatever the strictness;
  command interfaces released by controllers deactivated in the same request count as free;
  hardware ``prepare_command_mode_switch`` then (in the loop) ``perform_command_mode_switch`` ->
  deactivate -> chained-mode changes -> activate;
- chaining: preceding controllers update before their followers (topological sort); a
  controller activates only if its followers are (or become) active; a follower cannot be
  deactivated while a preceding controller stays active;
- per-controller ``update_rate`` (rolling: ``ticks = round(cm / rate)``, rate = cm / ticks);
- an update() returning ERROR or raising deactivates the controller's chain group and activates
  its ``fallback_controllers``, and ``update()`` returns ERROR for that cycle; fallbacks are
  checked as upstream (not the controller itself; before activation each exists, is configured
  and could take over); a hardware read/write ERROR deactivates every controller using that
  hardware's interfaces (a read() DEACTIVATE counts as ERROR), a write DEACTIVATE those holding
  its command interfaces;
- ``list_controllers`` fills the service's fields as upstream does for each state.

Time: the same manager runs deterministically (``step()``/``spin_for()`` on simulated time, for
tests and notebooks: a switch requested between cycles takes effect before the next update,
exactly as if the loop had performed it at the end of the previous one) or on the wall clock in
its own thread (:mod:`.loop`; then ``switch_controller`` blocks until the loop performs the
switch at the end of its next update, or times out).
"""

from __future__ import annotations

import math
import threading
import time as _time
from dataclasses import dataclass, field

import numpy as np

from .. import pluginlib
from ..hardware.types import ACTIVE, FINALIZED, INACTIVE, UNCONFIGURED, State, as_state, return_type
from ..lifecycle import Lifecycle
from ..log import LogSink
from ..parameters import (
    ParameterSchema,
    ParamListener,
    as_parameter_files,
    load_parameter_file,
    params_for,
)
from .controller_interface import ControllerInterface, interface_configuration_type
from .resource_manager import ResourceError, ResourceManager

BEST_EFFORT, STRICT, AUTO, FORCE_AUTO = 1, 2, 3, 4

CM_PARAMS = ParameterSchema.from_yaml("""
controller_manager:
  update_rate: {type: int, default_value: 100, description: "loop rate [Hz]", validation: {gt<>: [0]}}
  handle_exceptions: {type: bool, default_value: true, description: "treat a component's exception as ERROR"}
  defaults:
    switch_controller:
      strictness: {type: string, default_value: "strict", validation: {one_of<>: [["strict", "best_effort"]]}}
    allow_controller_activation_with_inactive_hardware: {type: bool, default_value: false}
    deactivate_controllers_on_hardware_self_deactivate: {type: bool, default_value: true}
  hardware_components_initial_state:
    unconfigured: {type: string_array, default_value: [], validation: {unique<>: null}}
    inactive: {type: string_array, default_value: [], validation: {unique<>: null}}
  overruns:
    print_warnings: {type: bool, default_value: true}
""")

_PER_CONTROLLER_KEYS = ("type", "params_file", "fallback_controllers")


class ControllerSpec:
    """One loaded controller: the object, its lifecycle, its claims and its timing (ControllerSpec)."""

    def __init__(self, name: str, type_: str, controller: ControllerInterface, fallback: list[str]):
        self.name = name
        self.type = type_
        self.c = controller
        self.lifecycle = Lifecycle(controller)
        self.fallback_controllers = list(fallback)
        self.ticks = 1
        self.counter = 0
        self.last_update: float | None = None
        self.update_ns = np.zeros(0, dtype=np.int64)
        self.updates = 0
        self.overruns = 0
        self.max_update_ns = 0
        self.update_error_logged = False

    @property
    def state(self) -> State:
        return self.lifecycle.state

    def __repr__(self) -> str:
        return f"ControllerSpec({self.name!r}, {self.type!r}, {self.state.label})"


@dataclass
class _SwitchRequest:
    activate: list[str]
    deactivate: list[str]
    to_chained: list[str]
    from_chained: list[str]
    start_interfaces: list[str]
    stop_interfaces: list[str]
    done: threading.Event = field(default_factory=threading.Event)


class ControllerManager:
    """``ControllerManager(urdf, params="controllers.yaml")``: hardware from the URDF, settings from YAML.

    ``params`` is a ROS 2 parameter file (path, YAML text, the same layout as a dict
    ``{node: {"ros__parameters": {...}}}``, or ``{node: {param: value}}``); the manager reads the
    ``controller_manager`` section (``update_rate``, ``<controller>.type`` ...) and each
    controller's own section. ``components={"<ros2_control name>": instance}`` supplies hardware
    objects (a student's class). ``context`` is the bus context the manager's node and the
    controllers' nodes live on (default: a new one on simulated time).
    """

    def __init__(self, urdf: str | None = None, *, params=None, update_rate: int | None = None,
                 components: dict | None = None, context=None, log: LogSink | None = None,
                 resource_manager: ResourceManager | None = None, node_name: str = "controller_manager"):
        self.log = log if log is not None else (resource_manager.log if resource_manager else LogSink())
        self.logger = self.log.logger(node_name)
        self.param_files = as_parameter_files(params)
        cm_values = params_for(self.param_files, node_name)
        if update_rate is not None:
            cm_values["update_rate"] = update_rate
        self.controller_entries = {}
        own = {}
        for key, value in cm_values.items():
            head, _, tail = key.rpartition(".")
            if head and tail in _PER_CONTROLLER_KEYS and not head.startswith(("defaults", "hardware_components",
                                                                             "overruns")):
                self.controller_entries.setdefault(head, {})[tail] = value
            else:
                own[key] = value
        self.param_listener = ParamListener(CM_PARAMS, own)
        self.params = self.param_listener.get_params()
        for key in self.param_listener.unused:
            self.logger.warning(f"parameter '{key}' is not a controller_manager parameter (ignored, as ROS does)")
        self.update_rate = int(self.params.update_rate)
        self.period = 1.0 / self.update_rate
        if context is None:
            from robocourse.bus import Context

            context = Context(use_sim_time=True)
        self.context = context
        self._components = components
        self.rm = resource_manager if resource_manager is not None else ResourceManager(
            update_rate=self.update_rate, log=self.log, handle_exceptions=self.params.handle_exceptions)
        if resource_manager is None and urdf is not None:
            self.rm.load_and_initialize_components(urdf, components=components)
            self.rm.activate_components(self._initial_states())
        self.controllers: dict[str, ControllerSpec] = {}
        self._ordered: list[ControllerSpec] = []
        self._active: list[ControllerSpec] = []
        self._pending: _SwitchRequest | None = None
        self._switch_lock = threading.Lock()
        self.rt_thread_running = False
        self.last_switch_message = ""
        self.time = 0.0
        self.cycles = 0
        self._node = None
        self._executor = None
        #: while run_realtime spins the bus in its own thread: that executor (nodes made meanwhile join it)
        self.bus_executor = None
        self.timing = None  # set by enable_timing / the real-time loop (see .loop)
        if not self.rm.is_initialized:
            from robocourse.bus import DurabilityPolicy, QoSProfile
            from robocourse.msgs.std_msgs import String

            self.node.create_subscription(String, "robot_description", self._on_robot_description,
                                          QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL))
            self.logger.warning("Waiting for data on 'robot_description' topic to finish initialization")

    def _initial_states(self) -> dict:
        initial = {n: "unconfigured" for n in self.params.hardware_components_initial_state.unconfigured}
        initial.update({n: "inactive" for n in self.params.hardware_components_initial_state.inactive})
        return initial

    def _on_robot_description(self, msg) -> None:
        if self.rm.is_initialized:
            self.logger.warning("ResourceManager has already loaded a urdf. Ignoring attempt to reload a robot "
                                "description.")
            return
        self.init_resource_manager(msg.data)

    def init_resource_manager(self, urdf: str) -> bool:
        """Load the hardware from ``urdf`` (what a /robot_description message does); False + log on error.

        Upstream's manager started without a valid description keeps running uninitialised and
        initialises when a valid one arrives; so does this one.
        """
        try:
            self.rm.load_and_initialize_components(urdf, components=self._components)
            self.rm.activate_components(self._initial_states())
        except (ValueError, TypeError, RuntimeError, LookupError) as exc:
            self.rm.reset()
            self.logger.error(f"Failed to initialize the resource manager from the robot description: {exc}")
            return False
        self.logger.info("Resource Manager has been successfully initialized. Starting Controller Manager services...")
        return True

    # --- the bus node and executor --------------------------------------------------------------------
    @property
    def node(self):
        """The manager's node (created on first use, with the controller_manager services)."""
        if self._node is None:
            from .services import attach_services

            self._node = self.context.create_node(self.logger.name)
            attach_services(self, self._node)
            self.executor.add_node(self._node)
        return self._node

    @property
    def executor(self):
        if self._executor is None:
            from robocourse.bus import SingleThreadedExecutor

            self._executor = SingleThreadedExecutor(context=self.context)
        return self._executor

    def _make_node(self, name: str):
        node = self.context.create_node(name)
        # during run_realtime the loop's bus thread spins the nodes; the manager's executor gets them back after
        (self.bus_executor or self.executor).add_node(node)
        return node

    # --- controller lifecycle -------------------------------------------------------------------------
    def controller_parameters(self, name: str) -> dict:
        values = params_for(self.param_files, name)
        extra = self.controller_entries.get(name, {}).get("params_file")
        if extra:
            files = [extra] if isinstance(extra, str) else list(extra)
            for f in files:
                values.update(params_for(load_parameter_file(f), name))
        return values

    def load_controller(self, name: str, controller_type: str | None = None,
                        controller: ControllerInterface | None = None) -> ControllerInterface | None:
        """Load and initialise controller ``name`` (type from ``<name>.type`` unless given).

        ``controller=`` passes an instance (a student's class) instead of a pluginlib type.
        Returns the controller, or None with the reason logged (upstream returns nullptr).
        """
        if not self.rm.is_initialized:
            self.logger.error("Resource Manager is not initialized yet! Please provide robot description on "
                              f"'robot_description' topic before trying to load any controller ('{name}').")
            return None
        if name in self.controllers:
            self.logger.error(f"Controller '{name}' already loaded, skipping load_controller")
            return None
        entry = self.controller_entries.get(name, {})
        if controller is not None:
            controller_type = controller_type or f"{type(controller).__module__}/{type(controller).__name__}"
        else:
            controller_type = controller_type or entry.get("type")
            if not controller_type:
                self.logger.error(f"The 'type' param was not defined for '{name}'.")
                return None
            try:
                cls = pluginlib.load(controller_type, pluginlib.CONTROLLER_BASE)
            except pluginlib.PluginlibException:
                self.logger.error(f"Loader for controller '{name}' (type '{controller_type}') not found.\n"
                                  f"Available classes:\n  " + "\n  ".join(pluginlib.declared(pluginlib.CONTROLLER_BASE)))
                return None
            controller = cls()
        fallbacks = entry.get("fallback_controllers", [])
        if isinstance(fallbacks, str) or not all(isinstance(f, str) for f in fallbacks):
            self.logger.error(f"'{name}.fallback_controllers' must be a list of controller names, got {fallbacks!r}")
            return None
        if name in fallbacks:
            self.logger.error(f"Controller '{name}' cannot be a fallback controller for itself.")
            return None
        spec = ControllerSpec(name, controller_type, controller, list(fallbacks))
        values = self.controller_parameters(name)
        # what upstream controllers parse from robot_description: the URDF <limit> of every joint
        controller.joint_limits = {j: lim for comp in self.rm.components.values() for j, lim in comp.info.limits.items()}
        try:
            state = spec.lifecycle.initialize(name, values, self.update_rate, self._make_node, self.log.logger(name),
                                              method="init")
        except Exception as exc:  # noqa: BLE001
            state, spec.lifecycle.last_exception = FINALIZED, exc
        if state != UNCONFIGURED:
            why = spec.lifecycle.last_exception
            self.logger.error(f"Could not initialize the controller named '{name}'" + (f": {why}" if why else ""))
            self.last_error = str(why) if why else "on_init did not return SUCCESS"
            return None
        for key in getattr(controller, "unused_parameters", []):
            self.logger.warning(f"parameter '{key}' of controller '{name}' is not declared by "
                                f"{controller_type} (ignored, as ROS does)")
        self.controllers[name] = spec
        self._reorder()
        self.logger.info(f"Loaded controller '{name}' of type '{controller_type}'")
        return controller

    def configure_controller(self, name: str) -> return_type:
        spec = self.controllers.get(name)
        if spec is None:
            self.logger.error(f"Controller '{name}' is not loaded")
            return return_type.ERROR
        if spec.state == ACTIVE:
            self.logger.error(f"Controller '{name}' can not be configured from 'active' state.")
            return return_type.ERROR
        if spec.state == INACTIVE:
            self.cleanup_controller(name)
        state = spec.lifecycle.configure()
        if state != INACTIVE:
            why = spec.lifecycle.last_exception
            self.logger.error(f"After configuring, controller '{name}' is in state '{state.label}' , expected "
                              "inactive." + (f" ({why!r})" if why else ""))
            return return_type.ERROR
        if spec.c.is_chainable() and not self._export_interfaces(spec):
            why = spec.lifecycle.last_exception
            spec.lifecycle.cleanup()
            spec.lifecycle.last_exception = why
            return return_type.ERROR
        rate = spec.c.update_rate
        if rate > self.update_rate:
            self.logger.warning(f"The controller : {name} update rate : {rate} Hz should be less than or equal to "
                                f"controller manager's update rate : {self.update_rate} Hz!. Setting it to "
                                f"{self.update_rate} Hz")
            rate = self.update_rate
        ticks = max(1, round(self.update_rate / rate))
        if self.update_rate % rate:
            new_rate = self.update_rate // ticks
            self.logger.warning(f"The controller : {name} update rate : {rate} Hz is not a divisor of the "
                                f"controller manager's update rate : {self.update_rate} Hz. Using {new_rate} Hz")
            rate = new_rate
        spec.c.update_rate = rate
        spec.ticks = ticks
        self._reorder()   # a controller may know its interfaces (and so its chain) only once configured
        return return_type.OK

    def _export_interfaces(self, spec: ControllerSpec) -> bool:
        """Upstream's configure step for a chainable controller: after ``on_configure`` (so names
        computed there count), its reference and state interfaces go into the resource manager
        (unavailable until it is activated)."""
        c, name = spec.c, spec.name
        try:
            refs, states = c.export_reference_interfaces(), c.export_state_interfaces()
        except Exception as exc:  # noqa: BLE001 - a student's on_export_* may raise
            spec.lifecycle.last_exception = exc
            self.logger.error(f"Export of the state or reference interfaces failed for controller '{name}': {exc!r}")
            return False
        if not refs and not states:
            self.logger.warning(f"Controller '{name}' is chainable, but does not export any state or reference "
                                "interfaces. Did you override the on_export_method() correctly?")
        try:
            self.rm.import_controller_reference_interfaces(name, refs, c.reference_interfaces)
            self.rm.import_controller_exported_state_interfaces(name, states, c.exported_state_interfaces)
        except ResourceError as exc:
            self.rm.remove_controller_interfaces(name)
            self.logger.error(str(exc))
            return False
        self._reorder()
        return True

    def cleanup_controller(self, name: str) -> return_type:
        """INACTIVE -> UNCONFIGURED; a chainable controller's exported interfaces are removed (upstream)."""
        spec = self.controllers.get(name)
        if spec is None or spec.state != INACTIVE:
            self.logger.error(f"Controller '{name}' can not be cleaned-up from "
                              f"'{spec.state.label if spec else 'not loaded'}' state.")
            return return_type.ERROR
        ok = spec.lifecycle.cleanup() == UNCONFIGURED
        if spec.c.is_chainable():
            self.rm.remove_controller_interfaces(name)
            self._reorder()
        return return_type.OK if ok else return_type.ERROR

    def unload_controller(self, name: str) -> return_type:
        spec = self.controllers.get(name)
        if spec is None:
            self.logger.error(f"Could not unload controller with name '{name}' because no controller with this "
                              "name exists")
            return return_type.ERROR
        if spec.state == ACTIVE:
            self.logger.error(f"Could not unload controller with name '{name}' because it is still in active state")
            return return_type.ERROR
        if spec.state == INACTIVE:
            spec.lifecycle.cleanup()
        spec.lifecycle.shutdown()
        self.rm.remove_controller_interfaces(name)
        node = spec.c._node
        if node is not None:
            if node._executor is not None:      # the manager's, or run_realtime's bus executor during a run
                node._executor.remove_node(node)
            node.destroy_node()
        del self.controllers[name]
        self._reorder()
        self.logger.info(f"Unloaded controller '{name}'")
        return return_type.OK

    def load_and_configure(self, name: str, controller_type: str | None = None) -> ControllerInterface:
        """Convenience for notebooks: load + configure, raising with the logged reason on failure."""
        c = self.load_controller(name, controller_type)
        if c is None or self.configure_controller(name) != return_type.OK:
            raise RuntimeError(f"could not load and configure '{name}': {self.log.records[-1].msg}")
        return c

    # --- interface bookkeeping ----------------------------------------------------------------------------
    def required_interfaces(self, spec: ControllerSpec) -> tuple[list[str], list[str]]:
        """(command, state) interface names the controller's configuration asks for right now."""
        c = spec.c
        cmd_cfg, st_cfg = c.command_interface_configuration(), c.state_interface_configuration()
        T = interface_configuration_type
        if cmd_cfg.type == T.ALL:
            cmds = [k for k in self.rm.available_command_interfaces() if not self.rm.is_reference_interface(k)]
        elif cmd_cfg.type == T.INDIVIDUAL:
            cmds = list(cmd_cfg.names)
        else:
            cmds = []
        if st_cfg.type == T.ALL:
            states = self.rm.available_state_interfaces()
        elif st_cfg.type == T.INDIVIDUAL:
            states = list(st_cfg.names)
        else:
            states = []
        return cmds, states

    def _configured_names(self, spec: ControllerSpec) -> tuple[list[str], list[str]]:
        """Declared names for INDIVIDUAL configurations (used for chain ordering before activation)."""
        try:
            cmds, states = self.required_interfaces(spec)
        except Exception:  # noqa: BLE001 - a controller not yet configured may not know its joints
            return [], []
        return cmds, states

    def _followers(self, spec: ControllerSpec) -> list[str]:
        """Controllers whose reference interfaces ``spec`` writes (it precedes them)."""
        cmds, _ = self._configured_names(spec)
        return sorted({self.rm.owner_of(k) for k in cmds if self.rm.is_reference_interface(k)})

    def _state_sources(self, spec: ControllerSpec) -> list[str]:
        _, states = self._configured_names(spec)
        return sorted({self.rm.owner_of(k) for k in states if self.rm.is_reference_interface(k)})

    def _reorder(self) -> None:
        """Topological sort: preceding controllers (and exporters of state) update first."""
        names = list(self.controllers)
        edges = {n: set() for n in names}   # n -> controllers that must come after n
        indeg = dict.fromkeys(names, 0)
        for n in names:
            spec = self.controllers[n]
            for f in self._followers(spec):
                if f in edges and f not in edges[n]:
                    edges[n].add(f)
                    indeg[f] += 1
            for s in self._state_sources(spec):
                if s in edges and n not in edges[s]:
                    edges[s].add(n)
                    indeg[n] += 1
        order, ready = [], [n for n in names if indeg[n] == 0]
        while ready:
            n = ready.pop(0)
            order.append(n)
            for m in names:
                if m in edges[n]:
                    indeg[m] -= 1
                    if indeg[m] == 0:
                        ready.append(m)
        if len(order) != len(names):
            cyc = [n for n in names if n not in order]
            self.logger.error(f"controllers {cyc} form a chaining cycle; they keep load order")
            order += cyc
        self._ordered = [self.controllers[n] for n in order]
        self._active = [s for s in self._ordered if s.state == ACTIVE]

    def ordered_controllers(self) -> list[str]:
        return [s.name for s in self._ordered]

    def _preceding(self, name: str) -> list[str]:
        return [s.name for s in self._ordered if name in self._followers(s)]

    def _chain_group(self, names) -> set[str]:
        """``names`` plus every controller chained to them, in either direction, transitively."""
        group, todo = set(), list(names)
        while todo:
            n = todo.pop()
            if n in group or n not in self.controllers:
                continue
            group.add(n)
            todo += self._followers(self.controllers[n]) + self._preceding(n)
        return group

    # --- switching -------------------------------------------------------------------------------------------
    def switch_controller(self, activate_controllers=(), deactivate_controllers=(), strictness: int = 0,
                          activate_asap: bool = False, timeout: float = 0.0) -> return_type:
        """Activate and deactivate controllers in one cycle; see the module docstring for the rules.

        ``activate_asap`` is accepted for message compatibility and does not change the outcome
        (activation always waits for the interfaces to be available). The reason for the outcome
        is in ``self.last_switch_message`` (what the service returns as ``message``).
        """
        activate, deactivate = list(activate_controllers), list(deactivate_controllers)
        if strictness == 0:
            strictness = STRICT if self.params.defaults.switch_controller.strictness == "strict" else BEST_EFFORT
        if strictness in (AUTO, FORCE_AUTO):
            self.logger.warning(f"Controller Manager: {'AUTO' if strictness == AUTO else 'FORCE_AUTO'} is not "
                                "currently implemented. Defaulting to BEST_EFFORT")
            strictness = BEST_EFFORT
        if strictness not in (BEST_EFFORT, STRICT):
            raise ValueError(f"strictness {strictness!r} is not one of 0 (default), 1 BEST_EFFORT, 2 STRICT, "
                             "3 AUTO, 4 FORCE_AUTO")
        if timeout == 0:
            self.logger.info("Switch controller timeout is set to 0, using default 1s!")
            timeout = 1.0
        mode = "STRICT" if strictness == STRICT else "BEST_EFFORT"
        failed: list[str] = []

        def fail(msg: str) -> return_type:
            self.logger.error(msg)
            self.last_switch_message = f"Failed switching controllers.... {msg}"
            return return_type.ERROR

        # 1. names must exist
        for lst, verb in ((activate, "activate"), (deactivate, "deactivate")):
            requested = list(lst)
            for n in requested:
                if n not in self.controllers:
                    msg = f"Could not {verb} controller with name '{n}' because no controller with this name exists"
                    if strictness == STRICT:
                        return fail(f"{msg}\nAborting, no controller is switched! ('STRICT' switch)")
                    self.logger.warning(msg)
                    lst.remove(n)
                    failed.append(n)
            if requested and not lst:
                return fail(f"None of the controllers to {verb} {requested} exist")

        # 2. per-controller state checks, then chaining rules; BEST_EFFORT drops and re-checks
        while True:
            problem = self._check_states(activate, deactivate) or self._check_chaining(activate, deactivate)
            if problem is None:
                break
            who, msg = problem
            if strictness == STRICT:
                return fail(f"{msg}\nAborting, no controller is switched! ('STRICT' switch)")
            self.logger.warning(msg)
            failed.append(who)
            if who in activate:
                activate.remove(who)
            if who in deactivate:
                deactivate.remove(who)

        if not activate and not deactivate:
            msg = "After checking the controllers, no controllers need to be activated or deactivated."
            self.logger.info(msg)
            self.last_switch_message = msg
            return return_type.OK

        # 3. interfaces (any strictness)
        problem = self._check_interfaces(activate, deactivate)
        if problem:
            self.logger.error(problem)
            self.last_switch_message = (f"Failed switching controllers.... {problem}\nUnable to activate "
                                        f"controllers: [ {' '.join(activate)} ]")
            return return_type.ERROR

        # 4. chained mode changes
        to_chained = [f for f in activate + [s.name for s in self._active]
                      if self.controllers[f].c.is_chainable()
                      and any(f in self._followers(self.controllers[p]) for p in activate)
                      and not self.controllers[f].c.is_in_chained_mode()]
        staying = [s.name for s in self._active if s.name not in deactivate] + activate
        from_chained = [s.name for s in self._active if s.c.is_chainable() and s.c.is_in_chained_mode()
                        and s.name not in deactivate
                        and not any(s.name in self._followers(self.controllers[p]) for p in staying)]

        # 5. hardware command mode
        start, stop = [], []
        for n in activate:
            start += self.required_interfaces(self.controllers[n])[0]
        for n in deactivate:
            stop += [loan.name for loan in self.controllers[n].c.command_interfaces]
        hw_start = [k for k in start if not self.rm.is_reference_interface(k)]
        hw_stop = [k for k in stop if not self.rm.is_reference_interface(k)]
        if not self.rm.prepare_command_mode_switch(hw_start, hw_stop):
            return fail("Could not switch controllers since prepare command mode switch was rejected.")

        request = _SwitchRequest(activate, deactivate, to_chained, from_chained, hw_start, hw_stop)
        if self.rt_thread_running:
            with self._switch_lock:
                self._pending = request
            if not request.done.wait(timeout):
                with self._switch_lock:
                    if self._pending is request:
                        self._pending = None
                return fail(f"Switch controller timed out after {timeout:g} seconds!")
        else:
            self._do_switch(request)
        activated = [n for n in activate if self.controllers[n].state == ACTIVE]
        deactivated = [n for n in deactivate if self.controllers[n].state != ACTIVE or n in activate]
        not_active = [n for n in activate if n not in activated]
        if not_active:
            return fail(f"Unable to activate controllers: [ {' '.join(not_active)} ]")
        msg = "Successfully switched controllers!"
        if strictness != STRICT:
            msg += f"\nDeactivated controllers: [ {' '.join(deactivated)} ]\nActivated controllers: [ {' '.join(activated)} ]"
            if failed:
                msg += f"\nSkipped ({mode}): [ {' '.join(failed)} ]"
        self.last_switch_message = msg
        return return_type.OK

    def _check_states(self, activate, deactivate):
        for n in activate:
            s = self.controllers[n]
            if s.state == UNCONFIGURED:
                return n, (f"Controller with name '{n}' is in 'unconfigured' state. The controller needs to be "
                           "configured to be in 'inactive' state before it can be checked and activated.")
            if s.state == FINALIZED:
                return n, f"Controller with name '{n}' is in 'finalized' state and cannot be activated."
            if s.state == ACTIVE and n not in deactivate:
                return n, f"Controller with name '{n}' is already active."
        for n in deactivate:
            if self.controllers[n].state != ACTIVE:
                return n, f"Controller with name '{n}' can not be deactivated since it is not active."
        for n in activate:
            problem = self._check_fallbacks(n)
            if problem:
                return n, problem
        return None

    def _check_fallbacks(self, name: str) -> str | None:
        """Upstream's check_fallback_controllers_state_pre_activation: each fallback of ``name``
        exists, is configured (inactive or active) and could take over (its interfaces available,
        or exported by an inactive controller in the same fallback list)."""
        spec = self.controllers[name]
        for fb in spec.fallback_controllers:
            other = self.controllers.get(fb)
            if other is None:
                return (f"Unable to find the fallback controller : '{fb}' of the controller : '{name}' within the "
                        "controller list")
            if other.state not in (INACTIVE, ACTIVE):
                return (f"Controller with name '{name}' cannot be activated, as its fallback controller : '{fb}' "
                        "need to be configured and be in inactive/active state!")
            try:
                cmds, states = self.required_interfaces(other)
            except Exception as exc:  # noqa: BLE001 - a student's configuration method may raise
                return f"Controller with name '{name}' cannot be activated: its fallback '{fb}' raised {exc!r}"
            for kind, keys, available in (("command", cmds, self.rm.command_interface_is_available),
                                          ("state", states, self.rm.state_interface_is_available)):
                for k in keys:
                    if available(k):
                        continue
                    owner = self.rm.owner_of(k) if self.rm.is_reference_interface(k) else None
                    if owner is None or owner not in self.controllers:
                        return (f"Controller with name '{name}' cannot be activated, as not all of its fallback "
                                f"controller's : '{fb}' {kind} interfaces are currently available!")
                    if self.controllers[owner].state == INACTIVE and owner not in spec.fallback_controllers:
                        return (f"Controller with name '{name}' cannot be activated, as the {kind} interface : "
                                f"'{k}' required by its fallback controller : '{fb}' is not available as the "
                                "controller is not in active state!. May be consider adding this controller to the "
                                f"fallback list of the controller : '{owner}' or already have it activated.")
        return None

    def _chain_cycle(self, start: str) -> list[str] | None:
        """The path start -> ... -> start through followers, if ``start`` is on a chaining cycle."""
        stack, seen = [(start, [start])], set()
        while stack:
            n, path = stack.pop()
            for f in self._followers(self.controllers[n]) if n in self.controllers else []:
                if f == start:
                    return path + [f]
                if f not in seen:
                    seen.add(f)
                    stack.append((f, path + [f]))
        return None

    def _check_chaining(self, activate, deactivate):
        active = {s.name for s in self._active}
        for n in activate:
            cycle = self._chain_cycle(n)
            if cycle:
                return n, (f"Unable to activate controller '{n}' since it is part of a chaining cycle "
                           f"{' -> '.join(cycle)}: a controller must not claim, directly or through others, "
                           "its own reference interfaces (break the cycle in the controllers' parameters)")
        for n in activate:
            for f in self._followers(self.controllers[n]):
                will_be_active = (f in active and f not in deactivate) or f in activate
                if not will_be_active:
                    return n, (f"Unable to activate controller '{n}' since its following controller '{f}' is not "
                               "active and will not be activated (activate them together)")
        for f in deactivate:
            if f in activate:
                continue
            for p in self._preceding(f):
                if p in active and p not in deactivate:
                    return f, (f"Unable to deactivate controller '{f}' since its preceding controller '{p}' is "
                               "active and will not be deactivated (deactivate them together)")
        return None

    def _check_interfaces(self, activate, deactivate) -> str | None:
        released = set()
        for n in deactivate:
            released.update(loan.name for loan in self.controllers[n].c.command_interfaces)
        becoming = set()
        for n in activate:
            becoming.update(self.rm.controller_interfaces(n)[0] + self.rm.controller_interfaces(n)[1])
        wanted: dict[str, str] = {}
        for n in activate:
            try:
                cmds, states = self.required_interfaces(self.controllers[n])
            except Exception as exc:  # noqa: BLE001 - a student's configuration method may raise
                return f"Unable to activate controller '{n}': its interface configuration raised {exc!r}"
            for k in cmds:
                if not self.rm.command_interface_exists(k) or (
                        not self.rm.command_interface_is_available(k) and k not in becoming):
                    return f"Unable to activate controller '{n}' since the command interface '{k}' is not available."
                if self.rm.command_interface_is_claimed(k) and k not in released:
                    return (f"Unable to activate controller '{n}' since the command interface '{k}' is currently "
                            "claimed by another controller.")
                if k in wanted:
                    return (f"Unable to activate controller '{n}' since the command interface '{k}' will be used "
                            "by another controller that is being activated.")
                wanted[k] = n
                owner = self.rm.components.get(self.rm.owner_of(k))
                if (owner is not None and owner.wrapper.state != ACTIVE
                        and not self.params.defaults.allow_controller_activation_with_inactive_hardware):
                    return (f"Unable to activate controller '{n}' since the command interface '{k}' belongs to "
                            f"hardware component '{owner.name}' in state '{owner.wrapper.state.label}' (activate the "
                            "hardware, or set defaults.allow_controller_activation_with_inactive_hardware: true)")
            for k in states:
                if not self.rm.state_interface_exists(k) or (
                        not self.rm.state_interface_is_available(k) and k not in becoming):
                    return f"Unable to activate controller '{n}' since the state interface '{k}' is not available."
        return None

    # --- executing a switch (in the loop, or right away when no loop runs) -------------------------------------
    def _do_switch(self, req: _SwitchRequest) -> None:
        self.rm.perform_command_mode_switch(req.start_interfaces, req.stop_interfaces)
        order = [s.name for s in self._ordered]
        for n in [n for n in order if n in req.deactivate]:      # preceding first
            self._deactivate(self.controllers[n])
        for n in req.from_chained:
            self.controllers[n].c.set_chained_mode(False)
        for n in req.to_chained:
            if not self.controllers[n].c.set_chained_mode(True):
                self.logger.error(f"Controller '{n}' refused to switch to chained mode")
        for n in [n for n in reversed(order) if n in req.activate]:  # followers first
            self._activate(self.controllers[n])
        self._active = [s for s in self._ordered if s.state == ACTIVE]
        req.done.set()

    def _activate(self, spec: ControllerSpec) -> bool:
        cmds, states = self.required_interfaces(spec)
        loans, state_loans = [], []
        try:
            for k in cmds:
                loans.append(self.rm.claim_command_interface(k, spec.name))
            for k in states:
                state_loans.append(self.rm.claim_state_interface(k))
        except ResourceError as exc:
            for loan in loans:
                loan.release()
            self.logger.error(f"Resource conflict for controller '{spec.name}'. {exc}")
            return False
        spec.c.assign_interfaces(loans, state_loans)
        state = spec.lifecycle.activate()
        if state != ACTIVE:
            spec.c.release_interfaces()
            why = spec.lifecycle.last_exception
            self.logger.error(f"After activation, controller '{spec.name}' is in state '{state.label}' ({state.id}), "
                              "expected 'active' (3)." + (f" ({why!r})" if why else ""))
            return False
        spec.counter = 0
        spec.last_update = None
        if spec.c.is_chainable():
            self.rm.set_controller_interfaces_available(spec.name, True)
        return True

    def _deactivate(self, spec: ControllerSpec) -> None:
        if spec.c.is_chainable():
            self.rm.set_controller_interfaces_available(spec.name, False)
            spec.c.set_chained_mode(False)
        state = spec.lifecycle.deactivate()
        spec.c.release_interfaces()
        if state != INACTIVE:
            self.logger.error(f"After deactivating, controller '{spec.name}' is in state '{state.label}', expected "
                              "'inactive'")

    def _deactivate_now(self, names, reason: str, quiet: bool = False) -> list[str]:
        """Deactivate ``names`` (and everything preceding them) immediately, inside the loop.

        An error deactivates with one ERROR line naming the victims; ``quiet`` (an orderly
        shutdown) logs each at INFO instead, as upstream's ``shutdown_controllers`` does."""
        group = set()
        for n in names:
            group.add(n)
            todo = [n]
            while todo:
                for p in self._preceding(todo.pop()):
                    if p not in group:
                        group.add(p)
                        todo.append(p)
        victims = [s for s in self._ordered if s.name in group and s.state == ACTIVE]
        if victims and not quiet:
            self.logger.error(f"Deactivating controllers: [ {' '.join(s.name for s in victims)} ] {reason}")
        for s in victims:
            if quiet:
                self.logger.info(f"Deactivating controller '{s.name}'")
            self._deactivate(s)
        for s in self._active:
            if s.c.is_chainable() and s.c.is_in_chained_mode() and s.state == ACTIVE and not any(
                    s.name in self._followers(p) for p in self._active if p.state == ACTIVE and p is not s):
                s.c.set_chained_mode(False)
        self._active = [s for s in self._ordered if s.state == ACTIVE]
        return [s.name for s in victims]

    # --- the loop's three stages ---------------------------------------------------------------------------------
    def read(self, time: float, period: float) -> None:
        status = self.rm.read(time, period)
        if not status.ok:
            self._hardware_failed(status, "read")

    def write(self, time: float, period: float) -> None:
        status = self.rm.write(time, period)
        if not status.ok:
            self._hardware_failed(status, "write")

    def _hardware_failed(self, status, stage: str) -> None:
        if status.failed_hardware_names:
            failed = set(status.failed_hardware_names)
            self.logger.error(f"Deactivating following hardware components as their {stage} cycle resulted in an "
                              f"error: [ {' '.join(status.failed_hardware_names)} ]")
            users = [s.name for s in self._active
                     if any(self.rm.owner_of(loan.name) in failed for loan in s.c.command_interfaces + s.c.state_interfaces)]
            self._deactivate_now(users, "as their used interfaces of hardware components went into error")
        if status.deactivated_hardware_names and self.params.defaults.deactivate_controllers_on_hardware_self_deactivate:
            gone = set(status.deactivated_hardware_names)
            users = [s.name for s in self._active
                     if any(self.rm.owner_of(loan.name) in gone for loan in s.c.command_interfaces)]
            self._deactivate_now(users, "as their hardware components deactivated themselves")

    def update(self, time: float, period: float) -> return_type:
        """Update every active controller due this cycle (preceding first), then apply a pending switch.

        Returns upstream's cycle result: OK, or the failing controller's ERROR in the cycle one
        failed (raising counts as ERROR); the failed controllers are deactivated either way."""
        failed = None
        result = return_type.OK
        for spec in self._active:
            if spec.ticks > 1:
                spec.counter += 1
                if spec.counter < spec.ticks and spec.last_update is not None:
                    continue
                spec.counter = 0
            dt = (time - spec.last_update) if spec.last_update is not None else (
                period if spec.ticks == 1 else 1.0 / spec.c.update_rate)
            spec.last_update = time
            t0 = _time.perf_counter_ns()
            try:
                ret = spec.c.update(time, dt)
            except Exception as exc:  # noqa: BLE001 - nothing in a controller takes the loop down
                ret = return_type.ERROR
                self.logger.error(f"Caught exception of type : {type(exc).__name__} while updating controller "
                                  f"'{spec.name}': {exc}")
            took = _time.perf_counter_ns() - t0
            spec.updates += 1
            if took > spec.max_update_ns:
                spec.max_update_ns = took
            if took * spec.c.update_rate > 1_000_000_000:
                spec.overruns += 1
                if spec.overruns == 1 and self.params.overruns.print_warnings:
                    self.logger.warning(f"Controller '{spec.name}' overran its period: update took {took / 1e6:.3f} ms, "
                                        f"period {1e3 / spec.c.update_rate:.3f} ms (counted in its overruns; it stays "
                                        "active)")
            if ret != return_type.OK:
                if failed is None:
                    failed = []
                failed.append(spec.name)
                result = ret if isinstance(ret, return_type) else return_type.ERROR
        if failed:
            self._controllers_failed(failed)
        if self._pending is not None and self._switch_lock.acquire(blocking=False):
            try:
                req, self._pending = self._pending, None
            finally:
                self._switch_lock.release()
            if req is not None:
                self._do_switch(req)
        return result

    def _controllers_failed(self, failed: list[str]) -> None:
        group = self._chain_group(failed)
        victims = [s for s in self._ordered if s.name in group and s.state == ACTIVE]
        self.logger.error("Deactivating following controllers as their update resulted in an error : [ "
                          f"{' '.join(failed)} ]" + (f" (with their chain: [ {' '.join(s.name for s in victims)} ])"
                                                     if len(victims) > len(failed) else ""))
        for s in victims:
            self._deactivate(s)
        fallbacks = [fb for n in failed for fb in self.controllers[n].fallback_controllers]
        self._active = [s for s in self._ordered if s.state == ACTIVE]
        missing = [fb for fb in fallbacks if fb not in self.controllers or self.controllers[fb].state != INACTIVE]
        if missing:
            self.logger.error(f"Fallback controllers [ {' '.join(missing)} ] are not loaded and configured "
                              f"(inactive): none of [ {' '.join(fallbacks)} ] is activated")
            fallbacks = []
        if fallbacks:
            problem = self._check_interfaces([f for f in fallbacks if self.controllers[f].state == INACTIVE], [])
            if problem:
                self.logger.error(f"Unable to activate fallback controllers [ {' '.join(fallbacks)} ]: {problem}")
            else:
                self.logger.info(f"Activating fallback controllers : [ {' '.join(fallbacks)} ]")
                for n in reversed([s.name for s in self._ordered]):
                    if n in fallbacks and self.controllers[n].state == INACTIVE:
                        self._activate(self.controllers[n])
                self._active = [s for s in self._ordered if s.state == ACTIVE]

    def _fail_pending_switch(self) -> None:
        with self._switch_lock:
            self._pending = None

    def enable_timing(self, capacity: int = 100_000):
        """Record per-stage durations of every deterministic cycle in ``self.timing`` (a CycleTimes)."""
        from .loop import CycleTimes

        self.timing = CycleTimes(capacity)
        return self.timing

    def cycle(self, time: float | None = None, period: float | None = None) -> return_type:
        """One read -> update -> write at ``time`` (default: the next tick of the manager's clock);
        returns what :meth:`update` returned."""
        if period is None:
            period = self.period
        if time is None:
            time = self.time + period
        if self.timing is not None:
            from .loop import timed_cycle

            return timed_cycle(self, self.timing, time, period)
        self.time = time
        self.read(time, period)
        ret = self.update(time, period)
        self.write(time, period)
        self.cycles += 1
        return ret

    def run_realtime(self, seconds: float, **kwargs):
        """The wall-clock loop (see :func:`robocourse.control.manager.loop.run_realtime`)."""
        from .loop import run_realtime

        return run_realtime(self, seconds, **kwargs)

    def step(self, n: int = 1) -> None:
        """``n`` deterministic cycles at the manager's period, with the bus callbacks due in between.

        On a simulated-time context the sim clock advances with the cycles, so the controllers'
        nodes stamp messages with the cycle's time and subscriptions are delivered before the
        cycle that should see them.
        """
        sim = getattr(self.context, "sim", None)
        for _ in range(n):
            t = self.time + self.period
            if sim is not None:
                sim.advance_to(int(round(t * 1e9)))
            if self._executor is not None:
                self.executor.spin_some()
            self.cycle(t, self.period)
        if self._executor is not None:
            self.executor.spin_some()

    def spin_for(self, seconds: float) -> None:
        """Run ``seconds`` of simulated time: ``round(seconds * update_rate)`` cycles."""
        if not math.isfinite(seconds) or seconds < 0:
            raise ValueError(f"seconds must be a finite number >= 0, got {seconds!r}")
        self.step(int(round(seconds * self.update_rate)))

    def spin_until_future_complete(self, future, timeout_sec: float | None = None) -> bool:
        """Step the manager (cycles and bus callbacks, on its simulated time) until ``future`` is
        done, as rclpy's ``executor.spin_until_future_complete`` spins; ``timeout_sec`` is cycle
        time (None: no limit). Returns ``future.done()``. For a service or action call to a
        controller whose answer needs the loop to run (a JTC goal, a switch)."""
        if timeout_sec is not None and (not isinstance(timeout_sec, (int, float)) or isinstance(timeout_sec, bool)
                                        or not math.isfinite(timeout_sec) or timeout_sec < 0):
            raise ValueError(f"timeout_sec must be None (no limit) or a finite number of seconds >= 0, "
                             f"got {timeout_sec!r}")
        if not hasattr(future, "done"):
            raise TypeError(f"spin_until_future_complete needs a future (call_async(), send_goal_async(), "
                            f"get_result_async()), got {type(future).__name__}")
        cycles = None if timeout_sec is None else int(math.ceil(timeout_sec * self.update_rate - 1e-9))
        n = 0
        if self._executor is not None:
            self.executor.spin_some()
        while not future.done() and (cycles is None or n < cycles):
            self.step(1)
            n += 1
        return future.done()

    # --- hardware lifecycle -------------------------------------------------------------------------------------------
    def set_hardware_component_state(self, name: str, target) -> return_type:
        """Move a hardware component; controllers using it are deactivated first when it leaves ACTIVE/INACTIVE."""
        target = as_state(target)
        comp = self.rm.components.get(name)
        if comp is None:
            self.logger.error(f"hardware component '{name}' does not exist; loaded: {sorted(self.rm.components)}")
            return return_type.ERROR
        keys = set(comp.state_keys) | set(comp.command_keys)
        if target in (UNCONFIGURED, FINALIZED):
            users = [s.name for s in self._active
                     if any(loan.name in keys for loan in s.c.command_interfaces + s.c.state_interfaces)]
            self._deactivate_now(users, f"as hardware component '{name}' goes to '{target.label}'")
        elif target == INACTIVE:
            users = [s.name for s in self._active if any(loan.name in keys for loan in s.c.command_interfaces)]
            self._deactivate_now(users, f"as hardware component '{name}' goes to 'inactive'")
        return self.rm.set_component_state(name, target)

    def shutdown(self) -> None:
        """Deactivate every controller, then deactivate and finalize the hardware (on Ctrl-C too).

        Logged at INFO like upstream's ``ControllerManager::shutdown_controllers()``: an orderly
        shutdown is not an error."""
        if self._active:
            self.logger.info("Shutting down all controllers in the controller manager.")
        self._deactivate_now([s.name for s in self._active], "on shutdown", quiet=True)
        self.rm.shutdown_components()

    # --- introspection data (what the list_* services return) --------------------------------------------------------
    def list_controllers(self):
        """controller_manager's list_controllers service, field by field as upstream fills it:
        required interfaces, chain connections and exported interfaces only for an inactive or
        active controller (empty while unconfigured); exported reference/state interfaces without
        the ``<controller>/`` prefix; a chain connection's ``reference_interfaces`` lists the
        interface part (after the first ``/``) of every required command interface that names a
        loaded controller."""
        from ..msgs import ChainConnection, ControllerState

        out = []
        for s in self._ordered:
            cmds, states, refs, exported, chains = [], [], [], [], []
            if s.state in (INACTIVE, ACTIVE):
                try:
                    cmds, states = self.required_interfaces(s)
                except Exception:  # noqa: BLE001 - a student's configuration method may raise
                    cmds, states = [], []
                targets, types = [], []
                for k in cmds:
                    prefix, _, rest = k.partition("/")
                    if prefix in self.controllers:
                        if prefix not in targets:
                            targets.append(prefix)
                        types.append(rest)
                chains = [ChainConnection(name=t, reference_interfaces=list(types)) for t in sorted(targets)]
                if s.c.is_chainable():
                    full_refs, full_exported = self.rm.controller_interfaces(s.name)
                    cut = len(s.name) + 1
                    refs, exported = [k[cut:] for k in full_refs], [k[cut:] for k in full_exported]
            out.append(ControllerState(
                name=s.name, state=s.state.label, type=s.type, is_async=s.c.is_async,
                update_rate=int(s.c.update_rate), claimed_interfaces=[loan.name for loan in s.c.command_interfaces],
                required_command_interfaces=cmds, required_state_interfaces=states,
                is_chainable=s.c.is_chainable(), is_chained=s.c.is_chainable() and s.c.is_in_chained_mode(),
                exported_state_interfaces=exported, reference_interfaces=refs, chain_connections=chains))
        return out

    def list_hardware_interfaces(self):
        from ..msgs import HardwareInterface

        cmd = [HardwareInterface(name=k, data_type="double", is_available=self.rm.command_interface_is_available(k),
                                 is_claimed=self.rm.command_interface_is_claimed(k))
               for k in sorted(self.rm.command_interface_keys())]
        st = [HardwareInterface(name=k, data_type="double", is_available=self.rm.state_interface_is_available(k),
                                is_claimed=False) for k in sorted(self.rm.state_interface_keys())]
        return cmd, st

    def list_hardware_components(self):
        from ..msgs import HardwareComponentState, HardwareInterface, LifecycleState

        out = []
        for name, c in self.rm.components.items():
            st = c.wrapper.state
            out.append(HardwareComponentState(
                name=name, type=c.info.type, class_type=c.info.hardware_plugin_name,
                plugin_name=c.info.hardware_plugin_name, state=LifecycleState(id=st.id, label=st.label),
                is_async=c.info.is_async, rw_rate=c.info.rw_rate or self.update_rate,
                command_interfaces=[HardwareInterface(name=k, data_type="double",
                                                      is_available=self.rm.command_interface_is_available(k),
                                                      is_claimed=self.rm.command_interface_is_claimed(k))
                                    for k in c.command_keys],
                state_interfaces=[HardwareInterface(name=k, data_type="double",
                                                    is_available=self.rm.state_interface_is_available(k),
                                                    is_claimed=False) for k in c.state_keys]))
        return out
