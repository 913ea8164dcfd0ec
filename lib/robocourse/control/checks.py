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
                hint = ("at t = 0 the segment starts at p0 with velocity v0 (a0 = p0, a1 = v0)" if t == 0.0 else
                        "at t = T it must end at p1 with velocity v1: check a2 = (3(p1-p0) - (2 v0 + v1) T) / T^2 and "
                        "a3 = (2(p0-p1) + (v0 + v1) T) / T^3" if t == c["T"] else
                        "check a2 = (3(p1-p0) - (2 v0 + v1) T) / T^2, a3 = (2(p0-p1) + (v0 + v1) T) / T^3, velocity "
                        "a1 + 2 a2 t + 3 a3 t^2 and acceleration 2 a2 + 6 a3 t")
                f.add(f"{' and '.join(wrong)} wrong {where}: expected position {np.round(rp, 5).tolist()}, velocity "
                      f"{np.round(rv, 5).tolist()}, acceleration {np.round(ra, 5).tolist()}; {hint}")
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


def _fault_inputs(rng):
    scenarios = []
    joints = [j for js in FAULT_BOARDS.values() for j in js]
    for _ in range(6):
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
        stage, result = [("read", "ERROR"), ("write", "ERROR"), ("write", "DEACTIVATE")][int(rng.integers(0, 3))]
        scenarios.append({"controllers": controllers, "failed": str(rng.choice(list(FAULT_BOARDS))), "stage": stage,
                          "result": result})
    return {"hardware": {b: [f"{j}/{i}" for j in js for i in ("position", "velocity")]
                         for b, js in FAULT_BOARDS.items()}, "scenarios": scenarios}


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


def admittance_step(mass, stiffness, damping, force, seconds, dt=1e-4):
    """1-DOF admittance under a step force: M x'' + D x' + K x = F from rest; returns (t, x).

    What the AdmittanceController does per axis with the measured force (upstream's
    admittance_rule), integrated semi-implicitly at ``dt``.
    """
    x = v = 0.0
    n = int(seconds / dt)
    t = np.arange(1, n + 1) * dt
    out = np.empty(n)
    for k in range(n):
        v += (force - stiffness * x - damping * v) / mass * dt
        x += v * dt
        out[k] = x
    return t, out


def _settle_time(t, x, final):
    outside = np.nonzero(np.abs(x - final) > 0.02 * abs(final))[0]
    return float(t[outside[-1]]) if len(outside) else 0.0


def _adm_inputs(rng):
    cases = []
    for _ in range(3):
        mass = float(rng.choice([1.0, 2.0, 5.0]))
        force = round(float(rng.uniform(5, 40)), 2)
        deflection = round(float(rng.uniform(0.01, 0.05)), 4)
        k = force / deflection
        t, x = admittance_step(mass, k, 2 * math.sqrt(mass * k), force, 3.0)
        cases.append({"mass": mass, "force": force, "deflection": deflection,
                      "settle": round(1.5 * _settle_time(t, x, deflection), 3)})
    return cases


def _adm_probe(inputs, tune_admittance):
    return [call(tune_admittance, c["mass"], c["force"], c["deflection"], c["settle"]) for c in inputs]


@register("ch04.admittance", weight=2, time_limit=10, uses=("tune_admittance",), probe=_adm_probe,
          inputs=_adm_inputs)
def check_admittance(inputs, outputs):
    """tune_admittance(mass, force, deflection, settle) -> {"stiffness", "damping_ratio", "damping"}."""
    from .controllers.admittance_controller import AdmittanceController
    from .parameters import ParamListener

    f = Failures()
    for c, got in zip(inputs, outputs, strict=True):
        where = (f"(M={c['mass']:g} kg, push {c['force']:g} N, yield {c['deflection'] * 1e3:.1f} mm within "
                 f"{c['settle']:.2f} s)")
        if "raised" in got:
            f.add(f"raised {got['raised']}: {got['message']} {where}")
            continue
        v = got.get("value")
        try:
            k, zeta, d = (number(v[key]) for key in ("stiffness", "damping_ratio", "damping"))
        except (TypeError, KeyError):
            f.add(f"return a dict with 'stiffness' (N/m), 'damping_ratio' and 'damping' (N s/m); got {got.get('type')}"
                  f" {where}")
            continue
        try:
            ParamListener(AdmittanceController.PARAMS, {  # the controller's own bounds
                "joints": ["j"], "command_interfaces": ["position"], "state_interfaces": ["position"],
                "chainable_command_interfaces": ["position"], "ft_sensor.name": "fts",
                "admittance.mass": [c["mass"]] * 6, "admittance.stiffness": [k] * 6,
                "admittance.damping_ratio": [zeta] * 6})
        except Exception as exc:  # noqa: BLE001 - the schema's message is the feedback
            f.add(f"the AdmittanceController refuses these values: {exc} {where}")
            continue
        if not math.isclose(d, 2 * zeta * math.sqrt(c["mass"] * k), rel_tol=1e-6):
            f.add(f"damping {d:.3f} N s/m does not match damping_ratio {zeta:g}: the controller uses "
                  f"D = 2 zeta sqrt(M K) = {2 * zeta * math.sqrt(c['mass'] * k):.3f} N s/m {where}")
            continue
        if not k > 0:
            f.add(f"stiffness {k:g}: a pure damper (K = 0) never settles at a deflection {where}")
            continue
        t, x = admittance_step(c["mass"], k, d, c["force"], max(3.0, 3 * c["settle"]))
        final = c["force"] / k
        if not math.isclose(final, c["deflection"], rel_tol=0.01):
            f.add(f"at rest the tool yields F / K = {final * 1e3:.2f} mm, not {c['deflection'] * 1e3:.1f} mm {where}: "
                  "K = force / deflection")
            continue
        peak = float(x.max())
        if peak > 1.02 * final:
            f.add(f"it overshoots to {peak * 1e3:.2f} mm ({100 * (peak / final - 1):.0f} % past the rest point) "
                  f"{where}: damping_ratio {zeta:g} < 1 oscillates; 1 is the fastest without overshoot")
            continue
        settled = _settle_time(t, x, final)
        if settled > c["settle"]:
            f.add(f"it takes {settled:.2f} s to settle within 2 % (allowed {c['settle']:.2f} s) {where}: "
                  f"damping_ratio {zeta:g} is more damping than needed; 1 settles fastest without overshoot")
    return f.done(f"{len(inputs)} tunings yield the asked deflection, without overshoot, in time")
