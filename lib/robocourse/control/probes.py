"""The student-side half of chapter 4's checks: the probes and the scenarios they run.

A probe runs where the student's code runs (their kernel, or the grading sandbox): it builds a
real :class:`~robocourse.control.ControllerManager` on simulated time, puts the student's class in
it with scripted peers (a controller that claims the board's joints, a cable that comes
unplugged, a NaN command, a JTC in front of a limiter), and returns what happened, cycle by
cycle, as plain data. The judges, with their reference implementations, live in
:mod:`robocourse.control.checks` (which the grading sandbox hides); they run the same scenario
functions on the reference and compare. Nothing is timed: every run is on the manager's clock
(``cm.step()``), except the allocation measurements (tracemalloc, deterministic).
"""

from __future__ import annotations

import math

import numpy as np

from robocourse.grading.probes import call, plain

from .hardware.types import CallbackReturn, return_type
from .log import LogSink
from .manager.controller_interface import ControllerInterface, InterfaceConfiguration
from .manager.controller_interface import interface_configuration_type as ict
from .manager.controller_manager import STRICT, ControllerManager
from .motor_board import MotorBoard, motor_board_urdf


class BoardPeer(ControllerInterface):
    """The scripted controller of the motor-board check: holds on activation, then a sine on every joint.

    Claims ``<joint>/position`` of ``joints``, reads their positions. ``nan_at``: the update (counted
    from activation) that writes NaN into the first joint, to see whether write() reports the refusal.
    """

    def __init__(self, joints, amplitude, frequency, nan_at=None):
        super().__init__()
        self.joints, self.amplitude, self.frequency, self.nan_at = list(joints), amplitude, frequency, nan_at
        self.hold = np.zeros(len(self.joints))
        self.k = 0
        self.t0 = None

    def command_interface_configuration(self):
        return InterfaceConfiguration(ict.INDIVIDUAL, [f"{j}/position" for j in self.joints])

    def state_interface_configuration(self):
        return InterfaceConfiguration(ict.INDIVIDUAL, [f"{j}/position" for j in self.joints])

    def on_activate(self, previous_state):
        for i, loan in enumerate(self.state_interfaces):
            self.hold[i] = loan.get_value()
        self.k, self.t0 = 0, None
        return CallbackReturn.SUCCESS

    def update(self, time, period):
        if self.t0 is None:
            self.t0 = time
        s = math.sin(2 * math.pi * self.frequency * (time - self.t0))
        for i, loan in enumerate(self.command_interfaces):
            loan.set_value(self.hold[i] + self.amplitude[i] * s)
        if self.nan_at is not None and self.k == self.nan_at:
            self.command_interfaces[0].set_value(math.nan)
        self.k += 1
        return return_type.OK


class FaultyBoard(MotorBoard):
    """The check's board: a MotorBoard whose encoders can stop answering (``read()`` False) while ``write()`` works."""

    encoder_fault = False

    def read(self, time, positions_out, velocities_out) -> bool:
        if self.encoder_fault:
            return False
        return super().read(time, positions_out, velocities_out)


def _unfinished(log, comp) -> None:
    """A stub still raising NotImplementedError: the whole check is "not implemented yet" (the manager caught it)."""
    if isinstance(comp.wrapper.last_exception, NotImplementedError) or log.count("Exception of type : NotImplementedError"):
        raise NotImplementedError


