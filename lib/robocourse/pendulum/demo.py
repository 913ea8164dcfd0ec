"""The seed demo's graph on robocourse.bus (ros2/demos pendulum_control, pendulum_demo.cpp).

Two nodes, as in the seed: ``pendulum_motor`` publishes ``pendulum_sensor`` (JointState) every
970 us and applies ``pendulum_command``; ``pendulum_controller`` runs the PID on each sensor
message, publishes ``pendulum_command`` every 960 us, listens to ``pendulum_setpoint`` and
publishes ``pendulum_statistics`` (RttestResults) every 1 ms. Sensor, command and statistics
use KEEP_LAST 1 BEST_EFFORT ("a RELIABLE setting can potentially block while trying to send");
the setpoint subscription is TRANSIENT_LOCAL, so a teleop that published before the
controller existed is still heard.

Two ways to run the same graph:

- real time (``run_realtime``): the motor's physics runs in its own thread every 1 ms, the
  executor runs inside robocourse.rt's periodic loop (:class:`RttExecutor`, the seed's
  ``RttExecutor``) and rttest's statistics are collected;
- simulated time (``run_simulated``): physics is a 1 ms timer on the motor node, the graph is
  spun for N seconds of simulated time in a fraction of that, identically every run.
"""

from __future__ import annotations

import math
import threading
import time
from dataclasses import dataclass, field

import numpy as np

from robocourse.bus import (
    Context,
    DurabilityPolicy,
    HistoryPolicy,
    QoSProfile,
    ReliabilityPolicy,
    SingleThreadedExecutor,
)

from .msgs import JointCommand, JointState, RttestResults
from .physics import PendulumPhysics, PendulumProperties
from .pid import SeedPID

MOTOR_PERIOD_NS = 970_000
CONTROLLER_PERIOD_NS = 960_000
STATISTICS_PERIOD_NS = 1_000_000
PHYSICS_PERIOD_NS = 1_000_000

#: sensor, command, statistics: "optimizing for performance and limited resource usage"
QOS_REALTIME = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1, reliability=ReliabilityPolicy.BEST_EFFORT)
#: the controller's setpoint subscription: late-joining, so it still gets the teleop's command
QOS_SETPOINT = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1, reliability=ReliabilityPolicy.BEST_EFFORT,
                          durability=DurabilityPolicy.TRANSIENT_LOCAL)
#: pendulum_teleop's publisher: publish once, keep it for late joiners
QOS_TELEOP = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10, reliability=ReliabilityPolicy.RELIABLE,
                        durability=DurabilityPolicy.TRANSIENT_LOCAL)
#: pendulum_logger: a deeper queue, it is not real-time
QOS_LOGGER = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100, reliability=ReliabilityPolicy.BEST_EFFORT)

TELEOP_DEFAULT_TEXT = "Command argument not specified. Setting command to 90 degrees (PI/2 radians)."


class PendulumMotor:
    """``pendulum_control::PendulumMotor``: physics, the ideal position motor, the sensor message."""

    def __init__(self, properties: PendulumProperties | None = None, publish_period_ns: int = MOTOR_PERIOD_NS,
                 initial_position: float = 0.0):
        self.physics = PendulumPhysics(properties)
        self.physics.state.position = initial_position
        self.publish_period_ns = publish_period_ns
        self.sensor_message = JointState()
        self.message_ready = False
        self.messages_received = 0
        self._done = threading.Event()
        self._thread: threading.Thread | None = None
        self.physics_steps = 0

    def on_command_message(self, msg: JointCommand) -> None:
        self.messages_received += 1
        self.physics.command(msg.position)

    def update_physics(self, dt: float = PHYSICS_PERIOD_NS * 1e-9) -> None:
        """One pass of the seed's physics loop, then refresh the sensor message."""
        s = self.physics.step(dt)
        self.sensor_message.position = s.position
        self.sensor_message.velocity = s.velocity
        self.physics_steps += 1
        self.message_ready = True

    def start(self) -> None:
        """Run the physics in its own thread with a 1 ms relative sleep, as the seed does."""
        if self._thread is not None:
            raise RuntimeError("PendulumMotor physics thread already started")
        self._done.clear()

        def loop():
            while not self._done.is_set():
                self.update_physics()
                time.sleep(PHYSICS_PERIOD_NS * 1e-9)

        self._thread = threading.Thread(target=loop, name="pendulum_physics", daemon=True)
        self._thread.start()

    def set_done(self) -> None:
        self._done.set()
        if self._thread is not None:
            self._thread.join(timeout=1.0)
            self._thread = None


