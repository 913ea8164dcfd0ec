"""Components with their own channel: one actuator per joint, and an external force/torque sensor.

Counterparts (ros2_control_demos): example 6's ``ros2_control_demo_example_6/RRBotModularJoint``
(an ``ActuatorInterface``: one joint, one position command, one position state, its own bus, e.g.
a CANopen drive or an RS485 servo) and example 5's ``ExternalRRBotForceTorqueSensorHardware`` (a
``SensorInterface``: a force/torque sensor on its own PC, read independently of the robot's
joints). Written from the demos' documented behaviour, not their code.

- :class:`RRBotModularJoint` (plugin ``robocourse/RRBotModularJoint``): read() moves the joint
  toward its command by ``(command - state) / slowdown`` per read, as the demo's simulated
  joint does. ``<param name="slowdown">`` (upstream: ``example_param_hw_slowdown``, default 2.0
  in the demo's xacro) must be >= 1. on_configure sets the state to its ``initial_value`` (0.0
  without one); on_activate copies the state into the command (the demo does this only while
  the state is NaN; copying always is the no-jump rule of this course). Upstream's
  ``example_param_hw_start/stop_duration_sec`` sleeps are left out: a component must not block.
- :class:`ForceTorqueSensor` (plugin ``robocourse/ForceTorqueSensor``): one ``<sensor>`` whose
  state interfaces are any of ``force.x force.y force.z torque.x torque.y torque.z``. read() asks
  its *source* for the six values (N, N m) and copies the declared ones into its states.
  ``ForceTorqueSensor(source)`` takes a callable ``source(time) -> 6 numbers``; loaded from the
  URDF alone (no source given) it reads :class:`RandomWrench`, the demo's simulated sensor: each
  value moves by at most ``max_sensor_change`` per read, clipped to the ``<sensor>``'s
  ``fx_range`` .. ``tz_range`` params, from a seeded generator (``<param name="seed">``), so runs
  repeat. A source that raises or returns the wrong number of values makes read() return
  ERROR (a sensor whose cable came loose), never raise.
"""

from __future__ import annotations

import math

import numpy as np

from .component import ActuatorInterface, SensorInterface
from .types import CallbackReturn, return_type

FT_INTERFACES = ("force.x", "force.y", "force.z", "torque.x", "torque.y", "torque.z")
"""The six state interfaces of a force/torque sensor, in the order a source returns them."""

_RANGE_PARAMS = ("fx_range", "fy_range", "fz_range", "tx_range", "ty_range", "tz_range")


def _number_param(component, params: dict, name: str, default: float, low: float) -> float | None:
    """``params[name]`` as a float >= ``low`` (``default`` when absent), or None after logging why."""
    text = params.get(name)
    if text is None:
        return default
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value >= low):
        component.get_logger().error(
            f"<param name=\"{name}\"> of '{component.get_name()}' is {text!r}; it must be a number >= {low:g}, "
            f"e.g. <param name=\"{name}\">{default:g}</param>")
        return None
    return value


class RRBotModularJoint(ActuatorInterface):
    """One joint on its own channel (ros2_control_demos example 6's RRBotModularJoint)."""

    SUPPORTED_COMMAND_INTERFACES = ("position",)
    SUPPORTED_STATE_INTERFACES = ("position",)

    def on_init(self, info):
        super().on_init(info)
        if len(info.joints) != 1 or info.sensors or info.gpios:
            self.get_logger().error(
                f"'{info.name}' is an actuator: it drives exactly one <joint> (got {len(info.joints)} joints, "
                f"{len(info.sensors)} sensors, {len(info.gpios)} gpios); write one <ros2_control type=\"actuator\"> "
                "per joint")
            return CallbackReturn.ERROR
        joint = info.joints[0]
        if [i.name for i in joint.command_interfaces] != ["position"] or \
                [i.name for i in joint.state_interfaces] != ["position"]:
            self.get_logger().error(
                f"Joint '{joint.name}' must have exactly one 'position' command interface and one 'position' "
                f"state interface (got commands {[i.name for i in joint.command_interfaces]}, states "
                f"{[i.name for i in joint.state_interfaces]})")
            return CallbackReturn.ERROR
        slowdown = _number_param(self, info.hardware_parameters, "slowdown", 2.0, 1.0)
        if slowdown is None:
            return CallbackReturn.ERROR
        self.slowdown = slowdown
        self.joint_name = joint.name
        self.writes = 0
        return CallbackReturn.SUCCESS

    def on_configure(self, previous_state):
        self._state = self.state_index[f"{self.joint_name}/position"]
        self._command = self.command_index[f"{self.joint_name}/position"]
        initial = self.info.joints[0].state_interfaces[0].initial()
        self.state_values[self._state] = 0.0 if math.isnan(initial) else initial
        return CallbackReturn.SUCCESS

    def on_activate(self, previous_state):
        self.command_values[self._command] = self.state_values[self._state]   # no jump on activation
        return CallbackReturn.SUCCESS

    def read(self, time, period):
        cmd = self.command_values[self._command]
        if cmd == cmd:                                   # a NaN command leaves the joint where it is
            st = self.state_values[self._state]
            self.state_values[self._state] = st + (cmd - st) / self.slowdown
        return return_type.OK

    def write(self, time, period):
        self.writes += 1                                 # the frame a real driver would send on its bus
        return return_type.OK