def board_scenario(inputs, component_class) -> dict:
    """Run ``component_class(board)`` through the chapter's scenario; return what happened (plain data).

    The same function runs the student's class (probe) and the reference (judge).
    """
    pos0 = list(inputs["positions"])
    n = len(pos0)
    joints = [f"joint{i + 1}" for i in range(n)]
    out: dict = {}

    # 0. a URDF naming one joint more than the board has motors: on_init must refuse
    log = LogSink(log_to_stderr=False)
    try:
        cm = ControllerManager(motor_board_urdf(joints + [f"joint{n + 1}"]), log=log,
                               components={"MotorBoard": component_class(MotorBoard(pos0))})
        _unfinished(log, cm.rm.components["MotorBoard"])
        out["mismatch_state"] = cm.rm.components["MotorBoard"].wrapper.state.label
    except NotImplementedError:
        raise
    except Exception as exc:  # noqa: BLE001 - the manager refusing to start is an acceptable outcome
        if "NotImplementedError" in str(exc):  # the manager wraps on_init's stub in its RuntimeError
            raise NotImplementedError from exc
        out["mismatch_state"] = f"refused ({type(exc).__name__})"

    # 1. inactive: read() runs, write() does not
    board = FaultyBoard(pos0)
    log = LogSink(log_to_stderr=False)
    cm = ControllerManager(motor_board_urdf(joints), log=log, components={"MotorBoard": component_class(board)},
                           params={"controller_manager": {"update_rate": 100,
                                                          "hardware_components_initial_state.inactive": ["MotorBoard"]}})
    comp = cm.rm.components["MotorBoard"]
    _unfinished(log, comp)
    out["initial_state"] = comp.wrapper.state.label
    impl = comp.impl
    pos_keys = [f"{j}/position" for j in joints]
    vel_keys = [f"{j}/velocity" for j in joints]

    def states(keys):
        return [float(impl.state_values[impl.state_index[k]]) for k in keys]

    cm.step(int(round(inputs["inactive_s"] * cm.update_rate)))
    _unfinished(log, comp)
    out["inactive_states"] = states(pos_keys)
    out["inactive_targets_received"] = board.targets_received

    def run(cycles):  # cm.step(cycles), counting what the component logs meanwhile (the real-time rule)
        first = len(log.records)
        cm.step(cycles)
        _unfinished(log, comp)
        rt_logs.extend(r.msg for r in log.records[first:] if r.name == "MotorBoard")

    rt_logs: list[str] = []

    # 2. activate the hardware, no controller: nothing may move
    out["activate"] = int(cm.set_hardware_component_state("MotorBoard", "active"))
    _unfinished(log, comp)
    out["active_state"] = comp.wrapper.state.label
    hold = []
    for _ in range(int(round(inputs["hold_s"] * cm.update_rate))):
        run(1)
        hold.append(board.positions.tolist())
    out["hold_positions"] = hold

    # 3. a controller moves every joint: the board gets each command, the states follow the encoders
    peer = BoardPeer(joints, inputs["amplitude"], inputs["frequency"])
    cm.load_controller("peer", controller=peer)
    cm.configure_controller("peer")
    out["switch"] = int(cm.switch_controller(["peer"], [], STRICT))
    track = {"command": [], "target": [], "state": [], "encoder": [], "velocity_state": [], "velocity": []}
    for _ in range(int(round(inputs["track_s"] * cm.update_rate))):
        run(1)
        track["command"].append([loan.get_value() for loan in peer.command_interfaces])
        track["target"].append(board.targets.tolist())
        track["state"].append(states(pos_keys))
        track["encoder"].append(board.positions.tolist())
        track["velocity_state"].append(states(vel_keys))
        track["velocity"].append(board.velocities.tolist())
    out["track"] = track
    out["logs_while_running"] = rt_logs[:3]
    out["logs_while_running_count"] = len(rt_logs)

    # 4. the encoders stop answering: read() must return ERROR (not raise, not pretend)
    board.encoder_fault = True
    cm.step(5)
    out["unplugged_peer"] = cm.controllers["peer"].state.label
    out["unplugged_hardware"] = comp.wrapper.state.label
    out["exceptions"] = log.count("Exception of type")

    # 5. while the driver was down the arm was moved by hand and left at rest; plugged in, cleaned up (whatever
    #    the fault did), configured and activated again: it must stay where it now is
    board.encoder_fault = False
    cm.set_hardware_component_state("MotorBoard", "unconfigured")
    board.positions[:] = board.targets[:] = inputs["moved_by_hand"]
    board.velocities[:] = 0.0
    out["reactivate"] = int(cm.set_hardware_component_state("MotorBoard", "active"))
    recovery = []
    for _ in range(10):
        cm.step()
        recovery.append(board.positions.tolist())
    out["recovery_positions"] = recovery
    out["reswitch"] = int(cm.switch_controller(["peer"], [], STRICT))
    cm.step(5)
    out["recovered_peer"] = cm.controllers["peer"].state.label

    # 6. a NaN command: the board refuses the frame, write() must say so
    cm.switch_controller([], ["peer"], STRICT)
    cm.unload_controller("peer")
    nan_peer = BoardPeer(joints, inputs["amplitude"], inputs["frequency"], nan_at=inputs["nan_at"])
    cm.load_controller("nan_peer", controller=nan_peer)
    cm.configure_controller("nan_peer")
    cm.switch_controller(["nan_peer"], [], STRICT)
    refused0, raised0 = board.frames_refused, log.count("Exception of type")
    cm.step(inputs["nan_at"] + 5)
    out["nan_refused"] = board.frames_refused - refused0
    out["nan_exceptions"] = log.count("Exception of type") - raised0
    out["nan_peer"] = cm.controllers["nan_peer"].state.label
    out["nan_hardware"] = comp.wrapper.state.label
    out["exceptions_total"] = log.count("Exception of type")

    # 7. read() and write() build no buffer per cycle (the board itself allocates none)
    def build(stage):
        def make(n):
            names = [f"joint{i + 1}" for i in range(n)]
            m = ControllerManager(motor_board_urdf(names), log=LogSink(log_to_stderr=False),
                                  components={"MotorBoard": component_class(FaultyBoard([0.1] * n))})
            impl = m.rm.components["MotorBoard"].impl
            if m.rm.components["MotorBoard"].wrapper.state.label != "active":
                raise RuntimeError(f"with {n} motors the component ended '{m.rm.components['MotorBoard'].wrapper.state.label}'")
            clock = [0.0]

            def read():
                clock[0] += 0.001
                impl.read(clock[0], 0.001)

            return read if stage == "read" else (lambda: impl.write(clock[0], 0.001))
        return make

    for stage in ("read", "write"):
        out[f"alloc_{stage}"] = allocation_record(build(stage))
    return plain(out)