class PendulumController:
    """``pendulum_control::PendulumController``: the seed's PID behind the sensor callback."""

    def __init__(self, pid: SeedPID | None = None, publish_period_ns: int = CONTROLLER_PERIOD_NS, verbose: bool = True):
        self.pid = pid or SeedPID(publish_period_ns * 1e-9)
        self.publish_period_ns = publish_period_ns
        self.command_message = JointCommand(position=self.pid.command)
        self.message_ready = False
        self.messages_received = 0
        self.verbose = verbose
        self.setpoints: list[float] = []

    def on_sensor_message(self, msg: JointState) -> None:
        self.messages_received += 1
        self.command_message.position = self.pid.update(msg.position)
        self.message_ready = True

    def on_pendulum_setpoint(self, msg: JointCommand) -> None:
        self.pid.command = msg.position
        self.setpoints.append(msg.position)
        if self.verbose:
            print(f"Pendulum set to: {msg.position:f}", flush=True)


class LatencyStatistics:
    """Running rttest figures the statistics timer publishes (``RttExecutor::set_rtt_results_message``)."""

    def __init__(self):
        self.n = 0
        self.cur = 0
        self.min = 0
        self.max = 0
        self.sum = 0
        self.minor = 0
        self.major = 0

    def add(self, latency_ns: int) -> None:
        self.cur = latency_ns
        if self.n == 0 or latency_ns < self.min:
            self.min = latency_ns
        if self.n == 0 or latency_ns > self.max:
            self.max = latency_ns
        self.sum += latency_ns
        self.n += 1

    def fill(self, msg: RttestResults) -> None:
        msg.cur_latency = max(0, self.cur)  # uint64 in the message, as in the seed
        msg.mean_latency = self.sum / self.n if self.n else 0.0
        msg.min_latency = max(0, self.min)
        msg.max_latency = max(0, self.max)
        msg.minor_pagefaults = self.minor
        msg.major_pagefaults = self.major


@dataclass
class PendulumGraph:
    """The nodes and entities of one demo graph (handles for tests and notebooks)."""

    context: Context
    motor: PendulumMotor
    controller: PendulumController
    motor_node: object
    controller_node: object
    statistics: LatencyStatistics
    published_statistics: int = 0
    entities: dict = field(default_factory=dict)


def build_graph(context: Context, motor: PendulumMotor | None = None, controller: PendulumController | None = None,
                physics_timer: bool = False) -> PendulumGraph:
    """Create ``pendulum_motor`` and ``pendulum_controller`` with the seed's topics and timers.

    ``physics_timer=True`` steps the physics from a 1 ms timer on the motor node (simulated
    time) instead of the motor's own thread (real time).
    """
    motor = motor or PendulumMotor()
    controller = controller or PendulumController()
    motor_node = context.create_node("pendulum_motor")
    controller_node = context.create_node("pendulum_controller")
    stats = LatencyStatistics()
    graph = PendulumGraph(context, motor, controller, motor_node, controller_node, stats)

    sensor_pub = motor_node.create_publisher(JointState, "pendulum_sensor", QOS_REALTIME)
    motor_node.create_subscription(JointCommand, "pendulum_command", motor.on_command_message, QOS_REALTIME)
    command_pub = controller_node.create_publisher(JointCommand, "pendulum_command", QOS_REALTIME)
    controller_node.create_subscription(JointState, "pendulum_sensor", controller.on_sensor_message, QOS_REALTIME)
    controller_node.create_subscription(JointCommand, "pendulum_setpoint", controller.on_pendulum_setpoint, QOS_SETPOINT)
    stats_pub = controller_node.create_publisher(RttestResults, "pendulum_statistics", QOS_REALTIME)
    results = RttestResults()

    def motor_publish():
        if motor.message_ready:
            sensor_pub.publish(motor.sensor_message)

    def controller_publish():
        if controller.message_ready:
            command_pub.publish(controller.command_message)

    def statistics_publish():
        results.command.position = controller.command_message.position
        results.state.position = motor.sensor_message.position
        results.state.velocity = motor.sensor_message.velocity
        now = controller_node.get_clock().now()
        results.stamp.sec, results.stamp.nanosec = divmod(now.nanoseconds, 1_000_000_000)
        stats.fill(results)
        stats_pub.publish(results)
        graph.published_statistics += 1

    graph.entities["motor_timer"] = motor_node.create_timer(MOTOR_PERIOD_NS * 1e-9, motor_publish)
    graph.entities["controller_timer"] = controller_node.create_timer(CONTROLLER_PERIOD_NS * 1e-9, controller_publish)
    graph.entities["statistics_timer"] = controller_node.create_timer(STATISTICS_PERIOD_NS * 1e-9, statistics_publish)
    if physics_timer:
        graph.entities["physics_timer"] = motor_node.create_timer(PHYSICS_PERIOD_NS * 1e-9, motor.update_physics)
    return graph


