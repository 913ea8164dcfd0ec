"""The resource manager: owns the hardware components, their interface values and the claims.

Counterpart: ``hardware_interface::ResourceManager`` (ros2_control:hardware_interface/src/
resource_manager.cpp). All state values live in one float64 array and all command values in
another, allocated once when the components are loaded; each component gets numpy views of its
own slots and each controller gets loans (:mod:`.loaned`) pointing into the same memory.

Availability follows upstream: an UNCONFIGURED (or FINALIZED) component offers nothing; an
INACTIVE one offers its state interfaces and, as upstream still does (ros2_control#931), its
command interfaces; an ACTIVE one everything. read() runs for INACTIVE and ACTIVE components,
write() for ACTIVE ones. A read()/write() that returns ERROR or raises runs the component's
error handler (on_error), makes all its interfaces unavailable and is reported back with the
component's name; write() returning DEACTIVATE makes the component INACTIVE (from read() it is
treated as ERROR, as upstream: "DEACTIVATE returned from read cycle is treated the same as
ERROR."). Hardware in the
same ``<group>`` fails together. The first NaN a component reads into a state is logged once
(upstream passes it on silently; the loop carries on either way).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .. import pluginlib
from ..hardware.component import HardwareComponent, HardwareComponentInterface
from ..hardware.info import HardwareInfo, URDFError, parse_control_resources_from_urdf
from ..hardware.types import (
    ACTIVE,
    FINALIZED,
    INACTIVE,
    UNCONFIGURED,
    UNKNOWN,
    State,
    as_state,
    return_type,
)
from ..log import LogSink
from .loaned import LoanedCommandInterface, LoanedStateInterface


class ResourceError(RuntimeError):
    """A claim or lookup the resource manager refuses (upstream throws std::runtime_error)."""


@dataclass
class HardwareReadWriteStatus:
    """What read()/write() report: OK or not, and which components failed."""

    ok: bool = True
    result: return_type = return_type.OK
    failed_hardware_names: list[str] = field(default_factory=list)
    deactivated_hardware_names: list[str] = field(default_factory=list)


_OK = HardwareReadWriteStatus()


class _Component:
    """Bookkeeping for one loaded component (the wrapper plus its slots and rate)."""

    def __init__(self, wrapper: HardwareComponent, state_keys, command_keys):
        self.wrapper = wrapper
        self.impl = wrapper.impl
        self.name = wrapper.name
        self.info = wrapper.info
        self.state_keys = state_keys
        self.command_keys = command_keys
        self.last: dict[str, float | None] = {"read": None, "write": None}
        self.nan_states: set[str] = set()


class ResourceManager:
    """``ResourceManager(urdf)`` loads, initialises and (by default) activates every component.

    ``components={"RRBot": MyArm()}`` supplies an instance for a ``<ros2_control name>``
    instead of creating one from its ``<plugin>`` (a student's class needs no registration).
    ``initial_states={"RRBot": "unconfigured"}`` mirrors the CM parameters
    ``hardware_components_initial_state.*``; everything else is activated (upstream default).
    """

    def __init__(self, urdf: str | None = None, *, update_rate: float = 100.0, components: dict | None = None,
                 initial_states: dict | None = None, activate_all: bool = True, log: LogSink | None = None,
                 handle_exceptions: bool = True):
        self.update_rate = float(update_rate)
        self.handle_exceptions = handle_exceptions
        self.log = log if log is not None else LogSink()
        self.logger = self.log.logger("resource_manager")
        self.components: dict[str, _Component] = {}
        self.state_values = np.zeros(0)
        self.command_values = np.zeros(0)
        self._state_map: dict[str, tuple[np.ndarray, int]] = {}
        self._command_map: dict[str, tuple[np.ndarray, int]] = {}
        self._owner: dict[str, str] = {}          # interface key -> component or controller name
        self._reference_owner: dict[str, str] = {}
        self.available_states: set[str] = set()
        self.available_commands: set[str] = set()
        self.claimed: dict[str, str] = {}          # command key -> claiming controller ("" if anonymous)
        self._read_list: list[_Component] = []
        self._write_list: list[_Component] = []
        self._nan_any = False
        self.is_initialized = False
        if urdf is not None:
            self.load_and_initialize_components(urdf, components=components)
            if activate_all:
                self.activate_components(initial_states or {})

    def activate_components(self, initial_states: dict) -> None:
        """Bring every component to its initial state: ``initial_states[name]`` or ACTIVE (upstream's default)."""
        for name in self.components:
            self.set_component_state(name, as_state(initial_states.get(name, "active")))

    def reset(self) -> None:
        """Forget a partially loaded description (before any controller used it)."""
        self.components.clear()
        self._state_map.clear()
        self._command_map.clear()
        self._owner.clear()
        self.available_states.clear()
        self.available_commands.clear()
        self.claimed.clear()
        self.state_values = np.zeros(0)
        self.command_values = np.zeros(0)
        self.is_initialized = False
        self._update_lists()

    # --- loading ----------------------------------------------------------------------------------
    def load_and_initialize_components(self, urdf: str, components: dict | None = None) -> None:
        """Parse the URDF, create each component from its plugin, run on_init, allocate the values."""
        infos = parse_control_resources_from_urdf(urdf)
        components = components or {}
        unknown = set(components) - {i.name for i in infos}
        if unknown:
            raise ValueError(f"components={sorted(unknown)} name no <ros2_control> element of the URDF "
                             f"(it has {[i.name for i in infos]}); use the name attribute of <ros2_control>")
        wrappers = []
        for info in infos:
            if info.is_async:
                raise URDFError(f'is_async="true" on <ros2_control name="{info.name}"> is not supported by robocourse '
                                "(every component is read and written in the manager's loop)", info.line,
                                'remove is_async (or set is_async="false")')
            impl = components.get(info.name)
            if impl is None:
                try:
                    cls = pluginlib.load(info.hardware_plugin_name, pluginlib.HARDWARE_BASE,
                                         f"hardware_interface::{info.type.capitalize()}Interface")
                except pluginlib.PluginlibException as exc:
                    raise URDFError(str(exc), info.plugin_line,
                                    f"use a declared plugin name, or register your class first: "
                                    f"robocourse.control.pluginlib.register('{info.hardware_plugin_name}', MyClass)"
                                    ) from None
                impl = cls()
            if not isinstance(impl, HardwareComponentInterface):
                raise TypeError(f"component for '{info.name}' is {impl!r}; it must be an instance of a "
                                "SystemInterface, ActuatorInterface or SensorInterface subclass")
            if impl.kind != info.type:
                raise URDFError(f"'{info.name}' is declared type=\"{info.type}\" but its plugin "
                                f"{type(impl).__name__} is a {impl.kind}", info.line,
                                f"write type=\"{impl.kind}\" or use a {info.type} plugin")
            self._check_supported(impl, info)
            impl._logger = self.log.logger(info.name)
            wrappers.append(HardwareComponent(impl, info))
        for w in wrappers:
            if w.initialize() is not UNCONFIGURED:
                detail = f": {w.last_exception!r}" if w.last_exception else ""
                raise RuntimeError(f"Failed to initialize hardware '{w.name}' (on_init did not return "
                                   f"SUCCESS{detail}); check its <param> values")
        self._allocate(wrappers)
        self.is_initialized = True

    @staticmethod
    def _check_supported(impl, info: HardwareInfo) -> None:
        for kind, allowed in (("command", impl.SUPPORTED_COMMAND_INTERFACES),
                              ("state", impl.SUPPORTED_STATE_INTERFACES)):
            if allowed is None:
                continue
            for comp in info.joints:
                for itf in getattr(comp, f"{kind}_interfaces"):
                    if itf.name not in allowed:
                        raise URDFError(f"{info.hardware_plugin_name} has no {kind} interface '{itf.name}' "
                                        f"(joint '{comp.name}' of '{info.name}')", itf.line,
                                        f"use one of {list(allowed)}")

    def _allocate(self, wrappers) -> None:
        exported = []
        n_state = n_cmd = 0
        for w in wrappers:
            st = w.impl.export_state_interfaces()
            cm = w.impl.export_command_interfaces()
            exported.append((w, st, cm))
            n_state += len(st)
            n_cmd += len(cm)
        self.state_values = np.full(n_state, math.nan)
        self.command_values = np.full(n_cmd, math.nan)
        offsets = {"state": 0, "command": 0}
        for w, st, cm in exported:
            skeys, s0, s1 = self._place(w, st, "state", self._state_map, self.state_values, offsets)
            ckeys, c0, c1 = self._place(w, cm, "command", self._command_map, self.command_values, offsets)
            w.impl.state_values = self.state_values[s0:s1]
            w.impl.command_values = self.command_values[c0:c1]
            w.impl.state_index = {k: i for i, k in enumerate(skeys)}
            w.impl.command_index = {k: i for i, k in enumerate(ckeys)}
            self.components[w.name] = _Component(w, skeys, ckeys)
        self._update_lists()

    def _place(self, w, descriptions, kind: str, table: dict, values: np.ndarray, offsets: dict):
        """Give each exported interface of ``w`` the next slot of ``values``; (keys, first, end)."""
        first = offsets[kind]
        keys = []
        for d in descriptions:
            if d.name in table:
                raise URDFError(f"{kind} interface '{d.name}' is exported twice ('{self._owner[d.name]}' and "
                                f"'{w.name}')", w.info.line, "each interface belongs to one component")
            i = offsets[kind]
            table[d.name] = (values, i)
            self._owner[d.name] = w.name
            values[i] = d.initial_value
            keys.append(d.name)
            offsets[kind] = i + 1
        return keys, first, offsets[kind]

    # --- lookups ------------------------------------------------------------------------------------
    def state_interface_keys(self) -> list[str]:
        return list(self._state_map)

    def command_interface_keys(self) -> list[str]:
        return list(self._command_map)

    def available_state_interfaces(self) -> list[str]:
        return [k for k in self._state_map if k in self.available_states]

    def available_command_interfaces(self) -> list[str]:
        return [k for k in self._command_map if k in self.available_commands]

    def state_interface_exists(self, key: str) -> bool:
        return key in self._state_map

    def command_interface_exists(self, key: str) -> bool:
        return key in self._command_map

    def state_interface_is_available(self, key: str) -> bool:
        return key in self.available_states

    def command_interface_is_available(self, key: str) -> bool:
        return key in self.available_commands

    def command_interface_is_claimed(self, key: str) -> bool:
        return key in self.claimed

    def owner_of(self, key: str) -> str:
        """The component (or controller, for reference interfaces) that exports ``key``."""
        return self._owner.get(key, "")

    def is_reference_interface(self, key: str) -> bool:
        return key in self._reference_owner

    def value(self, key: str) -> float:
        """Current value of a state (or, if no such state, command) interface."""
        if key in self._state_map:
            arr, i = self._state_map[key]
        elif key in self._command_map:
            arr, i = self._command_map[key]
        else:
            raise KeyError(f"no state or command interface '{key}'; state interfaces: "
                           f"{sorted(self._state_map)}, command interfaces: {sorted(self._command_map)}")
        return float(arr[i])

    def command_value(self, key: str) -> float:
        """Current value of a command (or controller reference) interface: what the controllers
        wrote this cycle, what write() sends (upstream: ``get_optional()`` on the handle)."""
        if key not in self._command_map:
            raise KeyError(f"no command interface '{key}'; command interfaces: {sorted(self._command_map)} "
                           "(a state interface's value: value(key))")
        arr, i = self._command_map[key]
        return float(arr[i])

    # --- claims ------------------------------------------------------------------------------------
    def claim_state_interface(self, key: str) -> LoanedStateInterface:
        if key not in self._state_map:
            raise ResourceError(f"State interface with key '{key}' does not exist")
        arr, i = self._state_map[key]
        return LoanedStateInterface(key, arr, i)

    def claim_command_interface(self, key: str, owner: str = "") -> LoanedCommandInterface:
        if key not in self._command_map:
            raise ResourceError(f"Command interface with '{key}' does not exist")
        if key in self.claimed:
            raise ResourceError(f"Command interface with key '{key}' is already claimed")
        self.claimed[key] = owner
        arr, i = self._command_map[key]
        return LoanedCommandInterface(key, arr, i, self.release_command_interface)

    def release_command_interface(self, key: str) -> None:
        self.claimed.pop(key, None)

    # --- controller reference / exported state interfaces ------------------------------------------
    def import_controller_reference_interfaces(self, controller: str, keys, array: np.ndarray) -> None:
        for i, key in enumerate(keys):
            if key in self._command_map:
                raise ResourceError(f"Reference interface '{key}' of controller '{controller}' clashes with an "
                                    f"existing command interface of '{self._owner[key]}'")
            self._command_map[key] = (array, i)
            self._owner[key] = controller
            self._reference_owner[key] = controller

    def import_controller_exported_state_interfaces(self, controller: str, keys, array: np.ndarray) -> None:
        for i, key in enumerate(keys):
            if key in self._state_map:
                raise ResourceError(f"Exported state interface '{key}' of controller '{controller}' clashes with "
                                    f"an existing state interface of '{self._owner[key]}'")
            self._state_map[key] = (array, i)
            self._owner[key] = controller
            self._reference_owner[key] = controller

    def controller_interfaces(self, controller: str) -> tuple[list[str], list[str]]:
        """(reference interfaces, exported state interfaces) of ``controller``."""
        refs = [k for k in self._command_map if self._reference_owner.get(k) == controller]
        states = [k for k in self._state_map if self._reference_owner.get(k) == controller]
        return refs, states

    def set_controller_interfaces_available(self, controller: str, available: bool) -> None:
        refs, states = self.controller_interfaces(controller)
        for target, keys in ((self.available_commands, refs), (self.available_states, states)):
            for k in keys:
                (target.add if available else target.discard)(k)

    def remove_controller_interfaces(self, controller: str) -> None:
        refs, states = self.controller_interfaces(controller)
        for k in refs:
            self._command_map.pop(k)
            self.available_commands.discard(k)
            self.claimed.pop(k, None)
        for k in states:
            self._state_map.pop(k)
            self.available_states.discard(k)
        for k in refs + states:
            self._owner.pop(k, None)
            self._reference_owner.pop(k, None)

    # --- lifecycle -----------------------------------------------------------------------------------
    def set_component_state(self, name: str, target) -> return_type:
        """Drive component ``name`` to ``target`` (State, id or label) through the legal transitions."""
        if name not in self.components:
            raise ValueError(f"hardware component '{name}' does not exist; loaded components: "
                             f"{sorted(self.components)}")
        target = as_state(target)
        w = self.components[name].wrapper
        if target == UNKNOWN:
            raise ValueError("a component cannot be set to 'unknown'; use unconfigured, inactive, active or finalized")
        steps = {
            UNCONFIGURED: {INACTIVE: ["cleanup"], ACTIVE: ["deactivate", "cleanup"]},
            INACTIVE: {UNCONFIGURED: ["configure"], ACTIVE: ["deactivate"]},
            ACTIVE: {UNCONFIGURED: ["configure", "activate"], INACTIVE: ["activate"]},
        }
        if target == FINALIZED:
            w.shutdown()
        else:
            for step in steps[target].get(w.state, []):
                before = w.state
                getattr(w, step)()
                if w.state == before:
                    break
        self._update_lists()
        if w.state != target:
            detail = f" ({w.last_exception!r})" if w.last_exception else ""
            self.logger.error(f"Failed to set hardware component '{name}' to state '{target.label}': it is "
                              f"'{w.state.label}'{detail}")
            return return_type.ERROR
        self.logger.info(f"Successful '{target.label}' of hardware '{name}'")
        return return_type.OK

    def _update_lists(self) -> None:
        for c in self.components.values():
            s = c.wrapper.state
            on_states = s in (INACTIVE, ACTIVE)
            for k in c.state_keys:
                (self.available_states.add if on_states else self.available_states.discard)(k)
            for k in c.command_keys:
                (self.available_commands.add if on_states else self.available_commands.discard)(k)
        self._read_list = [c for c in self.components.values() if c.wrapper.state in (INACTIVE, ACTIVE)]
        self._write_list = [c for c in self.components.values()
                            if c.wrapper.state == ACTIVE and c.info.type != "sensor"]

    def get_components_status(self) -> dict[str, State]:
        return {name: c.wrapper.state for name, c in self.components.items()}

    def shutdown_components(self) -> None:
        """Deactivate and shut down every component (what upstream does on CM destruction)."""
        for name, c in self.components.items():
            if c.wrapper.state == ACTIVE:
                c.wrapper.deactivate()
            c.wrapper.shutdown()
            self.logger.info(f"hardware '{name}' is {c.wrapper.state.label}")
        self._update_lists()

    # --- command mode switch --------------------------------------------------------------------------
    def _by_component(self, keys):
        out: dict[str, list[str]] = {}
        for k in keys:
            owner = self._owner.get(k)
            if owner in self.components:
                out.setdefault(owner, []).append(k)
        return out

    def prepare_command_mode_switch(self, start, stop) -> bool:
        for k in list(start) + list(stop):
            if k not in self._command_map:
                self.logger.error(f"Can not switch command mode: command interface '{k}' does not exist")
                return False
        starts, stops = self._by_component(start), self._by_component(stop)
        for name in sorted(set(starts) | set(stops)):
            c = self.components[name]
            if c.wrapper.state not in (INACTIVE, ACTIVE):
                continue
            try:
                ok = c.impl.prepare_command_mode_switch(starts.get(name, []), stops.get(name, [])) == return_type.OK
            except Exception as exc:
                self.logger.error(f"Component '{name}' raised in prepare_command_mode_switch: {exc!r}")
                ok = False
            if not ok:
                self.logger.error(f"Component '{name}' did not accept command interfaces combination: \n"
                                  f"\tstart interfaces: [ {' '.join(starts.get(name, []))} ]\n"
                                  f"\tstop interfaces: [ {' '.join(stops.get(name, []))} ]")
                return False
        return True

    def perform_command_mode_switch(self, start, stop) -> bool:
        starts, stops = self._by_component(start), self._by_component(stop)
        ok = True
        for name in sorted(set(starts) | set(stops)):
            c = self.components[name]
            try:
                res = c.impl.perform_command_mode_switch(starts.get(name, []), stops.get(name, []))
            except Exception:
                res = return_type.ERROR
            if res != return_type.OK:
                self.logger.error(f"Component '{name}' could not perform switch")
                ok = False
        return ok

    # --- the cyclic part (hot path) -------------------------------------------------------------------
    def _due(self, c: _Component, last: float | None, time: float) -> tuple[bool, float]:
        rate = c.info.rw_rate
        if rate <= 0 or rate == self.update_rate:
            return True, (time - last) if last is not None else 1.0 / self.update_rate
        if last is None:
            return True, 1.0 / rate
        t = time - last
        return abs(t * rate - 1.0) <= abs((t + 1.0 / self.update_rate) * rate - 1.0), t

    def _run(self, components, stage: str, time: float, period: float):
        """Call ``stage`` ("read"/"write") of each due component; return the failures or None."""
        failed = None
        for c in components:
            if c.info.rw_rate:
                due, dt = self._due(c, c.last[stage], time)
                if not due:
                    continue
            else:
                dt = period
            c.last[stage] = time
            try:
                ret = (c.impl.read if stage == "read" else c.impl.write)(time, dt)
            except Exception as exc:
                if not self.handle_exceptions:
                    raise
                where = "reading from" if stage == "read" else "writing to"
                self.logger.error(f"Exception of type : {type(exc).__name__} occurred while {where} "
                                  f"hardware '{c.name}': {exc}")
                ret = return_type.ERROR
            if ret is not return_type.OK and ret != return_type.OK:
                if failed is None:
                    failed = []
                failed.append((c, ret, stage))
        return failed

    def read(self, time: float, period: float) -> HardwareReadWriteStatus:
        """Call read() of every INACTIVE/ACTIVE component; failures are handled, never raised."""
        failed = self._run(self._read_list, "read", time, period)
        if failed is None:
            self._check_nan()
            return _OK
        return self._handle_failures(failed)

    def write(self, time: float, period: float) -> HardwareReadWriteStatus:
        """Call write() of every ACTIVE non-sensor component; ERROR/DEACTIVATE handled like upstream."""
        failed = self._run(self._write_list, "write", time, period)
        return _OK if failed is None else self._handle_failures(failed)

    def _handle_failures(self, failed) -> HardwareReadWriteStatus:
        status = HardwareReadWriteStatus(ok=False, result=return_type.ERROR)
        for c, ret, what in failed:
            if ret == return_type.DEACTIVATE and what == "read":
                # upstream's rule: a component cannot deactivate itself from read()
                self.logger.warning(f"hardware '{c.name}': DEACTIVATE returned from read cycle is treated the "
                                    "same as ERROR.")
                ret = return_type.ERROR
            if ret == return_type.DEACTIVATE:
                self.logger.warning(f"Deactivating hardware component '{c.name}' because its {what}() "
                                    "returned DEACTIVATE")
                c.wrapper.deactivate()
                status.deactivated_hardware_names.append(c.name)
                if status.result != return_type.ERROR or len(status.failed_hardware_names) == 0:
                    status.result = return_type.DEACTIVATE
                continue
            if ret != return_type.ERROR:
                self.logger.error(f"hardware '{c.name}' {what}() returned {ret!r}; expected a return_type: "
                                  "treated as ERROR")
            group = [c] + ([o for o in self.components.values() if o.info.group and o.info.group == c.info.group
                            and o is not c] if c.info.group else [])
            for g in group:
                if g.name in status.failed_hardware_names:
                    continue
                before = g.wrapper.state
                g.wrapper.error()
                status.failed_hardware_names.append(g.name)
                why = f"its {what}() returned ERROR" if g is c else f"'{c.name}' of its group '{c.info.group}' failed"
                self.logger.error(f"Deactivating hardware component '{g.name}' ({before.label} -> "
                                  f"{g.wrapper.state.label}) because {why}; all its interfaces are now unavailable")
        if status.failed_hardware_names:
            status.result = return_type.ERROR
        self._update_lists()
        return status

    def _check_nan(self) -> None:
        x = self.state_values
        d = x.dot(x)
        if d == d:
            if self._nan_any:
                self._nan_any = False
                for c in self.components.values():
                    c.nan_states.clear()
            return
        self._nan_any = True
        for c in self._read_list:
            vals = c.impl.state_values
            if not np.isnan(vals).any():
                c.nan_states.clear()
                continue
            now = {k for k, v in zip(c.state_keys, vals) if v != v}
            new = now - c.nan_states
            c.nan_states = now
            if new:
                self.logger.warning(f"hardware '{c.name}' read NaN into state interface(s) "
                                    f"{sorted(new)}; controllers receive NaN until it reads a number again")