def board_probe(inputs, BoardSystem):
    return board_scenario(inputs, BoardSystem)


def cubic_probe(inputs, cubic_sample):
    """ch04.cubic: one call per sample time of each segment."""
    cases = []
    for c in inputs:
        args = [np.array(c[k]) for k in ("p0", "v0", "p1", "v1")]
        cases.append([call(cubic_sample, *args, c["T"], t) for t in c["t"]])
    return {"cases": cases}


def yaml_probe(inputs, controllers_yaml):
    """ch04.controllers_yaml: the text the student's function returns (the judge loads it)."""
    return {"text": call(controllers_yaml)}


def fault_probe(inputs, after_hardware_error):
    """ch04.read_error: the student's prediction for each scenario."""
    return {"answers": [call(after_hardware_error, s["controllers"], inputs["hardware"], s["failed"], s["stage"],
                             s["result"]) for s in inputs["scenarios"]]}


def adm_probe(inputs, tune_admittance):
    """ch04.admittance: the student's gains for each case."""
    return {"cases": [call(tune_admittance, c["force"], c["deflection"], c["settle"]) for c in inputs]}


def generic_urdf(initial: dict, name: str = "Arm") -> str:
    """A serial arm on ``mock_components/GenericSystem``: per joint a position command (NaN until written)
    and position (``initial[joint]``) + velocity states."""
    joints = list(initial)
    links = "".join(f'<link name="link{i}"/>' for i in range(len(joints) + 1))
    js = "".join(f'<joint name="{j}" type="revolute"><parent link="link{i}"/><child link="link{i + 1}"/>'
                 '<axis xyz="0 0 1"/><limit lower="-3.14" upper="3.14" effort="10" velocity="2"/></joint>'
                 for i, j in enumerate(joints))
    hw = "".join(f'<joint name="{j}"><command_interface name="position"/><state_interface name="position">'
                 f'<param name="initial_value">{float(v)!r}</param></state_interface>'
                 '<state_interface name="velocity"/></joint>' for j, v in initial.items())
    return (f'<robot name="arm">{links}{js}<ros2_control name="{name}" type="system"><hardware>'
            f'<plugin>mock_components/GenericSystem</plugin></hardware>{hw}</ros2_control></robot>')


def _errors(log, since=0) -> list[str]:
    return [r.msg for r in log.records[since:] if int(r.severity) >= 40][:5]


def _commands(cm, joints) -> list[float]:
    return [cm.rm.command_value(f"{j}/position") for j in joints]


def _positions(cm, joints) -> list[float]:
    return [cm.rm.value(f"{j}/position") for j in joints]


