"""MyCar's launch file and parameter file: the seed's "use a launch file" advice.

``generate_launch_description()`` is the counterpart of ``mycar.launch.py`` (read it: it is the
one the chapter shows); ``launch()`` runs it like ``ros2 launch mycar mycar.launch.py
params_file:=... use_sim:=true`` and returns the started nodes as a :class:`MyCar`. The
parameters live in ``mycar.yaml`` (ROS 2 layout: node name -> ``ros__parameters``).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from robocourse.bus import Context, MultiThreadedExecutor, SingleThreadedExecutor
from robocourse.bus.arguments import param_file_entries
from robocourse.launch import (
    DeclareLaunchArgument,
    IfCondition,
    LaunchConfiguration,
    LaunchDescription,
    LaunchedSystem,
    Node,
    UnlessCondition,
)
from robocourse.launch import launch as ros2_launch

from .navigation import NavigationActionServer
from .nodes import DriverNode, LedServiceServer, SimulatorNode

DEFAULT_CONFIG = Path(__file__).with_name("mycar.yaml")


def generate_launch_description() -> LaunchDescription:
    """The car: simulator (if use_sim), driver, LED service, navigation server, one parameter file."""
    params = LaunchConfiguration("params_file")
    use_sim = LaunchConfiguration("use_sim")
    return LaunchDescription([
        DeclareLaunchArgument("params_file", default_value=str(DEFAULT_CONFIG),
                              description="ROS 2 parameter file for every node"),
        DeclareLaunchArgument("use_sim", default_value="true", choices=["true", "false"],
                              description="true: a MuJoCo car; false: a PWM-logging motor board, no physics"),
        Node(package="mycar", executable="simulator", name="mycar_sim", parameters=[params],
             condition=IfCondition(use_sim)),
        Node(package="mycar", executable="driver_node", name="driver_node", parameters=[params, {"driver": "mujoco"}],
             condition=IfCondition(use_sim)),
        Node(package="mycar", executable="driver_node", name="driver_node", parameters=[params, {"driver": "simulated"}],
             condition=UnlessCondition(use_sim)),
        Node(package="mycar", executable="led_service", name="led_service_server", parameters=[params]),
        Node(package="mycar", executable="navigation_server", name="navigation_server", parameters=[params]),
    ])


def load_parameters(config) -> dict[str, dict]:
    """{node name: {parameter: value}} from a YAML path or an already-loaded dict."""
    import yaml

    if isinstance(config, (str, Path)):
        path = Path(config)
        if not path.exists():
            raise FileNotFoundError(f"parameter file {str(path)!r} not found; start from {DEFAULT_CONFIG}")
        data = yaml.safe_load(path.read_text()) or {}
    else:
        data = dict(config or {})
    return {pattern.lstrip("/"): values for pattern, values in param_file_entries(data)}


@dataclass
class MyCar:
    context: Context
    driver: DriverNode
    led: LedServiceServer
    navigation: NavigationActionServer
    simulator: SimulatorNode | None
    executor: SingleThreadedExecutor
    system: LaunchedSystem | None = None

    @property
    def nodes(self):
        return [n for n in (self.simulator, self.driver, self.led, self.navigation) if n is not None]

    @classmethod
    def from_system(cls, system: LaunchedSystem) -> MyCar:
        """The car's nodes out of a launched description (any launch file that starts them)."""
        def one(kind, required=True):
            found = [n for n in system.nodes if isinstance(n, kind)]
            if len(found) > 1 or (required and not found):
                raise ValueError(f"the launch started {len(found)} {kind.__name__} nodes; a MyCar has exactly one"
                                 + ("" if required else " or none"))
            return found[0] if found else None

        return cls(system.context, one(DriverNode), one(LedServiceServer), one(NavigationActionServer),
                   one(SimulatorNode, required=False), system.executor, system)


def launch(context: Context | None = None, config=DEFAULT_CONFIG, overrides: dict | None = None,
           multithreaded: bool = False, use_sim: bool = True) -> MyCar:
    """Launch the car on ``context`` (default: a new simulated-time context).

    ``config``: a parameter file (path) or its loaded dict; ``overrides``: {node: {param: value}}
    applied after the file (a dict in the Node action's ``parameters``, as a launch file would).
    """
    ctx = context or Context(use_sim_time=True)
    tmp = None
    if not isinstance(config, (str, Path)):   # a loaded dict: launch reads files, so write it out
        import json
        import tempfile

        tmp = tempfile.NamedTemporaryFile("w", suffix=".yaml", prefix="mycar_", delete=False)
        json.dump(config, tmp)
        tmp.close()
        config = tmp.name
    description = generate_launch_description()
    for action in description.entities:
        if isinstance(action, Node) and action.name in (overrides or {}):
            action.parameters.append(dict(overrides[action.name]))
    ex = MultiThreadedExecutor(context=ctx) if multithreaded else SingleThreadedExecutor(context=ctx)
    try:
        system = ros2_launch(description, context=ctx, executor=ex, launch_arguments={
            "params_file": str(config), "use_sim": "true" if use_sim else "false"})
    finally:
        if tmp is not None:
            Path(tmp.name).unlink(missing_ok=True)
    return MyCar.from_system(system)
