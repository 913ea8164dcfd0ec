"""Graded checks of chapter 4 (ros2_control), as probe + judge. Registered as ``ch04.*``.

The student's code runs under the real :class:`~robocourse.control.ControllerManager` with scripted
peers (a controller that claims the board's joints, a cable that comes unplugged, a NaN command):
the probes return what happened, cycle by cycle, as plain data; the judges run the same scenario on
the reference (``MotorBoardSystem``, the JTC's spline code, the manager itself) in the grader and
compare. Nothing is timed: every run is on the manager's simulated clock (``cm.step()``).
"""

from __future__ import annotations

import math

import numpy as np

from robocourse.grading import CheckFailed, Failures, register
from robocourse.grading.probes import call, number, plain

from .hardware.component import SystemInterface
from .hardware.types import CallbackReturn, return_type
from .log import LogSink
from .manager.controller_interface import ControllerInterface, InterfaceConfiguration
from .manager.controller_interface import interface_configuration_type as ict
from .manager.controller_manager import STRICT, ControllerManager
from .motor_board import MotorBoard, boards_urdf, motor_board_urdf

# --- exercise 1: the motor board's SystemInterface, run under the controller manager --------------------------


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


def _board_inputs(rng):
    n = int(rng.integers(2, 4))
    return {"positions": rng.uniform(-1.2, 1.2, n).round(3).tolist(),
            "amplitude": rng.uniform(0.1, 0.4, n).round(3).tolist(), "frequency": float(rng.choice([0.5, 1.0])),
            "inactive_s": 0.2, "hold_s": 0.3, "track_s": 0.6, "nan_at": int(rng.integers(5, 15))}


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

    # 5. plugged in again: bring the hardware back, no jump, the controller runs again
    board.encoder_fault = False
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
    refused0 = board.frames_refused
    cm.step(inputs["nan_at"] + 5)
    out["nan_refused"] = board.frames_refused - refused0
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


def _board_probe(inputs, BoardSystem):
    return board_scenario(inputs, BoardSystem)


def _max_diff(a, b) -> float:
    try:
        x, y = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    except (TypeError, ValueError):
        return math.inf
    if x.shape != y.shape:
        return math.inf
    d = np.abs(x - y)
    if np.isnan(d).any():  # NaN where a number was due (a state never written), or the other way round
        return math.inf
    return float(d.max()) if x.size else 0.0


@register("ch04.motor_board", weight=4, time_limit=60, uses=("BoardSystem",), probe=_board_probe,
          inputs=_board_inputs, references=("robocourse.control.motor_board:MotorBoardSystem",))
def check_motor_board(inputs, out):
    """BoardSystem(board): a SystemInterface for MotorBoard, run under the controller manager with scripted peers."""
    from .motor_board import MotorBoardSystem

    ref = board_scenario(inputs, MotorBoardSystem)
    if not isinstance(out, dict):
        raise CheckFailed("the scenario returned nothing")
    f = Failures()
    n = len(inputs["positions"])
    if not str(out.get("mismatch_state")).startswith("refused"):
        f.add(f"a URDF naming {n + 1} joints for a board with {n} motors was initialised (it ended "
              f"'{out.get('mismatch_state')}' instead of the manager refusing to start): "
              "on_init must compare len(info.joints) with board.n and return CallbackReturn.ERROR")
    if out.get("initial_state") != "inactive":
        f.add(f"with hardware_components_initial_state.inactive the component should be 'inactive', it is "
              f"'{out.get('initial_state')}': on_init/on_configure must return CallbackReturn.SUCCESS")
        return f.done("")
    if _max_diff(out.get("inactive_states"), ref["inactive_states"]) > 1e-9:
        f.add(f"while inactive, the position state interfaces read {out.get('inactive_states')}, the encoders say "
              f"{ref['inactive_states']}: read() must copy board.read()'s positions into the state interfaces "
              "(read() runs in INACTIVE too)")
    if out.get("activate") != 0 or out.get("active_state") != "active":
        f.add(f"set_hardware_component_state('MotorBoard', 'active') gave {out.get('activate')} and state "
              f"'{out.get('active_state')}': on_activate must return CallbackReturn.SUCCESS when the board answers")
        return f.done("")
    jump = _max_diff(out.get("hold_positions"), ref["hold_positions"])
    if jump > 1e-6:
        try:
            moved = float(np.abs(np.asarray(out["hold_positions"], dtype=float)
                                 - np.asarray(inputs["positions"])).max())
        except (TypeError, ValueError, KeyError):
            moved = math.nan
        f.add(f"the activation jump: with no controller running, the motors moved up to {moved:.3f} rad in the "
              f"{inputs['hold_s']:g} s after activation (from {inputs['positions']}). The URDF's command initial_value "
              "is 0.0: on_activate must copy the measured positions into the position command interfaces")
    track, rtrack = out.get("track") or {}, ref["track"]
    if out.get("switch") != 0:
        f.add("a controller claiming every joint's position could not be activated: export the URDF's command "
              "and state interfaces (keep the base class's export_*_interfaces or call it)")
    else:
        if _max_diff(track.get("target"), track.get("command")) > 1e-12:
            f.add("while a controller commanded a sine, the board's targets were not the commands of the same cycle: "
                  "write() must send every joint's position command to board.write() in each cycle")
        if _max_diff(track.get("state"), track.get("encoder")) > 1e-12:
            f.add("the position state interfaces did not follow the encoders cycle by cycle: read() must copy "
                  "board.read()'s positions into <joint>/position")
        if _max_diff(track.get("velocity_state"), track.get("velocity")) > 1e-12:
            f.add("the velocity state interfaces did not follow the board's velocities: read() fills <joint>/velocity")
        if _max_diff(track.get("encoder"), rtrack["encoder"]) > 1e-9 and not f.messages:
            f.add("the motors did not track the controller's sine like the reference component")
    if out.get("logs_while_running_count", 0):
        f.add(f"{out['logs_while_running_count']} log lines while the loop ran normally (first: "
              f"{(out.get('logs_while_running') or [''])[0]!r}): read() and write() must not log (real-time rules)")
    if out.get("exceptions", 0) or out.get("exceptions_total", 0):
        f.add("read() or write() raised an exception when the board failed: never raise in the loop, "
              "return return_type.ERROR and let the manager handle it")
    elif out.get("unplugged_peer") == "active":
        f.add("the encoders stopped answering (board.read() returned False) but the controller kept running on "
              "stale states: read() must return return_type.ERROR when board.read() fails, not swallow it and "
              "return OK")
    elif out.get("unplugged_hardware") != ref["unplugged_hardware"]:
        f.add(f"after the read error the hardware is '{out.get('unplugged_hardware')}', expected "
              f"'{ref['unplugged_hardware']}' (on_error's default SUCCESS)")
    if out.get("reactivate") != 0 or out.get("recovered_peer") != "active":
        f.add(f"after the encoders answered again, bringing the hardware back gave {out.get('reactivate')} and the "
              f"controller ended '{out.get('recovered_peer')}': on_configure/on_activate must work a second time")
    elif _max_diff(out.get("recovery_positions"), ref["recovery_positions"]) > 1e-6 and not f.messages:
        f.add(f"reactivating after the fault moved the motors differently from holding where they were (up to "
              f"{_max_diff(out.get('recovery_positions'), ref['recovery_positions']):.3f} rad off): on_activate must "
              "read the board and copy the measured positions into the commands every time, not only the first")
    if not out.get("exceptions_total", 0) and out.get("nan_peer") == "active" and out.get("nan_refused", 0):
        f.add("the board refused a frame with a NaN (board.write() returned False) but write() returned OK: "
              "return return_type.ERROR when board.write() fails")
    for stage in ("read", "write"):
        why = allocation_verdict(f"{stage}()", out.get(f"alloc_{stage}"))
        if why:
            f.add(why)
    return f.done(f"{n} motors: no activation jump, commands and states exact over "
                  f"{len(rtrack['target'])} cycles, read/write errors returned as ERROR, recovery without a jump")