def _load(cm, name, cls, out, key) -> object | None:
    """Load and configure the student's ``cls()`` as ``name``; record why it failed in ``out[key]``."""
    try:
        ctrl = cls()
    except Exception as exc:  # noqa: BLE001 - the student's constructor: its exception is the feedback
        if isinstance(exc, NotImplementedError):
            raise
        out[key] = f"{type(exc).__name__} in {cls.__name__}(): {exc}"
        return None
    mark = len(cm.log.records)
    if cm.load_controller(name, controller=ctrl) is None:
        out[key] = "load failed: " + " | ".join(_errors(cm.log, mark))
        return None
    if cm.configure_controller(name) != return_type.OK:
        why = cm.controllers[name].lifecycle.last_exception
        if isinstance(why, NotImplementedError):
            raise NotImplementedError
        out[key] = "configure failed: " + (f"{type(why).__name__}: {why}" if why else " | ".join(_errors(cm.log, mark)))
        return None
    return ctrl


def _started(cm, name, cls, out):
    """(manager, the student's controller loaded and configured as ``name``, or None with out["load"] saying why)."""
    return cm, _load(cm, name, cls, out, "load")


def _record(cm, name, joints, cycles, what=None) -> list:
    """``cycles`` manager cycles; after each, ``what(cm, joints)`` (default: the joints' position commands)."""
    rows = []
    for _ in range(cycles):
        cm.step()
        _raise_if_unfinished(cm, name)
        rows.append((what or _commands)(cm, joints))
    return rows


def _raise_if_unfinished(cm, name) -> None:
    spec = cm.controllers.get(name)
    why = spec.lifecycle.last_exception if spec is not None else None
    if isinstance(why, NotImplementedError) or cm.log.count("Caught exception of type : NotImplementedError"):
        raise NotImplementedError


def allocation_growth(build, sizes=(2, 34)) -> dict:
    """Peak bytes of one call (min of two measurements) for each size, and bytes kept per call at the largest.

    ``build(n)`` returns the function of no argument to measure with ``n`` joints (or raises)."""
    from robocourse.rt.allocations import measure_allocations

    peaks, kept = [], 0.0
    for n in sizes:
        fn = build(n)
        runs = [measure_allocations(fn, calls=30) for _ in range(2)]
        peaks.append(min(r.peak_bytes for r in runs))
        kept = min(r.retained_bytes_per_call for r in runs)
    return {"sizes": list(sizes), "peak_bytes": peaks, "kept_per_call": kept}


def allocation_record(build, sizes=(2, 34)):
    """``allocation_growth(build)`` as a probe records it: the measurement, or why it could not be taken (str)."""
    try:
        return allocation_growth(build, sizes)
    except NotImplementedError:
        raise
    except Exception as exc:  # noqa: BLE001 - reported, judged as "could not be measured"
        return f"{type(exc).__name__}: {exc}"


CTRL_JOINTS = ("joint1", "joint2", "joint3", "joint4")


CTRL_NAME = "slew_controller"


def _ctrl_manager(inputs, extra_params=None, initial=None):
    from robocourse.bus import Context

    joints = inputs["joints"]
    rest = [j for j in CTRL_JOINTS if j not in joints]
    params = {"controller_manager": {"update_rate": 100,
                                     "other.type": "position_controllers/JointGroupPositionController",
                                     "mover.type": "position_controllers/JointGroupPositionController"},
              CTRL_NAME: {"joints": list(joints), "max_velocity": inputs["max_velocity"], **(extra_params or {})},
              "other": {"joints": rest}, "mover": {"joints": list(joints)}}
    return ControllerManager(generic_urdf(initial or inputs["initial"]), params=params,
                             log=LogSink(log_to_stderr=False), context=Context(use_sim_time=True))


def _publisher(cm, topic, msg_type):
    node = cm.context.create_node("grader_peer")
    cm.executor.add_node(node)
    return node.create_publisher(msg_type, topic, 10)