class RandomWrench:
    """The demo's simulated F/T readings: a seeded bounded random walk (N, N m).

    ``RandomWrench(ranges=(100, 100, 100, 15, 15, 15), max_change=5.0, seed=0)``: each call moves
    every value by a uniform step in [-max_change, max_change] and clips it to [-range, range].
    """

    def __init__(self, ranges=(100.0, 100.0, 100.0, 15.0, 15.0, 15.0), max_change: float = 5.0, seed: int = 0):
        self.ranges = np.array(ranges, dtype=np.float64)
        if self.ranges.shape != (6,) or not np.all(self.ranges >= 0):
            raise ValueError(f"ranges={ranges!r} must be 6 numbers >= 0 (fx, fy, fz in N; tx, ty, tz in N m)")
        if not (math.isfinite(max_change) and max_change >= 0):
            raise ValueError(f"max_change={max_change!r} must be a finite number >= 0, e.g. 5.0")
        self.max_change = float(max_change)
        self._rng = np.random.default_rng(seed)
        self.values = np.zeros(6)

    def __call__(self, time: float) -> np.ndarray:
        self.values += self._rng.uniform(-self.max_change, self.max_change, 6)
        np.clip(self.values, -self.ranges, self.ranges, out=self.values)
        return self.values


class ForceTorqueSensor(SensorInterface):
    """An external force/torque sensor (ros2_control_demos example 5's ExternalRRBotForceTorqueSensorHardware).

    ``ForceTorqueSensor(source=None)``; ``source(time)`` returns (fx, fy, fz, tx, ty, tz). Pass the
    instance as ``components={"<ros2_control name>": ForceTorqueSensor(my_source)}``; without a
    source it reads a :class:`RandomWrench` built from the URDF params (see the module docstring).
    """

    def __init__(self, source=None):
        super().__init__()
        if source is not None and not callable(source):
            raise ValueError(f"source={source!r} must be a callable source(time) -> (fx, fy, fz, tx, ty, tz), "
                             "e.g. ForceTorqueSensor(lambda t: (0, 0, -9.81, 0, 0, 0))")
        self.source = source
        self.read_errors = 0

    def on_init(self, info):
        super().on_init(info)
        if len(info.sensors) != 1 or info.joints or info.gpios:
            self.get_logger().error(
                f"'{info.name}' is a force/torque sensor: it needs exactly one <sensor> and no <joint>/<gpio> "
                f"(got {len(info.sensors)} sensors, {len(info.joints)} joints, {len(info.gpios)} gpios)")
            return CallbackReturn.ERROR
        sensor = info.sensors[0]
        names = [i.name for i in sensor.state_interfaces]
        unknown = [n for n in names if n not in FT_INTERFACES]
        if not names or unknown:
            self.get_logger().error(
                f"sensor '{sensor.name}' has state interfaces {names}; a force/torque sensor offers a non-empty "
                f"subset of {list(FT_INTERFACES)}, e.g. <state_interface name=\"force.z\"/>")
            return CallbackReturn.ERROR
        self.sensor_name = sensor.name
        self.frame_id = sensor.parameters.get("frame_id", "")
        if self.source is None:
            ranges = [_number_param(self, sensor.parameters, p, 100.0 if p[0] == "f" else 15.0, 0.0)
                      for p in _RANGE_PARAMS]
            change = _number_param(self, info.hardware_parameters, "max_sensor_change", 5.0, 0.0)
            seed = _number_param(self, info.hardware_parameters, "seed", 0.0, 0.0)
            if None in ranges or change is None or seed is None:
                return CallbackReturn.ERROR
            self.source = RandomWrench(ranges, change, int(seed))
        return CallbackReturn.SUCCESS

    def on_configure(self, previous_state):
        declared = [i.name for i in self.info.sensors[0].state_interfaces]
        # (slot in state_values, position in the source's 6 values) for each declared interface
        self._slots = np.array([self.state_index[f"{self.sensor_name}/{n}"] for n in declared], dtype=np.intp)
        self._from = np.array([FT_INTERFACES.index(n) for n in declared], dtype=np.intp)
        self._buf = np.zeros(6)
        self.state_values[self._slots] = 0.0
        return CallbackReturn.SUCCESS

    def read(self, time, period):
        try:
            values = self.source(time)
            if len(values) != 6:
                self.read_errors += 1
                return return_type.ERROR
            self._buf[:] = values
        except Exception:  # noqa: BLE001 - read() reports a broken source as ERROR, it never raises
            self.read_errors += 1
            return return_type.ERROR
        self.state_values[self._slots] = self._buf[self._from]
        return return_type.OK


__all__ = ["FT_INTERFACES", "ForceTorqueSensor", "RRBotModularJoint", "RandomWrench"]
