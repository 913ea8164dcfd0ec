"""Start the whole car from a parameter file: the seed's "use a launch file" advice.

``launch(ctx, "mycar.yaml")`` is the counterpart of ``ros2 launch mycar mycar.launch.py``: it
reads a ROS 2 parameter file (``node: ros__parameters: {...}``), creates the simulator (for
``driver: mujoco``), the driver, the LED service and the navigation server with those
parameters as overrides, and returns them with an executor ready to spin.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from robocourse.bus import Context, MultiThreadedExecutor, Parameter, SingleThreadedExecutor

from .drivers import MujocoMotorDriver, SimulatedMotorDriver
from .kinematics import DiffDriveGeometry
from .navigation import NavigationActionServer
from .nodes import DriverNode, LedServiceServer, SimulatorNode

DEFAULT_CONFIG = Path(__file__).with_name("mycar.yaml")


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
    out = {}
    for node, section in data.items():
        if not isinstance(section, dict) or "ros__parameters" not in section:
            raise ValueError(f"parameter file entry {node!r} must hold 'ros__parameters:' (ROS 2 layout)")
        out[node] = dict(section["ros__parameters"] or {})
    return out


@dataclass
class MyCar:
    context: Context
    driver: DriverNode
    led: LedServiceServer
    navigation: NavigationActionServer
    simulator: SimulatorNode | None
    executor: SingleThreadedExecutor

    @property
    def nodes(self):
        return [n for n in (self.simulator, self.driver, self.led, self.navigation) if n is not None]


def launch(context: Context | None = None, config=DEFAULT_CONFIG, overrides: dict | None = None,
           multithreaded: bool = False) -> MyCar:
    """Create the car's nodes on ``context`` (default: a new simulated-time context)."""
    ctx = context or Context(use_sim_time=True)
    params = load_parameters(config)
    for node, values in (overrides or {}).items():
        params.setdefault(node, {}).update(values)
    drv = params.get("driver_node", {})
    kind = drv.get("driver", "simulated")
    simulator = None
    if kind == "mujoco":
        from robocourse.sim.car import MujocoCar

        geometry = DiffDriveGeometry(drv.get("wheel_base", 0.15), drv.get("wheel_radius", 0.0325),
                                     drv.get("max_linear_speed", 0.5))
        car = MujocoCar(geometry)
        simulator = SimulatorNode(car, context=ctx)
        driver = MujocoMotorDriver(car)
    elif kind == "simulated":
        driver = SimulatedMotorDriver()
    else:
        raise ValueError(f"driver_node.driver is {kind!r}: use 'simulated' or 'mujoco'")

    def overrides_for(name):
        return [Parameter(k, value=float(v) if isinstance(v, int) and not isinstance(v, bool) else v)
                for k, v in params.get(name, {}).items()]

    driver_node = DriverNode(driver, context=ctx, parameter_overrides=overrides_for("driver_node"))
    led = LedServiceServer(context=ctx)
    nav = NavigationActionServer(context=ctx, parameter_overrides=overrides_for("navigation_server"))
    ex = MultiThreadedExecutor(context=ctx) if multithreaded else SingleThreadedExecutor(context=ctx)
    car = MyCar(ctx, driver_node, led, nav, simulator, ex)
    for node in car.nodes:
        ex.add_node(node)
    return car