def controller_scenario(inputs, cls) -> dict:
    """Run ``cls`` (a ControllerInterface) through the custom-controller scenarios; what happened, as plain data."""
    from robocourse.msgs.std_msgs import Float64MultiArray

    joints, out = inputs["joints"], {}
    cm, ctrl = _started(_ctrl_manager(inputs), CTRL_NAME, cls, out)
    if ctrl is None:
        return plain(out)
    for name in ("other", "mover"):
        cm.load_controller(name)
        cm.configure_controller(name)
    mark = len(cm.log.records)
    ret = cm.switch_controller([CTRL_NAME, "other"], [], STRICT)
    _raise_if_unfinished(cm, CTRL_NAME)
    out["switch"] = int(ret)
    out["switch_message"] = cm.last_switch_message if ret != return_type.OK else ""
    out["claimed_commands"] = [loan.name for loan in ctrl.command_interfaces]
    out["claimed_states"] = [loan.name for loan in ctrl.state_interfaces]
    out["errors"] = _errors(cm.log, mark)
    if ret != return_type.OK:            # try alone: a controller that claims too much still gets graded on the rest
        mark2 = len(cm.log.records)
        ret = cm.switch_controller([CTRL_NAME], [], STRICT)
        _raise_if_unfinished(cm, CTRL_NAME)
        out["switch_alone"] = int(ret)
        out["claimed_commands"] = [loan.name for loan in ctrl.command_interfaces]
        out["claimed_states"] = [loan.name for loan in ctrl.state_interfaces]
        if ret != return_type.OK:
            out["switch_alone_message"] = " | ".join([cm.last_switch_message] + _errors(cm.log, mark2))
            return plain(out)
    pub = _publisher(cm, f"/{CTRL_NAME}/commands", Float64MultiArray)

    def record(cycles, what=_commands):
        return _record(cm, CTRL_NAME, joints, cycles, what)

    hold = record(20, lambda m, js: _positions(m, js) + _commands(m, js))   # 1. activated, no target: nothing moves
    out["hold"] = [row[:len(joints)] for row in hold]
    out["hold_commands"] = [row[len(joints):] for row in hold]
    out["track"], out["bad_input"] = _ctrl_targets(cm, pub, inputs, bad=True)   # 2. slew; 3./4. NaN, wrong size
    out["state_after_bad_input"] = cm.controllers[CTRL_NAME].state.label
    # the same controller, the same targets, no bad message: what "ignored" must look like, for this code
    twin = _ctrl_manager(inputs)
    if _load(twin, CTRL_NAME, cls, {}, "load") is not None:
        if out["switch"] == 0:
            twin.load_controller("other")
            twin.configure_controller("other")
        if twin.switch_controller([CTRL_NAME] + (["other"] if out["switch"] == 0 else []), [], STRICT) == 0:
            _record(twin, CTRL_NAME, joints, 20)
            out["bad_input_control"] = _ctrl_targets(twin, _publisher(twin, f"/{CTRL_NAME}/commands",
                                                                      Float64MultiArray), inputs, bad=False)[1]
    # 5. deactivated, another controller moves the joints, activated again: it must start from there
    cm.switch_controller(["mover"], [CTRL_NAME], STRICT)
    cm.controllers["mover"].c.set_command(inputs["moved"])
    cm.step(40)
    out["reswitch"] = int(cm.switch_controller([CTRL_NAME], ["mover"], STRICT))
    _raise_if_unfinished(cm, CTRL_NAME)
    out["reactivated"] = record(20, _positions)
    out["errors"] += _errors(cm.log, mark)

    # 6. its own update_rate below the manager's: update() gets the longer period
    slow = _ctrl_manager(inputs, {"update_rate": inputs["slow_rate"]})
    sctrl = _load(slow, CTRL_NAME, cls, out, "slow_load")
    if sctrl is not None and slow.switch_controller([CTRL_NAME], [], STRICT) == return_type.OK:
        _publisher(slow, f"/{CTRL_NAME}/commands", Float64MultiArray).publish(
            Float64MultiArray(data=list(inputs["target1"])))
        out["slow_start"] = _commands(slow, joints)
        out["slow"] = _record(slow, CTRL_NAME, joints, 40)

    # 7. update() allocates nothing per cycle
    def build(n):
        names = [f"joint{i + 1}" for i in range(n)]
        m = ControllerManager(generic_urdf({j: 0.0 for j in names}),
                              params={"controller_manager": {"update_rate": 100},
                                      CTRL_NAME: {"joints": names, "max_velocity": inputs["max_velocity"]}},
                              log=LogSink(log_to_stderr=False))
        c = cls()
        m.load_controller(CTRL_NAME, controller=c)
        m.configure_controller(CTRL_NAME)
        if m.switch_controller([CTRL_NAME], [], STRICT) != return_type.OK:
            raise RuntimeError(m.last_switch_message)
        _publisher(m, f"/{CTRL_NAME}/commands", Float64MultiArray).publish(Float64MultiArray(data=[1.0] * n))
        m.step(2)
        return lambda: c.update(m.time, 0.01)

    out["alloc"] = allocation_record(build)
    return plain(out)