# --- exercise 2: cubic spline sampling, as the JTC does it -------------------------------------------------------


def _cubic_inputs(rng):
    cases = [{"p0": [0.0], "v0": [0.0], "p1": [1.0], "v1": [0.0], "T": 1.0, "t": [0.0, 0.25, 0.5, 1.0]}]
    for _ in range(8):
        n = int(rng.integers(1, 7))
        T = float(rng.uniform(0.2, 3.0))
        ts = sorted([0.0, T] + rng.uniform(0, T, 5).tolist())
        cases.append({"p0": rng.uniform(-2, 2, n).tolist(), "v0": rng.uniform(-1, 1, n).tolist(),
                      "p1": rng.uniform(-2, 2, n).tolist(), "v1": rng.uniform(-1, 1, n).tolist(), "T": T, "t": ts})
    return cases


def _cubic_probe(inputs, cubic_sample):
    out = []
    for c in inputs:
        args = [np.array(c[k]) for k in ("p0", "v0", "p1", "v1")]
        out.append([call(cubic_sample, *args, c["T"], t) for t in c["t"]])
    return out


def _jtc_cubic(c, t):
    """The JTC's own sample of the segment (trajectory.py), for the judge."""
    from .controllers.joint_trajectory_controller.trajectory import Sample, Trajectory

    n = len(c["p0"])
    traj = Trajectory([0.0, c["T"]], [c["p0"], c["p1"]], velocities=[c["v0"], c["v1"]], start_time=1.0)
    s = Sample(n)
    traj.sample(1.0 + c["T"] / 2, s)  # start it (the start state is unused inside a later segment)
    traj.sample(1.0 + t if t < c["T"] else 1.0 + c["T"] - 1e-12, s)
    if t >= c["T"]:
        traj._evaluate(c["T"], c["T"], s)
    return s.positions.copy(), s.velocities.copy(), s.accelerations.copy()


@register("ch04.cubic", weight=2, time_limit=20, uses=("cubic_sample",), probe=_cubic_probe, inputs=_cubic_inputs,
          references=("robocourse.control.controllers.joint_trajectory_controller.trajectory:Trajectory",
                      "robocourse.control.controllers.joint_trajectory_controller.trajectory:_coefficients"))
def check_cubic(inputs, outputs):
    """cubic_sample(p0, v0, p1, v1, T, t) -> (position, velocity, acceleration) arrays, the JTC's cubic segment."""
    f = Failures()
    for c, got_all in zip(inputs, outputs, strict=True):
        for t, got in zip(c["t"], got_all, strict=True):
            where = f"(T={c['T']:.3f} s, t={t:.3f} s, {len(c['p0'])} joints)"
            if "raised" in got:
                f.add(f"raised {got['raised']}: {got['message']} {where}")
                break
            try:
                p, v, a = (np.asarray(x, dtype=float).reshape(-1) for x in got["value"])
            except (TypeError, ValueError, KeyError):
                f.add(f"return (position, velocity, acceleration), each an array with one value per joint; got "
                      f"{got.get('type')} {where}")
                break
            rp, rv, ra = _jtc_cubic(c, t)
            if p.shape != rp.shape or v.shape != rv.shape or a.shape != ra.shape:
                f.add(f"one value per joint: got {p.size}, {v.size}, {a.size} values for {rp.size} joints {where}")
                break
            wrong = [name for name, x, y in (("position", p, rp), ("velocity", v, rv), ("acceleration", a, ra))
                     if not np.allclose(x, y, rtol=1e-9, atol=1e-9)]
            if wrong:
                p0, v0, p1, v1 = (np.round(np.asarray(c[k], dtype=float), 5).tolist() for k in ("p0", "v0", "p1", "v1"))
                hint = (f"at t = 0 the segment starts where the first point is: q(0) = p0 = {p0}, q'(0) = v0 = {v0}"
                        if t == 0.0 else
                        f"at t = T the segment must arrive at the second point: q(T) = p1 = {p1}, q'(T) = v1 = {v1}"
                        if t == c["T"] else
                        "inside the segment: the cubic is the one polynomial of degree 3 with q(0) = p0, q'(0) = v0, "
                        "q(T) = p1 and q'(T) = v1; velocity and acceleration are its first and second derivatives "
                        "(check yours meets the four conditions at t = 0 and t = T)")
                f.add(f"{' and '.join(wrong)} wrong {where}: {hint}. Expected position {np.round(rp, 5).tolist()}, "
                      f"velocity {np.round(rv, 5).tolist()}, acceleration {np.round(ra, 5).tolist()}")
                break
        if f.messages:
            break
    return f.done(f"{sum(len(c['t']) for c in inputs)} samples of {len(inputs)} segments equal the JTC's")


# --- exercise 3: a controller-manager parameter file that brings the stack up -------------------------------------

YAML_BOARDS = {"ArmBoard": ["joint1", "joint2"], "WristBoard": ["joint3"]}


def _yaml_probe(inputs, controllers_yaml):
    text = controllers_yaml() if callable(controllers_yaml) else controllers_yaml
    if not isinstance(text, str):
        return {"error": f"controllers_yaml must be the YAML text (a str), got {type(text).__name__}"}
    from . import introspection

    log = LogSink(log_to_stderr=False)
    out: dict = {"errors": []}
    try:
        cm = ControllerManager(boards_urdf(YAML_BOARDS, plugin="mock_components/GenericSystem"), params=text, log=log)
    except Exception as exc:  # noqa: BLE001 - the message is the feedback
        return {"error": f"{type(exc).__name__}: {exc}"}
    out["update_rate"] = cm.update_rate
    names = ["joint_state_broadcaster", "arm_controller", "wrist_controller"]
    for name in names:
        introspection.spawner(cm, [name], quiet=True)
    out["errors"] = [r.msg for r in log.records if int(r.severity) >= 40][:6]
    out["controllers"] = {n: {"type": s.type, "state": s.state.label} for n, s in cm.controllers.items()}
    arm = cm.controllers.get("arm_controller")
    if arm is not None and arm.state.label == "active":
        p = arm.c.params
        out["arm"] = {"joints": list(p.joints), "command_interfaces": list(p.command_interfaces),
                      "state_interfaces": list(p.state_interfaces), "goal_time": p.constraints.goal_time,
                      "goal": {j: p.constraints.get_entry(j).goal for j in p.joints}}
    wrist = cm.controllers.get("wrist_controller")
    if wrist is not None and wrist.state.label == "active":
        out["wrist_joints"] = list(wrist.c.params.joints)
        out["wrist_claims"] = [loan.name for loan in wrist.c.command_interfaces]
    cm.step(5)
    out["joint_states"] = len(cm.controllers["joint_state_broadcaster"].c.state_interfaces) \
        if "joint_state_broadcaster" in cm.controllers else 0
    return out


YAML_TYPES = {"joint_state_broadcaster": "joint_state_broadcaster/JointStateBroadcaster",
              "arm_controller": "joint_trajectory_controller/JointTrajectoryController",
              "wrist_controller": "position_controllers/JointGroupPositionController"}


