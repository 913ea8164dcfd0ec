"""The controller manager's services on the bus (what ``ros2 control`` and the spawner call).

Counterpart: the services controller_manager::ControllerManager creates under its node name:
``~/list_controllers``, ``~/list_controller_types``, ``~/list_hardware_interfaces``,
``~/list_hardware_components``, ``~/load_controller``, ``~/configure_controller``,
``~/switch_controller``, ``~/unload_controller``, ``~/set_hardware_component_state``.
Each callback calls the same Python method a notebook would (so the two cannot disagree).
"""

from __future__ import annotations

from .. import pluginlib
from ..hardware.types import as_state, return_type
from ..msgs import (
    ConfigureController,
    LifecycleState,
    ListControllers,
    ListControllerTypes,
    ListHardwareComponents,
    ListHardwareInterfaces,
    LoadController,
    SetHardwareComponentState,
    SwitchController,
    UnloadController,
)


def attach_services(cm, node) -> None:
    """Create the controller_manager services of ``cm`` on ``node``."""

    def list_controllers(req, resp):
        resp.controller = cm.list_controllers()
        return resp

    def list_types(req, resp):
        for base in (pluginlib.CONTROLLER_BASE,):
            for t in pluginlib.declared(base):
                resp.types.append(t)
                resp.base_classes.append(base)
        return resp

    def list_interfaces(req, resp):
        resp.command_interfaces, resp.state_interfaces = cm.list_hardware_interfaces()
        return resp

    def list_components(req, resp):
        resp.component = cm.list_hardware_components()
        return resp

    def load(req, resp):
        resp.ok = cm.load_controller(req.name) is not None
        return resp

    def configure(req, resp):
        resp.ok = cm.configure_controller(req.name) == return_type.OK
        return resp

    def unload(req, resp):
        resp.ok = cm.unload_controller(req.name) == return_type.OK
        return resp

    def switch(req, resp):
        timeout = req.timeout.sec + req.timeout.nanosec * 1e-9
        ret = cm.switch_controller(list(req.activate_controllers), list(req.deactivate_controllers),
                                   req.strictness, req.activate_asap, timeout)
        resp.ok = ret == return_type.OK
        resp.message = cm.last_switch_message
        return resp

    def set_hw_state(req, resp):
        target = req.target_state
        try:
            state = as_state(target.label) if target.label else as_state(int(target.id))
            resp.ok = cm.set_hardware_component_state(req.name, state) == return_type.OK
        except ValueError as exc:
            cm.logger.error(str(exc))
            resp.ok = False
        comp = cm.rm.components.get(req.name)
        if comp is not None:
            resp.state = LifecycleState(id=comp.wrapper.state.id, label=comp.wrapper.state.label)
        return resp

    for srv_type, name, cb in (
        (ListControllers, "list_controllers", list_controllers),
        (ListControllerTypes, "list_controller_types", list_types),
        (ListHardwareInterfaces, "list_hardware_interfaces", list_interfaces),
        (ListHardwareComponents, "list_hardware_components", list_components),
        (LoadController, "load_controller", load),
        (ConfigureController, "configure_controller", configure),
        (UnloadController, "unload_controller", unload),
        (SwitchController, "switch_controller", switch),
        (SetHardwareComponentState, "set_hardware_component_state", set_hw_state),
    ):
        node.create_service(srv_type, f"~/{name}", cb)