def _ctrl_targets(cm, pub, inputs, bad: bool):
    """Target 1 long enough to reach it, then target 2 (with ``bad``: a NaN and a wrong-size message after it);
    the commands per cycle of each part."""
    from robocourse.msgs.std_msgs import Float64MultiArray

    joints = inputs["joints"]
    pub.publish(Float64MultiArray(data=list(inputs["target1"])))
    track = _record(cm, CTRL_NAME, joints, TRACK_CYCLES)
    pub.publish(Float64MultiArray(data=list(inputs["target2"])))
    rows = _record(cm, CTRL_NAME, joints, 8)
    if bad:
        pub.publish(Float64MultiArray(data=[math.nan] + list(inputs["target1"][1:])))
    rows += _record(cm, CTRL_NAME, joints, 8)
    if bad:
        pub.publish(Float64MultiArray(data=list(inputs["target1"]) + [0.0]))
    rows += _record(cm, CTRL_NAME, joints, 30)
    return track, rows


#: cycles at 100 Hz to follow target 1: enough to reach it even from 0 rad, where a controller that forgot the
#: state starts (a target is at most 1.6 rad from 0; max_velocity is at least 0.3 rad/s)
TRACK_CYCLES = 560


def controller_probe(inputs, SlewRateController):
    return controller_scenario(inputs, SlewRateController)


LIM_NAME = "joint_limiter"


class ReferenceWriter(ControllerInterface):
    """The chain check's scripted preceding controller: claims ``<target>/<joint>/position`` reference
    interfaces and writes row k of ``script`` in its k-th update (the last row after the end)."""

    def __init__(self, target: str, joints, script):
        super().__init__()
        self.target, self.joints, self.script, self.k = target, list(joints), np.asarray(script, dtype=float), 0

    def command_interface_configuration(self):
        return InterfaceConfiguration(ict.INDIVIDUAL, [f"{self.target}/{j}/position" for j in self.joints])

    def state_interface_configuration(self):
        return InterfaceConfiguration(ict.NONE)

    def on_activate(self, previous_state):
        self.k = 0
        return CallbackReturn.SUCCESS

    def update(self, time, period):
        row = self.script[min(self.k, len(self.script) - 1)]
        for i, loan in enumerate(self.command_interfaces):
            loan.set_value(row[i])
        self.k += 1
        return return_type.OK


def _lim_manager(inputs, joints=None, initial=None):
    from robocourse.bus import Context

    joints = joints or inputs["joints"]
    initial = initial if initial is not None else inputs["initial"]
    params = {"controller_manager": {"update_rate": inputs["rate"],
                                     "jtc.type": "joint_trajectory_controller/JointTrajectoryController"},
              LIM_NAME: {"joints": list(joints), "max_velocity": inputs["max_velocity"],
                         "min_position": list(inputs["min"]), "max_position": list(inputs["max"])},
              "jtc": {"joints": list(joints), "command_joints": [f"{LIM_NAME}/{j}" for j in joints],
                      "command_interfaces": ["position"], "state_interfaces": ["position"]}}
    return ControllerManager(generic_urdf(dict(zip(joints, initial))), params=params, log=LogSink(log_to_stderr=False),
                             context=Context(use_sim_time=True))