@register("ch04.controllers_yaml", weight=2, time_limit=30, uses=("controllers_yaml",), probe=_yaml_probe)
def check_controllers_yaml(inputs, out):
    """controllers_yaml: the parameter file (ROS 2 layout) for the two-board robot, validated by the schemas."""
    if not isinstance(out, dict):
        raise CheckFailed("nothing came back from the parameter file")
    if out.get("error"):
        raise CheckFailed(f"the controller manager refused the file: {out['error']}")
    f = Failures()
    if out.get("update_rate") != 200:
        f.add(f"controller_manager update_rate is {out.get('update_rate')} Hz; the exercise asks for 200 "
              "(controller_manager: ros__parameters: update_rate: 200)")
    ctrls = out.get("controllers") or {}
    for name, typ in YAML_TYPES.items():
        got = ctrls.get(name)
        if got is None:
            f.add(f"'{name}' could not be loaded: declare it under controller_manager's ros__parameters as "
                  f"{name}: {{type: {typ}}}")
        elif got.get("type") != typ:
            f.add(f"'{name}' has type {got.get('type')!r}; expected {typ}")
        elif got.get("state") != "active":
            f.add(f"'{name}' was loaded but ended '{got.get('state')}' after spawning")
    if f.messages and out.get("errors"):
        f.add("the manager said: " + " | ".join(out["errors"][:3]))
    arm = out.get("arm")
    if isinstance(arm, dict):
        if arm.get("joints") != ["joint1", "joint2"]:
            f.add(f"arm_controller joints {arm.get('joints')}; expected [joint1, joint2] (the ArmBoard's)")
        if arm.get("command_interfaces") != ["position"]:
            f.add(f"arm_controller command_interfaces {arm.get('command_interfaces')}; the boards take [position]")
        if sorted(arm.get("state_interfaces") or []) != ["position", "velocity"]:
            f.add(f"arm_controller state_interfaces {arm.get('state_interfaces')}; use [position, velocity]")
        if arm.get("goal_time") != 1.0:
            f.add(f"constraints.goal_time is {arm.get('goal_time')}; expected 1.0 s")
        for j, g in (arm.get("goal") or {}).items():
            if g != 0.01:
                f.add(f"constraints.{j}.goal is {g}; expected 0.01 rad")
    if out.get("wrist_claims") is not None and out.get("wrist_claims") != ["joint3/position"]:
        f.add(f"wrist_controller claims {out.get('wrist_claims')}; expected [joint3/position]")
    return f.done("the stack comes up: broadcaster, JTC on the arm board at 200 Hz, forward controller on the wrist")


# --- exercise 4: which controllers a hardware error deactivates ----------------------------------------------------

FAULT_BOARDS = {"ArmBoard": ["joint1", "joint2"], "WristBoard": ["joint3"], "GripperBoard": ["joint4"]}


class _FaultBoard(SystemInterface):
    """A board whose read()/write() return a scripted result once ``fault`` is set (the judge's ground truth)."""

    def __init__(self):
        super().__init__()
        self.fault = None  # (stage, return_type)

    def read(self, time, period):
        if self.fault is not None and self.fault[0] == "read":
            return self.fault[1]
        for j in self.info.joints:
            self.set_state(f"{j.name}/position", self.get_command(f"{j.name}/position"))
        return return_type.OK

    def write(self, time, period):
        if self.fault is not None and self.fault[0] == "write":
            return self.fault[1]
        return return_type.OK


def _fault_scenario(rng, stage, result):
    """One random wiring that exercises the rule of (stage, result): a broadcaster reads the failed board's
    states without commanding it, and some controller uses nothing of the failed board."""
    joints = [j for js in FAULT_BOARDS.values() for j in js]
    while True:
        perm = list(rng.permutation(joints))
        cut = sorted(rng.choice(range(1, len(joints)), size=2, replace=False).tolist())
        groups = [perm[:cut[0]], perm[cut[0]:cut[1]], perm[cut[1]:]]
        controllers = {}
        for i, g in enumerate(groups):
            if g:
                controllers[f"forward_{i}"] = {"command": [f"{j}/position" for j in sorted(g)], "state": []}
        for i in range(int(rng.integers(1, 3))):
            seen = sorted(rng.choice(joints, size=int(rng.integers(1, 3)), replace=False).tolist())
            controllers[f"broadcaster_{i}"] = {"command": [],
                                               "state": [f"{j}/{s}" for j in seen for s in ("position", "velocity")]}
        failed = str(rng.choice(list(FAULT_BOARDS)))
        mine = set(FAULT_BOARDS[failed])
        uses = {n: {k.split("/")[0] for k in c["command"] + c["state"]} & mine for n, c in controllers.items()}
        readers = [n for n, c in controllers.items() if not c["command"] and uses[n]]
        bystanders = [n for n in controllers if not uses[n]]
        if readers and bystanders:
            return {"controllers": controllers, "failed": failed, "stage": stage, "result": result}


def _fault_inputs(rng):
    kinds = [("read", "ERROR"), ("write", "ERROR"), ("write", "DEACTIVATE")]
    kinds += [kinds[int(i)] for i in rng.integers(0, 3, 3)]
    order = rng.permutation(len(kinds))
    return {"hardware": {b: [f"{j}/{i}" for j in js for i in ("position", "velocity")]
                         for b, js in FAULT_BOARDS.items()},
            "scenarios": [_fault_scenario(rng, *kinds[int(k)]) for k in order]}


def _fault_probe(inputs, after_hardware_error):
    return [call(after_hardware_error, s["controllers"], inputs["hardware"], s["failed"], s["stage"], s["result"])
            for s in inputs["scenarios"]]


def fault_truth(scenario) -> dict:
    """Run the scenario under the real manager: which controllers end inactive, which state the board ends in."""
    params = {"controller_manager": {"update_rate": 100}}
    for name, c in scenario["controllers"].items():
        if c["command"]:
            params["controller_manager"][f"{name}.type"] = "position_controllers/JointGroupPositionController"
            params[name] = {"joints": [k.split("/")[0] for k in c["command"]]}
        else:
            params["controller_manager"][f"{name}.type"] = "joint_state_broadcaster/JointStateBroadcaster"
            params[name] = {"joints": sorted({k.split("/")[0] for k in c["state"]}),
                            "interfaces": ["position", "velocity"]}
    boards = {b: _FaultBoard() for b in FAULT_BOARDS}
    cm = ControllerManager(boards_urdf(FAULT_BOARDS, plugin="robocourse/FaultBoard"), components=boards,
                           params=params, log=LogSink(log_to_stderr=False))
    for name in scenario["controllers"]:
        cm.load_controller(name)
        cm.configure_controller(name)
    if cm.switch_controller(list(scenario["controllers"]), [], STRICT) != return_type.OK:
        raise RuntimeError(f"the fault scenario did not come up: {cm.last_switch_message}")
    cm.step(2)
    boards[scenario["failed"]].fault = (scenario["stage"], return_type[scenario["result"]])
    cm.step()
    return {"deactivated": sorted(n for n, s in cm.controllers.items() if s.state.label != "active"),
            "hardware_state": cm.rm.components[scenario["failed"]].wrapper.state.label}


@register("ch04.read_error", weight=2, time_limit=20, uses=("after_hardware_error",), probe=_fault_probe,
          inputs=_fault_inputs, references=("robocourse.control.manager.controller_manager:ControllerManager",))
