"""Bring a shipped robot up under a controller manager in one call (what a ros2_control launch file does).

Counterpart: ros2_control_demos' ``*.launch.py`` (robot_state_publisher + ros2_control_node +
spawners): ``bringup("ur5e", plugin="robocourse/MujocoSystem", spawn=["joint_state_broadcaster",
"forward_position_controller"])`` returns a running :class:`ControllerManager` with the robot's
URDF, the shipped ``config/<robot>_controllers.yaml`` (or ``param_file``) and those controllers
spawned (``inactive=[...]`` spawns them configured but inactive). ``variant="modular_fts"`` brings
up RRBot wired as one actuator per joint plus an external F/T sensor (demos' examples 6 and 5) with
the same ``config/rrbot_controllers.yaml`` (the controllers see the same joints and interfaces; example
5's force_torque_sensor_broadcaster is not in robocourse, the joint_state_broadcaster's
/dynamic_joint_states carries the sensor's values).
"""

from __future__ import annotations

from pathlib import Path

from .manager.controller_manager import ControllerManager

CONFIG = Path(__file__).with_name("config")


def default_param_file(robot: str) -> Path:
    return CONFIG / f"{robot}_controllers.yaml"


def bringup(robot: str = "rrbot", *, urdf: str | None = None, plugin: str | None = None, param_file=None,
            spawn=(), inactive=(), components: dict | None = None, context=None, log=None,
            quiet: bool = True, variant: str | None = None) -> ControllerManager:
    """Start a manager for ``robot`` (a shipped robot) or ``urdf`` (URDF text) and spawn controllers."""
    from . import introspection

    if urdf is None:
        from robocourse.sim.robots import urdf_text

        urdf = urdf_text(robot, plugin=plugin, variant=variant)
        if param_file is None:
            param_file = default_param_file(robot)
    elif plugin is not None:
        raise ValueError("plugin= applies to a shipped robot; edit the <plugin> of your own URDF instead")
    elif variant is not None:
        raise ValueError("variant= applies to a shipped robot; edit the <ros2_control> of your own URDF instead")
    cm = ControllerManager(urdf, params=Path(param_file) if param_file else None, components=components,
                           context=context, log=log)
    if spawn and not introspection.spawner(cm, list(spawn), quiet=quiet):
        raise RuntimeError(f"spawning {list(spawn)} failed: {cm.log.records[-1].msg}")
    if inactive and not introspection.spawner(cm, list(inactive), inactive=True, quiet=quiet):
        raise RuntimeError(f"spawning {list(inactive)} (inactive) failed: {cm.log.records[-1].msg}")
    return cm