def limiter_scenario(inputs, cls) -> dict:
    """Run ``cls`` (a ChainableControllerInterface) after a JTC and after a scripted peer; plain data."""
    from robocourse.msgs.trajectory_msgs import JointTrajectory, JointTrajectoryPoint

    joints, out = inputs["joints"], {}
    cm, lim = _started(_lim_manager(inputs), LIM_NAME, cls, out)
    if lim is None:
        return plain(out)
    out["chainable"] = bool(lim.is_chainable())
    out["exported"] = cm.rm.controller_interfaces(LIM_NAME)[0]
    mark = len(cm.log.records)
    jtc_ok = cm.load_controller("jtc") is not None and cm.configure_controller("jtc") == return_type.OK
    out["jtc_loaded"] = jtc_ok

    def switch(act, deact):
        ret = cm.switch_controller(act, deact, STRICT)
        _raise_if_unfinished(cm, LIM_NAME)
        return [int(ret), cm.last_switch_message.replace("\n", " ") if ret != return_type.OK else ""]

    def record(cycles, what=_commands):
        return _record(cm, LIM_NAME, joints, cycles, what)

    out["jtc_alone"] = switch(["jtc"], []) if jtc_ok else [1, "the JTC did not load"]
    out["limiter_alone"] = switch([LIM_NAME], [])
    if out["limiter_alone"][0] != 0:
        out["errors"] = _errors(cm.log, mark)
        return plain(out)
    out["hold"] = record(int(0.2 * inputs["rate"]), _positions)
    out["chained_alone"] = bool(lim.is_in_chained_mode())
    # the JTC in front: the activation rules, then a trajectory past the limits
    out["jtc_after"] = switch(["jtc"], []) if jtc_ok else [1, "the JTC did not load"]
    out["order"] = cm.ordered_controllers()
    out["chained_with_jtc"] = bool(lim.is_in_chained_mode())
    out["limiter_under_jtc"] = switch([], [LIM_NAME])
    if out["jtc_after"][0] == 0:
        node = cm.context.create_node("grader_peer")
        cm.executor.add_node(node)
        msg = JointTrajectory(joint_names=list(joints))
        point = JointTrajectoryPoint(positions=list(inputs["jtc_goal"]), velocities=[0.0] * len(joints))
        point.time_from_start.nanosec = 500_000_000      # faster than max_velocity allows: the limiter must act
        msg.points.append(point)
        node.create_publisher(JointTrajectory, "/jtc/joint_trajectory", 10).publish(msg)
        out["jtc_start"] = _commands(cm, joints)
        refs = [f"{LIM_NAME}/{j}/position" for j in joints]
        run = record(inputs["jtc_cycles"],
                     lambda m, js: _commands(m, js) + [m.rm.command_value(k) for k in refs])
        out["jtc_run"] = [row[:len(joints)] for row in run]
        out["jtc_refs"] = [row[len(joints):] for row in run]
        out["jtc_off"] = switch([], ["jtc"])
        out["chained_after_jtc"] = bool(lim.is_in_chained_mode())
        out["after_jtc"] = record(10)
    out["errors"] = _errors(cm.log, mark)
    out["state"] = cm.controllers[LIM_NAME].state.label
    # a fresh manager, the scripted preceding controller: steps past the limits, a NaN, a wave inside them
    cm = _lim_manager(inputs)
    lim = _load(cm, LIM_NAME, cls, out, "scripted_load")
    writer = ReferenceWriter(LIM_NAME, joints, inputs["script"])
    if lim is not None and cm.load_controller("writer", controller=writer) is not None \
            and cm.configure_controller("writer") == 0:
        out["writer_switch"] = switch([LIM_NAME, "writer"], [])
        if out["writer_switch"][0] == 0:
            out["scripted"] = record(len(inputs["script"]))

    def build(n):
        names = [f"joint{i + 1}" for i in range(n)]
        wide = {**inputs, "min": [-1.0] * n, "max": [1.0] * n}
        m = _lim_manager(wide, names, [0.0] * n)
        c = cls()
        m.load_controller(LIM_NAME, controller=c)
        m.configure_controller(LIM_NAME)
        if m.switch_controller([LIM_NAME], [], STRICT) != return_type.OK:
            raise RuntimeError(m.last_switch_message)
        c.reference_interfaces[:] = 0.5
        m.step(2)
        return lambda: c.update(m.time, 1.0 / inputs["rate"])

    out["alloc"] = allocation_record(build)
    return plain(out)


def limiter_probe(inputs, JointLimiter):
    return limiter_scenario(inputs, JointLimiter)


def urdf_probe(inputs, rrbot_ros2_control):
    """ch04.ros2_control_urdf: the element the student's function returns (the judge parses and runs it)."""
    return {"element": call(rrbot_ros2_control, dict(inputs["initial_positions"]))}