def check_read_error(inputs, outputs):
    """after_hardware_error(controllers, hardware, failed, stage, result) -> {"deactivated": [...], "hardware_state": ...}."""
    f = Failures()
    for s, got in zip(inputs["scenarios"], outputs, strict=True):
        want = fault_truth(s)
        what = f"{s['failed']}'s {s['stage']}() returned {s['result']}"
        if "raised" in got:
            f.add(f"{what}: raised {got['raised']}: {got['message']}")
            continue
        value = got.get("value")
        if not isinstance(value, dict) or "deactivated" not in value or "hardware_state" not in value:
            f.add(f"{what}: return a dict with 'deactivated' (controller names) and 'hardware_state'; got "
                  f"{got.get('type')}")
            continue
        deact = value["deactivated"] if isinstance(value["deactivated"], list) else []
        names = sorted(str(x) for x in deact)
        if names != want["deactivated"]:
            missing = sorted(set(want["deactivated"]) - set(names))
            extra = sorted(set(names) - set(want["deactivated"]))
            why = []
            if missing:
                why.append(f"{missing} also stop" + (": a read/write ERROR stops every controller using the "
                                                     "component's command OR state interfaces"
                                                     if s["result"] == "ERROR" else ""))
            if extra:
                why.append(f"{extra} keep running" + (": DEACTIVATE only stops the controllers holding the "
                                                      "component's command interfaces; its states stay readable"
                                                      if s["result"] == "DEACTIVATE" else
                                                      ": they use no interface of the failed component"))
            f.add(f"{what}: you said {names} stop, the manager stops {want['deactivated']}; " + "; ".join(why))
        if str(value["hardware_state"]).lower() != want["hardware_state"]:
            f.add(f"{what}: the component ends '{want['hardware_state']}', not {value['hardware_state']!r}"
                  + (" (ERROR runs on_error; its default SUCCESS leaves it unconfigured)" if s["result"] == "ERROR"
                     else " (DEACTIVATE makes it inactive: read() continues)"))
    return f.done(f"{len(inputs['scenarios'])} hardware faults predicted like the controller manager")


# --- exercise 5: admittance gains for a given response ------------------------------------------------------------

SETTLE_BAND = 0.02      # settled: within 2 % of the rest deflection
SETTLE_SLACK = 0.01     # a settle time 1 % over the asked one still counts (a rounded constant)
SETTLE_EARLIEST = 0.9   # and not sooner than 0.9 x the asked time (a lighter virtual mass amplifies sensor noise)


def admittance_response(mass, stiffness, damping, t) -> np.ndarray:
    """x(t) / x_rest of ``M x'' + D x' + K x = F`` from rest under a step force (closed form).

    What the AdmittanceController does per axis with the measured force (upstream's admittance_rule)."""
    t = np.asarray(t, dtype=float)
    w = math.sqrt(stiffness / mass)
    zeta = damping / (2.0 * math.sqrt(mass * stiffness))
    if abs(zeta - 1.0) < 1e-9:
        return 1.0 - (1.0 + w * t) * np.exp(-w * t)
    if zeta > 1.0:
        r = math.sqrt(zeta * zeta - 1.0)
        r1, r2 = -w * (zeta - r), -w * (zeta + r)
        return 1.0 + (r2 * np.exp(r1 * t) - r1 * np.exp(r2 * t)) / (r1 - r2)
    wd = w * math.sqrt(1.0 - zeta * zeta)
    return 1.0 - np.exp(-zeta * w * t) * (np.cos(wd * t) + zeta * w / wd * np.sin(wd * t))


def settle_time(mass, stiffness, damping, band: float = SETTLE_BAND) -> float:
    """The last time (s) the step response is outside +-``band`` of its rest value."""
    w = math.sqrt(stiffness / mass)
    horizon = 50.0 / w * max(1.0, damping / (2.0 * math.sqrt(mass * stiffness))) ** 2
    t = np.linspace(0.0, horizon, 200_001)
    outside = np.nonzero(np.abs(admittance_response(mass, stiffness, damping, t) - 1.0) > band)[0]
    if len(outside) == 0:
        return 0.0
    lo, hi = t[outside[-1]], t[min(outside[-1] + 1, len(t) - 1)]
    for _ in range(60):                      # bisect the crossing between two grid points
        mid = 0.5 * (lo + hi)
        if abs(admittance_response(mass, stiffness, damping, mid) - 1.0) > band:
            lo = mid
        else:
            hi = mid
    return float(hi)


def _adm_inputs(rng):
    cases = []
    while len(cases) < 3:
        force = round(float(rng.uniform(5, 40)), 1)
        deflection = round(float(rng.uniform(0.01, 0.05)), 3)
        settle = round(float(rng.uniform(0.3, 1.5)), 2)
        mass = force / deflection * (settle / 5.8335) ** 2     # what a critically damped answer needs
        if 0.5 <= mass <= 60.0 and abs(mass - 1.0) > 0.3:
            cases.append({"force": force, "deflection": deflection, "settle": settle})
    return cases


def _adm_probe(inputs, tune_admittance):
    return [call(tune_admittance, c["force"], c["deflection"], c["settle"]) for c in inputs]


@register("ch04.admittance", weight=2, time_limit=20, uses=("tune_admittance",), probe=_adm_probe,
          inputs=_adm_inputs)
def check_admittance(inputs, outputs):
    """tune_admittance(force, deflection, settle) -> {"mass", "stiffness", "damping_ratio", "damping"}."""
    from .controllers.admittance_controller import AdmittanceController
    from .parameters import ParamListener

    f = Failures()
    if not isinstance(outputs, list) or len(outputs) != len(inputs):
        raise CheckFailed("the probe returned no answer per case")
    for c, got in zip(inputs, outputs):
        where = f"(push {c['force']:g} N, yield {c['deflection'] * 1e3:.0f} mm, settle in {c['settle']:g} s)"
        if not isinstance(got, dict) or "raised" in got:
            f.add(f"raised {got.get('raised') if isinstance(got, dict) else got}: "
                  f"{got.get('message') if isinstance(got, dict) else ''} {where}")
            continue
        v = got.get("value")
        try:
            m, k, zeta, d = (number(v[key]) for key in ("mass", "stiffness", "damping_ratio", "damping"))
        except (TypeError, KeyError):
            f.add(f"return a dict with 'mass' (kg), 'stiffness' (N/m), 'damping_ratio' and 'damping' (N s/m); got "
                  f"{got.get('type')} {where}")
            continue
        if not all(math.isfinite(x) for x in (m, k, zeta, d)):
            f.add(f"mass {m}, stiffness {k}, damping_ratio {zeta}, damping {d}: every value must be a finite number {where}")
            continue
        try:
            ParamListener(AdmittanceController.PARAMS, {  # the controller's own bounds
                "joints": ["j"], "command_interfaces": ["position"], "state_interfaces": ["position"],
                "chainable_command_interfaces": ["position"], "ft_sensor.name": "fts",
                "admittance.mass": [m] * 6, "admittance.stiffness": [k] * 6, "admittance.damping_ratio": [zeta] * 6})
        except Exception as exc:  # noqa: BLE001 - the schema's message is the feedback
            f.add(f"the AdmittanceController refuses these values: {exc} {where}")
            continue
        if not k > 0:
            f.add(f"stiffness {k:g}: without a spring (K = 0) the tool never comes to rest at a deflection {where}")
            continue
        if not math.isclose(d, 2 * zeta * math.sqrt(m * k), rel_tol=1e-6):
            f.add(f"damping {d:.4g} N s/m does not go with damping_ratio {zeta:g}, mass {m:g} kg and stiffness {k:g} N/m "
                  f"as the controller computes it (D = 2 zeta sqrt(M K) = {2 * zeta * math.sqrt(m * k):.4g}) {where}")
            continue
        rest = c["force"] / k
        if not math.isclose(rest, c["deflection"], rel_tol=0.01):
            f.add(f"at rest the spring balances the push: F / K = {rest * 1e3:.2f} mm, not the {c['deflection'] * 1e3:.0f} mm "
                  f"asked {where}")
            continue
        if zeta < 1.0 - 1e-9:
            over = math.exp(-math.pi * zeta / math.sqrt(1.0 - zeta * zeta))
            f.add(f"damping_ratio {zeta:g} < 1 overshoots the rest point by {100 * over:.3g} % {where}: 'without "
                  "overshoot' means any overshoot at all")
            continue
        t_s = settle_time(m, k, 2 * zeta * math.sqrt(m * k))
        if t_s > c["settle"] * (1 + SETTLE_SLACK):
            f.add(f"it settles (within {SETTLE_BAND:.0%}) after {t_s:.3f} s, later than the {c['settle']:g} s asked "
                  f"{where}: a heavier virtual mass or more damping than critical is slower")
        elif t_s < SETTLE_EARLIEST * c["settle"]:
            f.add(f"it settles after {t_s:.3f} s, sooner than {SETTLE_EARLIEST:g} x {c['settle']:g} s {where}: the task "
                  "asks for the settle time given, not the fastest possible (a light virtual mass amplifies sensor noise)")
    return f.done(f"{len(inputs)} tunings rest at the asked deflection, never overshoot and settle in the asked time")