def teleop(context: Context, command: float | None = None, verbose: bool = True):
    """``pendulum_teleop``: publish one setpoint (default pi/2, with the seed's message)."""
    if command is None:
        if verbose:
            print(TELEOP_DEFAULT_TEXT, flush=True)
        command = math.pi / 2
    _check_angle("setpoint", command)
    node = context.create_node("pendulum_teleop")
    pub = node.create_publisher(JointCommand, "pendulum_setpoint", QOS_TELEOP)
    pub.publish(JointCommand(position=float(command)))
    return node


class PendulumLogger:
    """``pendulum_logger``: prints the seed's lines for every statistics message it receives."""

    def __init__(self, context: Context, echo: bool = True):
        self.node = context.create_node("pendulum_logger")
        self.echo = echo
        self.lines: list[str] = []
        self.received = 0
        self.node.create_subscription(RttestResults, "pendulum_statistics", self.on_results, QOS_LOGGER)

    def on_results(self, msg: RttestResults) -> None:
        self.received += 1
        text = (f"Commanded motor angle: {msg.command.position:f}\n"
                f"Actual motor angle: {msg.state.position:f}\n"
                f"Current latency: {msg.cur_latency} ns\n"
                f"Mean latency: {msg.mean_latency:f} ns\n"
                f"Min latency: {msg.min_latency} ns\n"
                f"Max latency: {msg.max_latency} ns\n"
                f"Minor pagefaults during execution: {msg.minor_pagefaults}\n"
                f"Major pagefaults during execution: {msg.major_pagefaults}\n")
        self.lines.append(text)
        if self.echo:
            print(text, flush=True)


class RttExecutor:
    """``pendulum_control::RttExecutor``: a single-threaded executor inside rttest's loop.

    Each loop iteration records the wake-up latency (robocourse.rt semantics), updates the
    running statistics, then runs every ready callback (``spin_some``).
    """

    def __init__(self, context: Context, statistics: LatencyStatistics | None = None):
        self.executor = SingleThreadedExecutor(context=context)
        self.statistics = statistics or LatencyStatistics()
        self.callbacks_run = 0

    def add_node(self, node) -> None:
        self.executor.add_node(node)

    def spin(self, iterations: int = 1000, period_ns: int = 1_000_000, wait=None):
        """Run ``iterations`` loop iterations (rttest -i, -u); return robocourse.rt's LoopResult."""
        from robocourse.rt import PeriodicLoop

        stats = self.statistics
        spin_some = self.executor.spin_some

        def iteration(tick):
            stats.add(tick.latency_ns)
            self.callbacks_run += spin_some()

        result = PeriodicLoop(period_ns, iterations, wait).run(iteration)
        stats.minor = int(result.minor_pagefaults.sum())
        stats.major = int(result.major_pagefaults.sum())
        return result


def run_simulated(seconds: float = 1.0, setpoint: float | None = None, initial_position: float = math.pi / 2 + 0.05,
                  pid: SeedPID | None = None, record: bool = True, teleop_first: bool = True) -> dict:
    """Spin the seed's graph for ``seconds`` of simulated time; return arrays for plotting.

    ``teleop_first`` publishes the setpoint before the controller exists (TRANSIENT_LOCAL).
    """
    if isinstance(seconds, bool) or not isinstance(seconds, (int, float)) or not (math.isfinite(seconds) and seconds > 0):
        raise ValueError(f"run_simulated(seconds={seconds!r}): spin for a positive, finite number of seconds "
                         "of simulated time, e.g. run_simulated(2.0)")
    _check_angle("initial_position", initial_position)
    if setpoint is not None:
        _check_angle("setpoint", setpoint)
    ctx = Context(use_sim_time=True)
    if setpoint is not None and teleop_first:
        teleop(ctx, setpoint, verbose=False)
    motor = PendulumMotor(initial_position=initial_position)
    controller = PendulumController(pid, verbose=False)
    graph = build_graph(ctx, motor, controller, physics_timer=True)
    if setpoint is not None and not teleop_first:
        teleop(ctx, setpoint, verbose=False)
    t, angle, command = [], [], []
    if record:
        probe = ctx.create_node("pendulum_probe")

        def sample():
            t.append(probe.get_clock().now().nanoseconds * 1e-9)
            angle.append(motor.physics.state.position)
            command.append(controller.command_message.position)

        probe.create_timer(0.001, sample)
    ex = SingleThreadedExecutor(context=ctx)
    for node in list(ctx.nodes):
        ex.add_node(node)
    ex.spin_for(seconds)
    out = {"t": np.array(t), "angle": np.array(angle), "command": np.array(command), "graph": graph,
           "motor_received": motor.messages_received, "controller_received": controller.messages_received,
           "physics_steps": motor.physics_steps, "setpoints": list(controller.setpoints)}
    ctx.shutdown()
    return out