# --- shared by the controller exercises: a mock arm, a recorder, the allocation probe ------------------------------


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


def allocation_verdict(what: str, alloc, bytes_per_joint: int = 8) -> str | None:
    """The feedback for ``allocation_growth`` data, or None when the call creates no buffer per cycle."""
    if not isinstance(alloc, dict):
        return None if alloc is None else f"{what} could not be measured: {alloc}"
    try:
        (n0, n1), (p0, p1), kept = alloc["sizes"], alloc["peak_bytes"], number(alloc["kept_per_call"])
        p0, p1 = number(p0), number(p1)
    except (KeyError, TypeError, ValueError):
        return f"{what}: the allocation measurement came back malformed"
    if not (math.isfinite(p0) and math.isfinite(p1) and math.isfinite(kept)):
        return f"{what}: the allocation measurement came back malformed"
    grown = p1 - p0
    if grown >= bytes_per_joint * (n1 - n0):
        return (f"{what} allocates a buffer every cycle: its peak memory grows from {p0:.0f} to {p1:.0f} bytes from "
                f"{n0} to {n1} joints (tracemalloc). Make arrays in on_configure and write into them (np.copyto, "
                "out=, np.take(..., out=buf, mode='clip'), a loop); values[idx] and list comprehensions build new ones")
    if kept > 8:
        return (f"{what} keeps {kept:.0f} bytes per call that are never freed (a list or dict growing every "
                "cycle): a real-time loop must run forever in constant memory")
    return None


# --- exercise 6: a controller of your own (ControllerInterface) ------------------------------------------------------

CTRL_JOINTS = ("joint1", "joint2", "joint3", "joint4")
CTRL_NAME = "slew_controller"


def _ctrl_inputs(rng):
    initial = {j: round(float(v), 3) for j, v in zip(CTRL_JOINTS, rng.uniform(-1.0, 1.0, len(CTRL_JOINTS)))}
    k = int(rng.integers(2, 4))
    joints = [CTRL_JOINTS[i] for i in rng.permutation(len(CTRL_JOINTS))[:k]]
    start = np.array([initial[j] for j in joints])
    return {"initial": initial, "joints": joints, "max_velocity": round(float(rng.uniform(0.3, 1.0)), 2),
            "target1": (start + rng.choice([-1, 1], k) * rng.uniform(0.2, 0.6, k)).round(3).tolist(),
            "target2": (start + rng.uniform(-0.3, 0.3, k)).round(3).tolist(),
            "moved": (start + rng.uniform(-0.5, 0.5, k)).round(3).tolist(),
            "slow_rate": int(rng.choice([20, 25, 50]))}


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

    out["hold"] = record(20, _positions)                       # 1. activated with no target: nothing moves
    pub.publish(Float64MultiArray(data=list(inputs["target1"])))
    out["track"] = record(150)                                  # 2. slew toward the target at max_velocity
    pub.publish(Float64MultiArray(data=list(inputs["target2"])))
    bad = record(8)
    pub.publish(Float64MultiArray(data=[math.nan] + list(inputs["target1"][1:])))   # 3. a NaN: ignored
    bad += record(8)
    pub.publish(Float64MultiArray(data=list(inputs["target1"]) + [0.0]))              # 4. wrong size: ignored
    bad += record(30)
    out["bad_input"] = bad
    out["state_after_bad_input"] = cm.controllers[CTRL_NAME].state.label
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
        rows = []
        for _ in range(40):
            slow.step()
            rows.append(_commands(slow, joints))
        out["slow"] = rows

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


def _ctrl_probe(inputs, SlewRateController):
    return controller_scenario(inputs, SlewRateController)


class _ReferenceSlew(ControllerInterface):
    """The judge's reference for exercise 6 (what the solution notebook asks students to write)."""

    from .parameters import ParameterSchema as _Schema

    PARAMS = _Schema.from_yaml("""
slew_rate_controller:
  joints: {type: string_array, validation: {not_empty<>: null, unique<>: null}}
  max_velocity: {type: double, default_value: 0.5, validation: {gt<>: [0.0]}}
""")
    del _Schema

    def _names(self):
        return InterfaceConfiguration(ict.INDIVIDUAL, [name + "/position" for name in self.params.joints])

    command_interface_configuration = state_interface_configuration = _names

    def on_configure(self, previous_state):
        from robocourse.msgs.std_msgs import Float64MultiArray

        size = len(self.params.joints)
        self._out, self._goal, self._delta, self._inbox = np.zeros(size), np.zeros(size), np.zeros(size), None
        if self._node is None:
            self.get_node().create_subscription(Float64MultiArray, "~/commands", self._take, 10)
        return CallbackReturn.SUCCESS

    def _take(self, msg):
        values = np.asarray(msg.data, dtype=float)
        if values.shape == self._goal.shape and np.isfinite(values).all():
            self._inbox = values

    def on_activate(self, previous_state):
        from .manager.loaned import InterfaceGroup

        self._cmd, self._meas = InterfaceGroup(self.command_interfaces), InterfaceGroup(self.state_interfaces)
        self._meas.get(out=self._out)
        np.copyto(self._goal, self._out)
        self._inbox = None
        return CallbackReturn.SUCCESS

    def update(self, time, period):
        box, self._inbox = self._inbox, None
        if box is not None:
            np.copyto(self._goal, box)
        bound = period * self.params.max_velocity
        np.clip(np.subtract(self._goal, self._out, out=self._delta), -bound, bound, out=self._delta)
        self._out += self._delta
        self._cmd.set(self._out)
        return return_type.OK


def _rows_differ(got, want, tol=1e-9) -> tuple[int, float] | None:
    """(first row index, difference) where two recordings part, or None when they agree."""
    try:
        g, w = np.asarray(got, dtype=float), np.asarray(want, dtype=float)
    except (TypeError, ValueError):
        return (0, math.inf)
    if g.shape != w.shape:
        return (0, math.inf)
    d = np.abs(g - w)
    d[np.isnan(d) & ~(np.isnan(g) & np.isnan(w))] = math.inf
    d[np.isnan(g) & np.isnan(w)] = 0.0
    bad = np.nonzero(d.max(axis=-1) > tol)[0] if d.ndim > 1 else np.nonzero(d > tol)[0]
    return None if len(bad) == 0 else (int(bad[0]), float(d[bad[0]].max()))