def _check_angle(name: str, value) -> None:
    """An angle of the seed's pendulum: radians from the ground, 0 and pi flat, pi/2 upright.

    The seed's motor clamps every position to [0, pi]; a value outside would be clamped without a
    word, so it is refused here, before anything runs."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ValueError(f"{name}={value!r}: an angle in radians from the ground, finite; pi/2 is upright "
                         f"(the seed's convention), e.g. {name}=math.pi / 2")
    if not 0.0 <= value <= math.pi:
        raise ValueError(f"{name}={value!r}: the seed's angle runs from 0 to pi = {math.pi:.4f} rad (measured from "
                         f"the ground: 0 and pi lie flat, pi/2 = {math.pi / 2:.4f} is upright) and its motor clamps "
                         f"anything outside to that range; pick a value in it, e.g. {name}=1.3")


@dataclass
class RealtimeRun:
    loop: object  # robocourse.rt LoopResult
    graph: PendulumGraph
    settings: list
    logger: PendulumLogger | None

    @property
    def motor_received(self) -> int:
        return self.graph.motor.messages_received

    @property
    def controller_received(self) -> int:
        return self.graph.controller.messages_received


def run_realtime(iterations: int = 1000, period_ns: int = 1_000_000, priority: int = 98, policy: str = "rr",
                 setpoint: float | None = None, log: bool = False, lock_memory: bool = True,
                 stack_size: int = 1024 * 1024, heap_size: int = 64 * 1024 * 1024, wait=None,
                 initial_position: float = math.pi / 2, quiet: bool = False) -> RealtimeRun:
    """The seed's ``pendulum_demo`` main: build, ask for SCHED_RR 98, lock + prefault last, spin.

    Permission failures print the seed's messages and the run carries on. The calling thread's
    scheduling and memory settings are restored afterwards (a notebook kernel keeps working).
    """
    from robocourse.rt import WaitStrategy
    from robocourse.rt import settings as rts

    for name, value, rule in (("iterations", iterations, "at least 1 (the demo reports counts at the end), e.g. 5000"),
                              ("period_ns", period_ns, "a positive number of ns, e.g. 1_000_000 for 1 kHz")):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
            raise ValueError(f"run_realtime({name}={value!r}): {rule}")
    if isinstance(priority, bool) or not isinstance(priority, int) or not 1 <= priority <= 98:
        raise ValueError(f"run_realtime(priority={priority!r}): a real-time priority 1..98 (99 belongs to the "
                         "kernel's watchdogs), e.g. 98 as the seed")
    if str(policy).lower() not in ("rr", "fifo"):
        raise ValueError(f"run_realtime(policy={policy!r}): 'rr' (the seed's SCHED_RR) or 'fifo'")
    for name, value in (("stack_size", stack_size), ("heap_size", heap_size)):
        if isinstance(value, bool) or not isinstance(value, int) or value < 0:
            raise ValueError(f"run_realtime({name}={value!r}): a whole number of bytes >= 0, e.g. 64 << 20")
    if wait is not None and not isinstance(wait, WaitStrategy):
        raise ValueError(f"run_realtime(wait={wait!r}): Sleep() (the default, as rttest), Hybrid(spin_ns=...) or Spin()")
    _check_angle("initial_position", initial_position)
    if setpoint is not None:
        _check_angle("setpoint", setpoint)
    ctx = Context()
    if setpoint is not None or log:
        teleop(ctx, setpoint, verbose=not quiet)  # published before the controller exists
    motor = PendulumMotor(initial_position=initial_position)
    controller = PendulumController(verbose=not quiet)
    graph = build_graph(ctx, motor, controller)
    logger = PendulumLogger(ctx, echo=not quiet) if log else None
    rtt = RttExecutor(ctx, graph.statistics)
    for node in (graph.motor_node, graph.controller_node) + ((logger.node,) if logger else ()):
        rtt.add_node(node)
    saved = rts.current_scheduling()  # ("unknown", 0) off Linux: nothing to restore there
    reports = []
    motor.start()
    try:
        reports.append(rts.set_scheduling(policy, priority, quiet=quiet))
        if lock_memory:  # "Always do this as the last step of the initialization phase."
            mem = rts.lock_and_prefault(stack_size, heap_size, quiet=True)
            reports += mem
            if not mem[0].ok and not quiet:
                print("Couldn't lock all cached virtual memory.", flush=True)
                print("Pagefaults from reading pages not yet mapped into RAM will be recorded.", flush=True)
        loop = rtt.spin(iterations, period_ns, wait)
    finally:
        motor.set_done()
        if lock_memory:
            rts.unlock_memory()
        rts.reset_scheduling(*saved)
        ctx.try_shutdown()
    return RealtimeRun(loop, graph, reports, logger)