@register("ch04.controller", weight=4, time_limit=60, uses=("SlewRateController",), probe=_ctrl_probe,
          inputs=_ctrl_inputs, references=("robocourse.control.checks:_ReferenceSlew",))
def check_controller(inputs, out):
    """SlewRateController: claims, no activation jump, slew at max_velocity with the period given, bad input ignored."""
    if not isinstance(out, dict):
        raise CheckFailed("the scenario returned nothing")
    ref = controller_scenario(inputs, _ReferenceSlew)
    f = Failures()
    joints, vmax = inputs["joints"], inputs["max_velocity"]
    if out.get("load"):
        raise CheckFailed(f"the controller did not come up: {out['load']}")
    want_c, want_s = ref["claimed_commands"], ref["claimed_states"]
    if out.get("claimed_commands") != want_c or out.get("claimed_states") != want_s:
        f.add(f"with joints {joints} it claimed command interfaces {out.get('claimed_commands')} and state interfaces "
              f"{out.get('claimed_states')}; expected {want_c} and {want_s}, in the order of the 'joints' parameter "
              "(INDIVIDUAL, '<joint>/position')")
    if out.get("switch") != 0:
        alone = out.get("switch_alone")
        f.add("it could not be activated next to a controller on the other joints: "
              + (out.get("switch_message") or "").replace("\n", " ")
              + (" (alone it activated: it claims interfaces it does not need, e.g. ALL)" if alone == 0 else ""))
        if alone != 0:
            f.add("alone it could not be activated either: " + (out.get("switch_alone_message") or "").replace("\n", " "))
            return f.done("")
    hold = out.get("hold")
    start = [inputs["initial"][j] for j in joints]
    if _rows_differ(hold, [start] * len(ref["hold"])) is not None:
        try:
            moved = float(np.abs(np.asarray(hold, dtype=float) - start).max())
        except (TypeError, ValueError):
            moved = math.inf
        f.add(f"the activation jump: activated with no target, the joints moved up to {moved:.3f} rad from {start}. "
              "on_activate must copy each joint's measured position (state interface) into the command it writes")
    track = _rows_differ(out.get("track"), ref["track"])
    if track is not None:
        k, d = track
        f.add(f"each update moves every command toward the newest target by at most max_velocity * period "
              f"({vmax:g} rad/s x {1 / 100:g} s) and stops on it. Target {inputs['target1']}, cycle {k + 1}: "
              f"commands {_row(out.get('track'), k)}, expected {_row(ref['track'], k)}")
    bad = _rows_differ(out.get("bad_input"), ref["bad_input"])
    if bad is not None or out.get("state_after_bad_input") != "active":
        k = bad[0] if bad else 0
        f.add(f"a message with a NaN, or with {len(joints) + 1} values, must be ignored: the controller keeps its last "
              f"valid target {inputs['target2']} and stays active (it is '{out.get('state_after_bad_input')}'). "
              f"Cycle {k + 1}: commands {_row(out.get('bad_input'), k)}, expected {_row(ref['bad_input'], k)}")
    re = _rows_differ(out.get("reactivated"), ref["reactivated"])
    if out.get("reswitch") != 0 or re is not None:
        f.add("copy the measured positions in on_activate every time, not once in on_configure: deactivated, moved "
              f"to {inputs['moved']} by another controller and activated again, it drove the joints to "
              f"{_row(out.get('reactivated'), -1)} instead of holding {_row(ref['reactivated'], -1)}")
    slow = _rows_differ(out.get("slow"), ref.get("slow"))
    if slow is not None:
        k, d = slow
        f.add(f"Use the period argument, not a fixed step: with update_rate: {inputs['slow_rate']} under a 100 Hz "
              f"manager, update() runs every {100 // inputs['slow_rate']} cycles with period "
              f"{1 / inputs['slow_rate']:g} s. Cycle {k + 1}: commands {_row(out.get('slow'), k)}, expected "
              f"{_row(ref['slow'], k)}")
    alloc = allocation_verdict("update()", out.get("alloc"))
    if alloc:
        f.add(alloc)
    if out.get("errors") and f.messages:
        f.add("the manager logged: " + " | ".join(out["errors"][:3]))
    return f.done(f"{len(joints)} joints: claims in order, no jump on activation, slewing at {vmax:g} rad/s with the "
                  "period given, bad messages ignored, no buffer allocated per update")


def _row(rows, k) -> list:
    try:
        return [round(float(v), 6) for v in rows[k]]
    except (TypeError, IndexError, ValueError, KeyError):
        return []


# --- exercise 7: a chainable controller after the JTC (a joint limiter) --------------------------------------------

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


def _lim_inputs(rng):
    n = int(rng.integers(2, 4))
    joints = [f"joint{i + 1}" for i in range(n)]
    lo, hi = (-rng.uniform(0.3, 0.8, n)).round(3), rng.uniform(0.3, 0.8, n).round(3)
    initial = (rng.uniform(0.2, 0.6, n) * np.where(rng.random(n) < 0.5, lo, hi)).round(3)
    rate = int(rng.choice([100, 200]))
    vmax = round(float(rng.uniform(0.4, 1.0)), 2)
    beyond = (hi + rng.uniform(0.1, 0.4, n)).round(3)                 # every joint asked past its upper limit
    script = [initial.tolist()] * 10                                   # A: hold, the limiter is transparent
    script += [np.where(np.arange(n) == 0, beyond, initial).tolist()] * int(rate * 1.2)   # B: joint 1 past its limit
    nan_row = np.where(np.arange(n) == n - 1, np.nan, beyond).tolist()
    script += [nan_row] * 8                                            # C: NaN on the last joint: it holds
    t = np.arange(int(rate * 0.8)) / rate                              # D: a slow wave inside the limits
    wave = 0.5 * np.outer(np.sin(2 * np.pi * 0.5 * t), (hi - lo) / 2 * 0.5) + (lo + hi) / 2
    script += wave.round(6).tolist()
    jtc_goal = np.where(np.arange(n) % 2 == 0, beyond, lo + (hi - lo) * 0.3).round(3)
    return {"joints": joints, "min": lo.tolist(), "max": hi.tolist(), "initial": initial.tolist(), "rate": rate,
            "max_velocity": vmax, "script": script, "jtc_goal": jtc_goal.tolist()}


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
        out["jtc_run"] = record(int(1.5 * inputs["rate"]))
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


def _lim_probe(inputs, JointLimiter):
    return limiter_scenario(inputs, JointLimiter)


def _reference_limiter():
    """The judge's reference for exercise 7 (built lazily: the chainable base lives in the manager package)."""
    from .manager.controller_interface import ChainableControllerInterface
    from .parameters import ParameterSchema

    class _ReferenceLimiter(ChainableControllerInterface):
        PARAMS = ParameterSchema.from_yaml("""
joint_limiter:
  joints: {type: string_array, validation: {not_empty<>: null, unique<>: null}}
  max_velocity: {type: double, default_value: 1.0, validation: {gt<>: [0.0]}}
  min_position: {type: double_array, default_value: []}
  max_position: {type: double_array, default_value: []}
""")

        def on_configure(self, previous_state):
            size = len(self.params.joints)
            if {len(self.params.min_position), len(self.params.max_position)} != {size}:
                return CallbackReturn.ERROR
            self._low = np.asarray(self.params.min_position, dtype=float)
            self._high = np.asarray(self.params.max_position, dtype=float)
            self._out, self._aim, self._gap = np.zeros(size), np.zeros(size), np.zeros(size, dtype=bool)
            return CallbackReturn.SUCCESS

        def _names(self):
            return InterfaceConfiguration(ict.INDIVIDUAL, [name + "/position" for name in self.params.joints])

        command_interface_configuration = state_interface_configuration = _names

        def on_export_reference_interfaces(self):
            return [name + "/position" for name in self.params.joints]

        def on_activate(self, previous_state):
            from .manager.loaned import InterfaceGroup

            self._cmd = InterfaceGroup(self.command_interfaces)
            InterfaceGroup(self.state_interfaces).get(out=self._out)
            np.copyto(self.reference_interfaces, self._out)
            return CallbackReturn.SUCCESS

        def update_reference_from_subscribers(self, time, period):
            return return_type.OK

        def update_and_write_commands(self, time, period):
            bound = period * self.params.max_velocity
            np.copyto(self._aim, self.reference_interfaces)
            np.putmask(self._aim, np.isnan(self._aim, out=self._gap), self._out)
            np.minimum(np.maximum(self._aim, self._low, out=self._aim), self._high, out=self._aim)
            self._aim -= self._out
            np.clip(self._aim, -bound, bound, out=self._aim)
            self._out += self._aim
            self._cmd.set(self._out)
            return return_type.OK

    return _ReferenceLimiter


@register("ch04.chainable", weight=4, time_limit=90, uses=("JointLimiter",), probe=_lim_probe, inputs=_lim_inputs)
def check_chainable(inputs, out):
    """JointLimiter after a JTC: reference interfaces, the chain's activation rules, limited output, NaN held."""
    if not isinstance(out, dict):
        raise CheckFailed("the scenario returned nothing")
    if out.get("load"):
        raise CheckFailed(f"the limiter did not come up: {out['load']}")
    ref = limiter_scenario(inputs, _reference_limiter())
    f = Failures()
    joints, rate, vmax = inputs["joints"], inputs["rate"], inputs["max_velocity"]
    refs = [f"{LIM_NAME}/{j}/position" for j in joints]
    if not out.get("chainable"):
        f.add("is_chainable() is False: derive the limiter from ChainableControllerInterface")
    if out.get("exported") != refs:
        f.add("reference interfaces: on_export_reference_interfaces returns '<joint>/position' for each joint, in "
              f"order (the manager adds the controller's name); the JTC needs {refs}, got {out.get('exported')}")
    rules = []
    if (out.get("jtc_alone") or [0])[0] == 0:
        rules.append("the JTC was activated while the limiter it writes into was inactive (its reference "
                     "interfaces must exist, and be unavailable until the limiter is active)")
    if (out.get("limiter_alone") or [1])[0] != 0:
        rules.append(f"the limiter alone could not be activated: {(out.get('limiter_alone') or ['', ''])[1]}")
    if (out.get("jtc_after") or [1])[0] != 0:
        rules.append(f"with the limiter active the JTC could not be activated: {(out.get('jtc_after') or ['', ''])[1]}")
    elif out.get("order") != ref["order"] or not out.get("chained_with_jtc"):
        rules.append(f"the manager's update order is {out.get('order')} and the limiter's chained mode "
                     f"{out.get('chained_with_jtc')}; expected {ref['order']} and True (on_set_chained_mode must accept)")
    if (out.get("limiter_under_jtc") or [0])[0] == 0:
        rules.append("the limiter was deactivated while the JTC still wrote into it")
    if out.get("chained_after_jtc") not in (False, None):
        rules.append("after the JTC was deactivated the limiter still says it is in chained mode")
    for r in rules:
        f.add("chain rules: " + r)
    if out.get("limiter_alone", [1])[0] == 0:
        hold = out.get("hold")
        if _rows_differ(hold, [inputs["initial"]] * len(ref["hold"])) is not None:
            f.add(f"activated before any reference was written, the joints moved from {inputs['initial']} to "
                  f"{_row(hold, -1)}: on_activate must start the command (and the reference interfaces) at the "
                  "measured positions; the reference interfaces start as NaN")
    if ref.get("jtc_run") is not None and out.get("jtc_run") is not None:
        d = _rows_differ(out.get("jtc_run"), ref["jtc_run"])
        if d is not None:
            k, dv = d
            f.add(f"behind the JTC: clamp each reference to [min_position, max_position], then move the command "
                  f"toward it by at most max_velocity * period ({vmax:g} rad/s at {rate} Hz). Goal {inputs['jtc_goal']}, "
                  f"cycle {k + 1}: commands {_row(out['jtc_run'], k)}, expected {_row(ref['jtc_run'], k)}")
    script, sref = out.get("scripted"), ref.get("scripted")
    if sref is not None:
        n_b = 10 + int(rate * 1.2)
        phases = (("transparent while the reference is inside the limits", 0, 10),
                  ("past the upper limit: ramp at max_velocity, then stop at max_position", 10, n_b),
                  ("a NaN reference: that joint holds its last command", n_b, n_b + 8),
                  ("a wave inside the limits: follow it (after catching up at max_velocity)", n_b + 8, len(sref)))
        if script is None:
            f.add(f"the scripted preceding controller could not chain to the limiter: {out.get('writer_switch')}")
        else:
            for what, a, b in phases:
                d = _rows_differ(_rows(script, a, b), sref[a:b])
                if d is not None:
                    k, dv = d
                    f.add(f"{what}: script step {a + k + 1}, reference {_row(inputs['script'], a + k)}, limits "
                          f"{inputs['min']}..{inputs['max']}: commands {_row(script, a + k)}, expected "
                          f"{_row(sref, a + k)}")
    alloc = allocation_verdict("update()", out.get("alloc"))
    if alloc:
        f.add(alloc)
    return f.done(f"{len(joints)} joints behind a JTC: reference interfaces exported, chain rules hold, commands "
                  f"clamped to the limits at {vmax:g} rad/s, NaN held, nothing allocated per update")


def _rows(rows, a, b):
    try:
        return rows[a:b]
    except TypeError:
        return None


# --- exercise 8: the <ros2_control> element of the RRBot ------------------------------------------------------------

URDF_MAX_CHARS = 20_000
FT_STATES = ["force.x", "force.y", "force.z", "torque.x", "torque.y", "torque.z"]
#: the driver the exercise describes: per joint (command interfaces with (min, max), state interfaces)
RRBOT_SPEC = {"joint1": ({"position": (-1.0, 1.0), "velocity": (-3.0, 3.0)}, ["position", "velocity"]),
              "joint2": ({"velocity": (-3.0, 3.0)}, ["position", "velocity"])}


def _urdf_inputs(rng):
    return {"initial_positions": {j: round(float(v), 2) for j, v in zip(RRBOT_SPEC, rng.uniform(-0.8, 0.8, 2))},
            "joint1_target": round(float(rng.uniform(-0.6, 0.6)), 2), "joint2_velocity": round(float(rng.uniform(0.2, 0.6)), 2)}


def _urdf_probe(inputs, rrbot_ros2_control):
    return call(rrbot_ros2_control, dict(inputs["initial_positions"]))


def rrbot_with(element: str) -> str:
    """rrbot.urdf with its ``<ros2_control>`` element replaced by ``element`` (text)."""
    import re

    from robocourse.sim.robots import urdf_path

    text = urdf_path("rrbot").read_text()
    return re.sub(r"<ros2_control\s[^>]*>.*?</ros2_control>", lambda _m: element, text, count=1, flags=re.S)


def _urdf_runtime(urdf: str, inputs) -> dict:
    """Bring the URDF up on mock hardware: the states at start, then joint1 to a position and joint2 at a velocity."""

    params = {"controller_manager": {"update_rate": 100,
                                     "j1.type": "position_controllers/JointGroupPositionController",
                                     "j2.type": "velocity_controllers/JointGroupVelocityController"},
              "j1": {"joints": ["joint1"]}, "j2": {"joints": ["joint2"]}}
    log = LogSink(log_to_stderr=False)
    cm = ControllerManager(urdf, params=params, log=log)
    out = {"start": {k: cm.rm.value(k) for k in ("joint1/position", "joint2/position", "joint1/velocity")
                     if cm.rm.state_interface_exists(k)}}
    ok = all(cm.load_controller(n) is not None and cm.configure_controller(n) == return_type.OK for n in ("j1", "j2"))
    if not ok or cm.switch_controller(["j1", "j2"], [], STRICT) != return_type.OK:
        out["error"] = cm.last_switch_message or " | ".join(_errors(log))
        return out
    cm.controllers["j1"].c.set_command([inputs["joint1_target"]])
    cm.controllers["j2"].c.set_command([inputs["joint2_velocity"]])
    p0 = cm.rm.value("joint2/position")
    cm.spin_for(1.0)
    out["joint1_after"] = cm.rm.value("joint1/position")
    out["joint2_moved"] = cm.rm.value("joint2/position") - p0
    return out


def _float(text) -> float:
    try:
        return float(text)
    except (TypeError, ValueError):
        return math.nan


@register("ch04.ros2_control_urdf", weight=3, time_limit=30, uses=("rrbot_ros2_control",), probe=_urdf_probe,
          inputs=_urdf_inputs)
def check_ros2_control_urdf(inputs, got):
    """rrbot_ros2_control(initial_positions) -> the <ros2_control> element: parsed, loaded by MuJoCo, run on mock hardware."""
    import mujoco

    from .hardware.info import URDFError, parse_control_resources_from_urdf

    if "raised" in got:
        raise CheckFailed(f"rrbot_ros2_control raised {got['raised']}: {got['message']}")
    text = got.get("value")
    if not isinstance(text, str):
        raise CheckFailed(f"return the element as text (a str); got {got.get('type')}")
    if len(text) > URDF_MAX_CHARS or "<!" in text:
        raise CheckFailed(f"the element must be plain XML under {URDF_MAX_CHARS} characters without <!DOCTYPE>/<!ENTITY> "
                          f"(got {len(text)} characters)")
    urdf = rrbot_with(text.strip())
    try:
        infos = parse_control_resources_from_urdf(urdf)
    except URDFError as exc:
        raise CheckFailed(f"ros2_control's parser refuses it: {exc}") from None
    f = Failures()
    try:
        model = mujoco.MjModel.from_xml_string(urdf)
        names = [model.joint(i).name for i in range(model.njnt)]
        if names != ["joint1", "joint2"]:
            f.add(f"MuJoCo loads the URDF with joints {names}, not the RRBot's [joint1, joint2]")
    except ValueError as exc:
        f.add(f"MuJoCo cannot load the URDF with your element in it: {exc}")
    if len(infos) != 1:
        raise CheckFailed(f"write exactly one <ros2_control> element; the URDF now has {len(infos)}")
    hw = infos[0]
    if (hw.name, hw.type, hw.hardware_plugin_name) != ("RRBot", "system", "mock_components/GenericSystem"):
        f.add(f"the component is name={hw.name!r} type={hw.type!r} plugin={hw.hardware_plugin_name!r}; the driver "
              "described is one system named 'RRBot' with plugin mock_components/GenericSystem")
    if hw.hardware_parameters.get("calculate_dynamics", "").strip().lower() != "true":
        f.add(f"hardware parameters {hw.hardware_parameters}: the driver integrates velocity commands "
              "(<param name=\"calculate_dynamics\">true</param> inside <hardware>)")
    joints = {j.name: j for j in hw.joints}
    if list(joints) != list(RRBOT_SPEC):
        f.add(f"<joint> elements {list(joints)}; the RRBot's are {list(RRBOT_SPEC)} (in this order)")
    for jname, (cmds, states) in RRBOT_SPEC.items():
        j = joints.get(jname)
        if j is None:
            continue
        got_c = [i.name for i in j.command_interfaces]
        got_s = [i.name for i in j.state_interfaces]
        if sorted(got_c) != sorted(cmds) or sorted(got_s) != sorted(states):
            f.add(f"{jname}: command interfaces {got_c}, state interfaces {got_s}; the driver takes "
                  f"{sorted(cmds)} and reports {states}")
        for itf in j.command_interfaces:
            want = cmds.get(itf.name)
            if want is not None and (_float(itf.min), _float(itf.max)) != want:
                f.add(f"{jname}/{itf.name} limits min={itf.min!r} max={itf.max!r}; expected {want[0]:g} .. {want[1]:g} "
                      "(<param name=\"min\"> / <param name=\"max\"> inside the command_interface)")
    sensors = {s.name: s for s in hw.sensors}
    fts = sensors.get("tool_fts")
    if fts is None or len(sensors) != 1:
        f.add(f"<sensor> elements {list(sensors)}; the driver has one force/torque sensor named 'tool_fts'")
    else:
        got_s = [i.name for i in fts.state_interfaces]
        if got_s != FT_STATES:
            f.add(f"tool_fts state interfaces {got_s}; a force/torque sensor reports {FT_STATES}")
        if fts.parameters.get("frame_id") != "tool_link":
            f.add(f"tool_fts parameters {fts.parameters}: the sensor's frame is <param name=\"frame_id\">tool_link</param>")
    run = None
    try:
        run = _urdf_runtime(urdf, inputs)
    except (ValueError, RuntimeError, KeyError) as exc:
        f.add(f"the controller manager could not bring it up on mock hardware: {exc}")
    if run is not None:
        init = inputs["initial_positions"]
        start = run.get("start", {})
        for j in RRBOT_SPEC:
            v = start.get(f"{j}/position")
            if v is None or not math.isclose(v, init[j], abs_tol=1e-9):
                f.add(f"on mock hardware {j}/position starts at {v}, not initial_positions[{j!r}] = {init[j]} "
                      "(<param name=\"initial_value\"> in the position state_interface)")
        if run.get("error"):
            f.add("a position controller on joint1 and a velocity controller on joint2 could not be activated: "
                  + run["error"].replace("\n", " "))
        else:
            if not math.isclose(run.get("joint1_after", math.nan), inputs["joint1_target"], abs_tol=1e-9):
                f.add(f"joint1 commanded to {inputs['joint1_target']} rad ended at {run.get('joint1_after')}")
            want = inputs["joint2_velocity"] * 1.0
            moved = run.get("joint2_moved", math.nan)
            if not math.isclose(moved, want, rel_tol=0.02):
                f.add(f"joint2 commanded at {inputs['joint2_velocity']} rad/s for 1 s moved {moved:.3f} rad, not "
                      f"{want:.3f}: with calculate_dynamics the mock integrates the velocity command into position")
    return f.done("parsed like ros2_control, loaded by MuJoCo, the mock starts at the initial positions, joint1 "
                  "follows a position command, joint2 integrates a velocity command")
