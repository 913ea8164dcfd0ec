"""Graded checks of chapter 4 (ros2_control), the grader's side: inputs, schemas, sub-tests, references.

The student's code runs under the real :class:`~robocourse.control.ControllerManager` with scripted
peers in :mod:`robocourse.control.probes` (the student's side); the judges here run the same
scenario functions on the reference implementations (``MotorBoardSystem``, the controllers below,
the JTC's spline code, the manager itself) and compare, sub-test by sub-test, one per property
the exercise states. The grading sandbox hides this module: the references and expected values
never reach a submission. Nothing is timed: every scenario runs on the manager's simulated clock,
and allocation is measured with tracemalloc (deterministic), so a verdict is the same on a
loaded machine.
"""

from __future__ import annotations

import json
import math
import re
from collections import OrderedDict

import numpy as np

from robocourse.grading import CheckFailed, Failures, SubTest, register
from robocourse.grading.schema import (
    Any,
    Array,
    Bool,
    Call,
    Dict,
    Int,
    List,
    Number,
    OneOf,
    Str,
)

from .hardware.component import SystemInterface
from .hardware.types import CallbackReturn, return_type
from .log import LogSink
from .manager.controller_interface import ControllerInterface, InterfaceConfiguration
from .manager.controller_interface import interface_configuration_type as ict
from .manager.controller_manager import STRICT, ControllerManager
from .motor_board import boards_urdf
from .probes import (
    CTRL_JOINTS,
    LIM_NAME,
    adm_probe,
    board_probe,
    board_scenario,
    controller_probe,
    controller_scenario,
    cubic_probe,
    fault_probe,
    limiter_probe,
    limiter_scenario,
    urdf_probe,
    yaml_probe,
)

# --- shared by the judges -------------------------------------------------------------------------------------------

_REFERENCE_RUNS: OrderedDict = OrderedDict()


def reference_run(key: str, inputs, run):
    """``run(inputs)`` once per (key, inputs): every sub-test of a check compares with the same reference run."""
    k = (key, json.dumps(inputs, sort_keys=True, default=str))
    if k not in _REFERENCE_RUNS:
        _REFERENCE_RUNS[k] = run(inputs)
        while len(_REFERENCE_RUNS) > 16:
            _REFERENCE_RUNS.popitem(last=False)
    return _REFERENCE_RUNS[k]


ROWS = Array((None, None), finite=False)   # per cycle, per joint (NaN where a value was NaN)
ALLOC = OneOf(Dict(sizes=List(Int(lo=1), length=2), peak_bytes=List(Number(), length=2),
                   kept_per_call=Number(finite=False)), Str(max_len=2000), label="an allocation measurement")
MESSAGE = Str(max_len=4000)


def _rows_differ(got, want, tol=1e-9) -> tuple[int, float] | None:
    """(first row index, difference) where two recordings part, or None when they agree."""
    try:
        g, w = np.asarray(got, dtype=float), np.asarray(want, dtype=float)
    except (TypeError, ValueError):
        return (0, math.inf)
    if g.shape != w.shape:
        return (0, math.inf)
    if g.size == 0:
        return None
    d = np.abs(g - w)
    d[np.isnan(d) & ~(np.isnan(g) & np.isnan(w))] = math.inf
    d[np.isnan(g) & np.isnan(w)] = 0.0
    bad = np.nonzero(d.max(axis=-1) > tol)[0] if d.ndim > 1 else np.nonzero(d > tol)[0]
    return None if len(bad) == 0 else (int(bad[0]), float(d[bad[0]].max()))


def _row(rows, k) -> list:
    try:
        return [round(float(v), 6) for v in rows[k]]
    except (TypeError, IndexError, ValueError, KeyError):
        return []


def allocation_verdict(what: str, alloc, bytes_per_joint: int = 8) -> str | None:
    """The feedback for a validated ``ALLOC`` record, or None when the call creates no buffer per cycle."""
    if isinstance(alloc, str):
        return f"{what} could not be measured: {alloc}"
    (n0, n1), (p0, p1), kept = alloc["sizes"], alloc["peak_bytes"], alloc["kept_per_call"]
    if not math.isfinite(kept):
        return f"{what}: the allocation measurement came back malformed"
    if p1 - p0 >= bytes_per_joint * (n1 - n0):
        return (f"{what} allocates a buffer every cycle: its peak memory grows from {p0:.0f} to {p1:.0f} bytes from "
                f"{n0} to {n1} joints (tracemalloc). Make arrays in on_configure and write into them (np.copyto, "
                "out=, np.take(..., out=buf, mode='clip'), a loop); values[idx] and list comprehensions build new ones")
    if kept > 8:
        return (f"{what} keeps {kept:.0f} bytes per call that are never freed (a list or dict growing every "
                "cycle): a real-time loop must run forever in constant memory")
    return None


def _passed(message: str) -> str:
    return message



# --- exercise 8: admittance gains for a given response ------------------------------------------------------------

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


GAINS = Call(Dict(mass=Number(finite=False), stiffness=Number(finite=False), damping_ratio=Number(finite=False),
                  damping=Number(finite=False), label="the gains"))


def _gains(inputs, out):
    """(case, where, (M, K, zeta, D)) per case; a raise or a non-finite value fails the sub-test reading it."""
    for c, got in zip(inputs, out["cases"]):
        where = f"(push {c['force']:g} N, yield {c['deflection'] * 1e3:.0f} mm, settle in {c['settle']:g} s)"
        if "raised" in got:
            raise CheckFailed(f"raised {got['raised']}: {got['message']} {where}")
        v = got["value"]
        gains = (v["mass"], v["stiffness"], v["damping_ratio"], v["damping"])
        if not all(math.isfinite(x) for x in gains):
            raise CheckFailed(f"mass {gains[0]}, stiffness {gains[1]}, damping_ratio {gains[2]}, damping {gains[3]}: "
                              f"every value must be a finite number {where}")
        yield c, where, gains


def _adm_schema_ok(inputs, out):
    from .controllers.admittance_controller import AdmittanceController
    from .parameters import ParamListener

    for _c, where, (m, k, zeta, d) in _gains(inputs, out):
        try:
            ParamListener(AdmittanceController.PARAMS, {  # the controller's own bounds
                "joints": ["j"], "command_interfaces": ["position"], "state_interfaces": ["position"],
                "chainable_command_interfaces": ["position"], "ft_sensor.name": "fts",
                "admittance.mass": [m] * 6, "admittance.stiffness": [k] * 6, "admittance.damping_ratio": [zeta] * 6})
        except Exception as exc:  # noqa: BLE001 - the schema's message is the feedback
            raise CheckFailed(f"the AdmittanceController refuses these values: {exc} {where}") from None
        if not math.isclose(d, 2 * zeta * math.sqrt(m * k), rel_tol=1e-6):
            raise CheckFailed(f"damping {d:.4g} N s/m does not go with damping_ratio {zeta:g}, mass {m:g} kg and "
                              f"stiffness {k:g} N/m as the controller computes it (D = 2 zeta sqrt(M K) = "
                              f"{2 * zeta * math.sqrt(m * k):.4g}) {where}")
    return "values the controller accepts, the damping consistent with them"


def _adm_rest(inputs, out):
    for c, where, (_m, k, _zeta, _d) in _gains(inputs, out):
        if not k > 0:
            raise CheckFailed(f"stiffness {k:g}: without a spring (K = 0) the tool never comes to rest at a deflection "
                              f"{where}")
        rest = c["force"] / k
        if not math.isclose(rest, c["deflection"], rel_tol=0.01):
            raise CheckFailed(f"at rest the spring balances the push: F / K = {rest * 1e3:.2f} mm, not the "
                              f"{c['deflection'] * 1e3:.0f} mm asked {where}")
    return "the tool rests at the asked deflection"


def _adm_overshoot(inputs, out):
    for _c, where, (_m, _k, zeta, _d) in _gains(inputs, out):
        if zeta < 1.0 - 1e-9:
            over = math.exp(-math.pi * max(zeta, 0.0) / math.sqrt(1.0 - min(zeta, 1.0) ** 2))
            raise CheckFailed(f"damping_ratio {zeta:g} < 1 overshoots the rest point by {100 * over:.3g} % {where}: "
                              "'without overshoot' means any overshoot at all")
    return "never overshoots"


def _adm_settle(inputs, out):
    for c, where, (m, k, zeta, _d) in _gains(inputs, out):
        if not (m > 0 and k > 0 and zeta >= 1.0 - 1e-9):
            raise CheckFailed(f"mass {m:g} kg, stiffness {k:g} N/m, damping_ratio {zeta:g}: no settle time to judge "
                              f"(the response must be a positive mass on a spring, damped without overshoot) {where}")
        t_s = settle_time(m, k, 2 * zeta * math.sqrt(m * k))
        if t_s > c["settle"] * (1 + SETTLE_SLACK):
            raise CheckFailed(f"it settles (within {SETTLE_BAND:.0%}) after {t_s:.3f} s, later than the {c['settle']:g} "
                              f"s asked {where}: a heavier virtual mass or more damping than critical is slower")
        if t_s < SETTLE_EARLIEST * c["settle"]:
            raise CheckFailed(f"it settles after {t_s:.3f} s, sooner than {SETTLE_EARLIEST:g} x {c['settle']:g} s "
                              f"{where}: the task asks for the settle time given, not the fastest possible (a light "
                              "virtual mass amplifies sensor noise)")
    return "settles in the asked time"


register("ch04.admittance", uses=("tune_admittance",), probe=adm_probe, inputs=_adm_inputs, time_limit=20,
         schema=Dict(cases=List(GAINS, length=3)),
         subtests=[SubTest("values the controller accepts, damping consistent", 0.5, _adm_schema_ok),
                   SubTest("rests at the asked deflection", 0.5, _adm_rest),
                   SubTest("no overshoot", 0.5, _adm_overshoot),
                   SubTest("settles in the asked time", 0.5, _adm_settle)])


# --- exercise 1: the <ros2_control> element of the RRBot ------------------------------------------------------------

URDF_MAX_CHARS = 20_000
FT_STATES = ["force.x", "force.y", "force.z", "torque.x", "torque.y", "torque.z"]
#: the driver the exercise describes: per joint (command interfaces with (min, max), state interfaces)
RRBOT_SPEC = {"joint1": ({"position": (-1.0, 1.0), "velocity": (-3.0, 3.0)}, ["position", "velocity"]),
              "joint2": ({"velocity": (-3.0, 3.0)}, ["position", "velocity"])}


def _urdf_inputs(rng):
    signs = rng.choice([-1.0, 1.0], 2)          # never 0.0: a missing initial_value must show
    return {"initial_positions": {j: round(float(s * v), 2) for j, s, v in zip(RRBOT_SPEC, signs, rng.uniform(0.1, 0.8, 2))},
            "joint1_target": round(float(rng.uniform(-0.6, 0.6)), 2),
            "joint2_velocity": round(float(rng.uniform(0.2, 0.6)), 2)}


def rrbot_with(element: str) -> str:
    """rrbot.urdf with its ``<ros2_control>`` element replaced by ``element`` (text)."""
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
    try:
        cm = ControllerManager(urdf, params=params, log=log)
    except (ValueError, RuntimeError, KeyError) as exc:
        return {"error": f"the controller manager could not bring it up on mock hardware: {exc}"}
    out = {"start": {k: cm.rm.value(k) for k in ("joint1/position", "joint2/position")
                     if cm.rm.state_interface_exists(k)}}
    ok = all(cm.load_controller(n) is not None and cm.configure_controller(n) == return_type.OK for n in ("j1", "j2"))
    if not ok or cm.switch_controller(["j1", "j2"], [], STRICT) != return_type.OK:
        out["switch"] = (cm.last_switch_message or " | ".join(r.msg for r in log.records[-3:])).replace("\n", " ")
        return out
    cm.controllers["j1"].c.set_command([inputs["joint1_target"]])
    cm.controllers["j2"].c.set_command([inputs["joint2_velocity"]])
    p0 = cm.rm.value("joint2/position")
    cm.spin_for(1.0)
    out["joint1_after"] = cm.rm.value("joint1/position")
    out["joint2_moved"] = cm.rm.value("joint2/position") - p0
    return out


def _urdf_parsed(inputs, out):
    """(HardwareInfo, the whole URDF) of the student's element; CheckFailed when it is not one parsable element."""
    from .hardware.info import URDFError, parse_control_resources_from_urdf

    got = out["element"]
    if "raised" in got:
        raise CheckFailed(f"rrbot_ros2_control raised {got['raised']}: {got['message']}")
    text = got["value"]
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
    if len(infos) != 1:
        raise CheckFailed(f"write exactly one <ros2_control> element; the URDF now has {len(infos)}")
    return infos[0], urdf


def _urdf_loads(inputs, out):
    import mujoco

    _, urdf = _urdf_parsed(inputs, out)
    try:
        model = mujoco.MjModel.from_xml_string(urdf)
    except ValueError as exc:
        raise CheckFailed(f"MuJoCo cannot load the URDF with your element in it: {exc}") from None
    names = [model.joint(i).name for i in range(model.njnt)]
    if names != ["joint1", "joint2"]:
        raise CheckFailed(f"MuJoCo loads the URDF with joints {names}, not the RRBot's [joint1, joint2]")
    return "ros2_control's parser accepts it and MuJoCo loads the URDF"


def _urdf_component(inputs, out):
    hw, _ = _urdf_parsed(inputs, out)
    f = Failures()
    if (hw.name, hw.type, hw.hardware_plugin_name) != ("RRBot", "system", "mock_components/GenericSystem"):
        f.add(f"the component is name={hw.name!r} type={hw.type!r} plugin={hw.hardware_plugin_name!r}; the driver "
              "described is one system named 'RRBot' with plugin mock_components/GenericSystem")
    if hw.hardware_parameters.get("calculate_dynamics", "").strip().lower() != "true":
        f.add(f"hardware parameters {hw.hardware_parameters}: the driver integrates velocity commands "
              "(<param name=\"calculate_dynamics\">true</param> inside <hardware>)")
    return f.done("one system RRBot on mock_components/GenericSystem with calculate_dynamics")


def _urdf_interfaces(inputs, out):
    hw, _ = _urdf_parsed(inputs, out)
    f = Failures()
    joints = {j.name: j for j in hw.joints}
    if list(joints) != list(RRBOT_SPEC):
        f.add(f"<joint> elements {list(joints)}; the RRBot's are {list(RRBOT_SPEC)} (in this order)")
    for jname, (cmds, states) in RRBOT_SPEC.items():
        j = joints.get(jname)
        if j is None:
            continue
        got_c, got_s = [i.name for i in j.command_interfaces], [i.name for i in j.state_interfaces]
        if sorted(got_c) != sorted(cmds) or sorted(got_s) != sorted(states):
            f.add(f"{jname}: command interfaces {got_c}, state interfaces {got_s}; the driver takes "
                  f"{sorted(cmds)} and reports {states}")
    return f.done("each joint's command and state interfaces")


def _urdf_limits(inputs, out):
    hw, _ = _urdf_parsed(inputs, out)
    f = Failures()
    for j in hw.joints:
        for itf in j.command_interfaces:
            want = RRBOT_SPEC.get(j.name, ({}, []))[0].get(itf.name)
            got = (float(itf.min) if _is_number(itf.min) else itf.min, float(itf.max) if _is_number(itf.max) else itf.max)
            if want is not None and got != want:
                f.add(f"{j.name}/{itf.name} limits min={itf.min!r} max={itf.max!r}; expected {want[0]:g} .. {want[1]:g} "
                      "(<param name=\"min\"> / <param name=\"max\"> inside the command_interface)")
    return f.done("the command limits")


def _is_number(text) -> bool:
    try:
        float(text)
        return True
    except (TypeError, ValueError):
        return False


def _urdf_sensor(inputs, out):
    hw, _ = _urdf_parsed(inputs, out)
    sensors = {s.name: s for s in hw.sensors}
    fts = sensors.get("tool_fts")
    if fts is None or len(sensors) != 1:
        raise CheckFailed(f"<sensor> elements {list(sensors)}; the driver has one force/torque sensor named 'tool_fts'")
    f = Failures()
    got = [i.name for i in fts.state_interfaces]
    if got != FT_STATES:
        f.add(f"tool_fts state interfaces {got}; a force/torque sensor reports {FT_STATES}")
    if fts.parameters.get("frame_id") != "tool_link":
        f.add(f"tool_fts parameters {fts.parameters}: the sensor's frame is <param name=\"frame_id\">tool_link</param>")
    return f.done("the force/torque sensor")


def _urdf_run(inputs, out) -> dict:
    _, urdf = _urdf_parsed(inputs, out)
    run = reference_run("urdf", {"urdf": urdf, **inputs}, lambda i: _urdf_runtime(i["urdf"], i))
    if run.get("error"):
        raise CheckFailed(run["error"])
    return run


def _urdf_initial(inputs, out):
    run, init = _urdf_run(inputs, out), inputs["initial_positions"]
    f = Failures()
    for j in RRBOT_SPEC:
        v = run["start"].get(f"{j}/position")
        if v is None or not math.isclose(v, init[j], abs_tol=1e-9):
            f.add(f"on mock hardware {j}/position starts at {v}, not initial_positions[{j!r}] = {init[j]} "
                  "(<param name=\"initial_value\"> in the position state_interface)")
    return f.done("the mock starts at the initial positions")


def _urdf_dynamics(inputs, out):
    run = _urdf_run(inputs, out)
    if run.get("switch"):
        raise CheckFailed("a position controller on joint1 and a velocity controller on joint2 could not be activated: "
                          + run["switch"])
    f = Failures()
    if not math.isclose(run["joint1_after"], inputs["joint1_target"], abs_tol=1e-9):
        f.add(f"joint1 commanded to {inputs['joint1_target']} rad ended at {run['joint1_after']}")
    want, moved = inputs["joint2_velocity"] * 1.0, run["joint2_moved"]
    if not math.isclose(moved, want, rel_tol=0.02):
        f.add(f"joint2 commanded at {inputs['joint2_velocity']} rad/s for 1 s moved {moved:.3f} rad, not {want:.3f}: "
              "with calculate_dynamics the mock integrates the velocity command into position")
    return f.done("joint1 follows a position command, joint2 integrates a velocity command")


register("ch04.ros2_control_urdf", uses=("rrbot_ros2_control",), probe=urdf_probe, inputs=_urdf_inputs,
         time_limit=30, judge_time_limit=60, schema=Dict(element=Call(Any(max_items=10))), max_bytes=100_000,
         subtests=[SubTest("parsed by ros2_control's rules, loaded by MuJoCo", 0.5, _urdf_loads),
                   SubTest("one system RRBot on the mock with calculate_dynamics", 0.5, _urdf_component),
                   SubTest("the joints' command and state interfaces", 0.5, _urdf_interfaces),
                   SubTest("the command limits", 0.5, _urdf_limits),
                   SubTest("the force/torque sensor", 0.25, _urdf_sensor),
                   SubTest("initial values on mock hardware", 0.5, _urdf_initial),
                   SubTest("joint2 integrates its velocity command", 0.25, _urdf_dynamics)])


# --- exercise 2: the motor board's SystemInterface, run under the controller manager --------------------------

def _board_inputs(rng):
    n = int(rng.integers(2, 4))
    return {"positions": rng.uniform(-1.2, 1.2, n).round(3).tolist(),
            "amplitude": rng.uniform(0.1, 0.4, n).round(3).tolist(), "frequency": float(rng.choice([0.5, 1.0])),
            "inactive_s": 0.2, "hold_s": 0.3, "track_s": 0.6, "nan_at": int(rng.integers(5, 15)),
            "moved_by_hand": rng.uniform(-1.2, 1.2, n).round(3).tolist()}


BOARD_SCHEMA = Dict(
    mismatch_state=Str(max_len=200), initial_state=Str(max_len=40), inactive_states=Array((None,), finite=False),
    inactive_targets_received=Int(), activate=Int(), active_state=Str(max_len=40), hold_positions=ROWS, switch=Int(),
    track=Dict(command=ROWS, target=ROWS, state=ROWS, encoder=ROWS, velocity_state=ROWS, velocity=ROWS),
    logs_while_running=List(MESSAGE, max_len=3), logs_while_running_count=Int(lo=0), unplugged_peer=Str(max_len=40),
    unplugged_hardware=Str(max_len=40), exceptions=Int(lo=0), reactivate=Int(),
    recovery_positions=ROWS, nan_exceptions=Int(lo=0),
    reswitch=Int(), recovered_peer=Str(max_len=40), nan_refused=Int(lo=0), nan_peer=Str(max_len=40),
    nan_hardware=Str(max_len=40), exceptions_total=Int(lo=0), alloc_read=ALLOC, alloc_write=ALLOC)


def _board_ref(inputs):
    from .motor_board import MotorBoardSystem

    return reference_run("board", inputs, lambda i: board_scenario(i, MotorBoardSystem))


def _board_started(out) -> None:
    if out["initial_state"] != "inactive":
        raise CheckFailed(f"with hardware_components_initial_state.inactive the component should start 'inactive', it "
                          f"is '{out['initial_state']}': on_init and on_configure must return CallbackReturn.SUCCESS")


def _board_on_init(inputs, out):
    n = len(inputs["positions"])
    if not out["mismatch_state"].startswith("refused"):
        raise CheckFailed(f"a URDF naming {n + 1} joints for a board with {n} motors was initialised (it ended "
                          f"'{out['mismatch_state']}' instead of the manager refusing to start): on_init must compare "
                          "len(info.joints) with board.n and return CallbackReturn.ERROR")
    return "a URDF that does not match the board is refused"


def _board_read(inputs, out):
    _board_started(out)
    ref, f, tr = _board_ref(inputs), Failures(), out["track"]
    if _rows_differ(out["inactive_states"], ref["inactive_states"]) is not None:
        f.add(f"while inactive, the position state interfaces read {_row([out['inactive_states']], 0)}, the encoders "
              f"say {ref['inactive_states']}: read() must copy board.read()'s positions into the state interfaces "
              "(read() runs in INACTIVE too)")
    if out["switch"] == 0:
        if _rows_differ(tr["state"], tr["encoder"], 1e-12) is not None:
            f.add("the position state interfaces did not follow the encoders cycle by cycle: read() must copy "
                  "board.read()'s positions into <joint>/position")
        if _rows_differ(tr["velocity_state"], tr["velocity"], 1e-12) is not None:
            f.add("the velocity state interfaces did not follow the board's velocities: read() fills <joint>/velocity")
    return f.done("read() copies positions and velocities into the state interfaces, inactive and active")


def _board_jump(inputs, out):
    _board_started(out)
    if out["activate"] != 0 or out["active_state"] != "active":
        raise CheckFailed(f"set_hardware_component_state('MotorBoard', 'active') gave {out['activate']} and state "
                          f"'{out['active_state']}': on_activate must return CallbackReturn.SUCCESS when the board answers")
    hold = out["hold_positions"]
    if hold.size == 0 or _rows_differ(hold, _board_ref(inputs)["hold_positions"], 1e-6) is not None:
        moved = float(np.nanmax(np.abs(hold - np.asarray(inputs["positions"])))) if hold.size else math.nan
        raise CheckFailed(f"the activation jump: with no controller running, the motors moved up to {moved:.3f} rad in "
                          f"the {inputs['hold_s']:g} s after activation (from {inputs['positions']}). The URDF's command "
                          "initial_value is 0.0: on_activate must copy the measured positions into the position "
                          "command interfaces")
    return "no jump on activation"


def _board_write(inputs, out):
    _board_started(out)
    if out["switch"] != 0:
        raise CheckFailed("a controller claiming every joint's position could not be activated: export the URDF's "
                          "command and state interfaces (keep the base class's export_*_interfaces or call it)")
    tr = out["track"]
    if tr["target"].size == 0 or _rows_differ(tr["target"], tr["command"], 1e-12) is not None:
        raise CheckFailed("while a controller commanded a sine, the board's targets were not the commands of the same "
                          "cycle: write() must send every joint's position command to board.write() in each cycle")
    return "write() sends each cycle's commands"


def _board_read_error(inputs, out):
    _board_started(out)
    if out["exceptions"] or out["exceptions_total"]:
        raise CheckFailed("read() or write() raised an exception when the board failed: never raise in the loop, "
                          "return return_type.ERROR and let the manager handle it")
    if out["unplugged_peer"] == "active":
        raise CheckFailed("the encoders stopped answering (board.read() returned False) but the controller kept "
                          "running on stale states: read() must return return_type.ERROR when board.read() fails, not "
                          "swallow it and return OK")
    want = _board_ref(inputs)["unplugged_hardware"]
    if out["unplugged_hardware"] != want:
        raise CheckFailed(f"after the read error the hardware is '{out['unplugged_hardware']}', expected '{want}' "
                          "(on_error's default SUCCESS)")
    return "a failed board.read() is returned as ERROR"


def _board_write_error(inputs, out):
    _board_started(out)
    if out["nan_exceptions"]:
        raise CheckFailed("write() raised when the board refused a frame: return return_type.ERROR instead")
    if out["nan_refused"] and out["nan_peer"] == "active":
        raise CheckFailed("the board refused a frame with a NaN (board.write() returned False) but write() returned OK: "
                          "return return_type.ERROR when board.write() fails")
    return "a refused board.write() is returned as ERROR"


def _board_recovery(inputs, out):
    _board_started(out)
    if out["reactivate"] != 0 or out["recovered_peer"] != "active":
        raise CheckFailed(f"after the encoders answered again, bringing the hardware back gave {out['reactivate']} and "
                          f"the controller ended '{out['recovered_peer']}': on_configure/on_activate must work a second "
                          "time")
    at = inputs["moved_by_hand"]
    d = _rows_differ(out["recovery_positions"], [at] * len(out["recovery_positions"]), 1e-9)
    if len(out["recovery_positions"]) == 0 or d is not None:
        raise CheckFailed(f"while the driver was down the arm was moved by hand to {at}; cleaned up, configured and "
                          f"activated again with no controller running, the motors moved (up to "
                          f"{d[1] if d else math.nan:.3f} rad): on_activate must read the board and copy the measured "
                          "positions into the commands every time, not only the first")
    return "after the fault it comes back without a jump"


def _board_no_logging(inputs, out):
    _board_started(out)
    if out["logs_while_running_count"]:
        first = out["logs_while_running"][0] if out["logs_while_running"] else ""
        raise CheckFailed(f"{out['logs_while_running_count']} log lines while the loop ran normally (first: {first!r}): "
                          "read() and write() must not log (real-time rules)")
    return "read() and write() log nothing"


def _board_allocation(inputs, out):
    why = [w for w in (allocation_verdict("read()", out["alloc_read"]), allocation_verdict("write()", out["alloc_write"]))
           if w]
    if why:
        raise CheckFailed(*why)
    return "read() and write() allocate no buffer per cycle"


register("ch04.motor_board", uses=("BoardSystem",), probe=board_probe, inputs=_board_inputs, time_limit=90,
         judge_time_limit=90, schema=BOARD_SCHEMA, references=("robocourse.control.motor_board:MotorBoardSystem",),
         subtests=[SubTest("on_init refuses a URDF that does not match the board", 0.25, _board_on_init,
                           reads=("mismatch_state",)),
                   SubTest("read() fills the state interfaces", 0.5, _board_read),
                   SubTest("no jump on activation", 0.75, _board_jump),
                   SubTest("write() sends each cycle's commands", 0.5, _board_write),
                   SubTest("a failed read returns ERROR", 0.5, _board_read_error),
                   SubTest("a refused write returns ERROR", 0.25, _board_write_error),
                   SubTest("recovery without a jump", 0.5, _board_recovery),
                   SubTest("no logging in read()/write()", 0.25, _board_no_logging),
                   SubTest("no buffer allocated per cycle", 0.5, _board_allocation,
                           reads=("alloc_read", "alloc_write"))])


# --- exercise 7: cubic spline sampling, as the JTC does it -------------------------------------------------------

def _cubic_inputs(rng):
    cases = [{"p0": [0.0], "v0": [0.0], "p1": [1.0], "v1": [0.0], "T": 1.0, "t": [0.0, 0.25, 0.5, 1.0]}]
    for _ in range(8):
        n = int(rng.integers(1, 7))
        T = float(rng.uniform(0.2, 3.0))
        ts = sorted([0.0, T] + rng.uniform(0, T, 5).tolist())
        cases.append({"p0": rng.uniform(-2, 2, n).tolist(), "v0": rng.uniform(-1, 1, n).tolist(),
                      "p1": rng.uniform(-2, 2, n).tolist(), "v1": rng.uniform(-1, 1, n).tolist(), "T": T, "t": ts})
    return cases


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


def _cubic_samples(inputs, out):
    """Yield (case, t, where, (p, v, a) as arrays or None with why) for every sample."""
    for c, got_all in zip(inputs, out["cases"]):
        for t, got in zip(c["t"], got_all):
            where = f"(T={c['T']:.3f} s, t={t:.3f} s, {len(c['p0'])} joints)"
            if "raised" in got:
                yield c, t, where, None, f"raised {got['raised']}: {got['message']}"
                continue
            try:
                values = got["value"]
                if not isinstance(values, list) or len(values) != 3:
                    raise ValueError
                p, v, a = (np.asarray(x, dtype=float).reshape(-1) for x in values)
            except (TypeError, ValueError):
                yield c, t, where, None, (f"return (position, velocity, acceleration), each an array with one value "
                                          f"per joint; got {got.get('type')}")
                continue
            yield c, t, where, (p, v, a), ""


def _cubic_shape(inputs, out):
    for c, _t, where, got, why in _cubic_samples(inputs, out):
        if got is None:
            raise CheckFailed(f"{why} {where}")
        n = len(c["p0"])
        if any(x.size != n for x in got):
            raise CheckFailed(f"one value per joint: got {got[0].size}, {got[1].size}, {got[2].size} values for {n} "
                              f"joints {where}")
    return "an array per quantity, one value per joint"


def _cubic_part(k: int, name: str):
    def judge(inputs, out):
        for c, t, where, got, why in _cubic_samples(inputs, out):
            if got is None:
                raise CheckFailed(f"{why} {where}")
            want = _jtc_cubic(c, t)[k]
            if got[k].shape != want.shape or not np.allclose(got[k], want, rtol=1e-9, atol=1e-9):
                p0, v0, p1, v1 = (np.round(np.asarray(c[q], dtype=float), 5).tolist() for q in ("p0", "v0", "p1", "v1"))
                hint = (f"at t = 0 the segment starts where the first point is: q(0) = p0 = {p0}, q'(0) = v0 = {v0}"
                        if t == 0.0 else
                        f"at t = T the segment must arrive at the second point: q(T) = p1 = {p1}, q'(T) = v1 = {v1}"
                        if t == c["T"] else
                        "inside the segment: the cubic is the one polynomial of degree 3 with q(0) = p0, q'(0) = v0, "
                        "q(T) = p1 and q'(T) = v1; velocity and acceleration are its first and second derivatives")
                raise CheckFailed(f"{name} wrong {where}: {hint}. Expected {name} {np.round(want, 5).tolist()}, got "
                                  f"{np.round(got[k], 5).tolist() if got[k].shape == want.shape else got[k].size}")
        return f"{name}s equal the JTC's"
    return judge


register("ch04.cubic", uses=("cubic_sample",), probe=cubic_probe, inputs=_cubic_inputs, time_limit=20,
         schema=Dict(cases=List(List(Call(Any(max_items=100)), max_len=10), length=9)),
         references=("robocourse.control.controllers.joint_trajectory_controller.trajectory:Trajectory",
                     "robocourse.control.controllers.joint_trajectory_controller.trajectory:_coefficients"),
         subtests=[SubTest("(position, velocity, acceleration), one value per joint", 0.25, _cubic_shape),
                   SubTest("positions", 0.75, _cubic_part(0, "position")),
                   SubTest("velocities", 0.5, _cubic_part(1, "velocity")),
                   SubTest("accelerations", 0.5, _cubic_part(2, "acceleration"))])


# --- exercise 3: a controller-manager parameter file that brings the stack up -------------------------------------

YAML_BOARDS = {"ArmBoard": ["joint1", "joint2"], "WristBoard": ["joint3"]}
YAML_TYPES = {"joint_state_broadcaster": "joint_state_broadcaster/JointStateBroadcaster",
              "arm_controller": "joint_trajectory_controller/JointTrajectoryController",
              "wrist_controller": "position_controllers/JointGroupPositionController"}
TEXT_MAX_CHARS = 20_000


def _yaml_bringup(inputs, out) -> dict:
    """Load the student's parameter file into a manager here, on mock hardware; what came up (cached per text)."""
    got = out["text"]
    if "raised" in got:
        raise CheckFailed(f"controllers_yaml() raised {got['raised']}: {got['message']}")
    text = got["value"]
    if not isinstance(text, str):
        raise CheckFailed(f"controllers_yaml must return the YAML text (a str), got {got.get('type')}")
    if len(text) > TEXT_MAX_CHARS or re.search(r"(^|[\s:\[{,])[&*!]\w", text):
        raise CheckFailed(f"a parameter file of plain YAML under {TEXT_MAX_CHARS} characters, without anchors, aliases "
                          f"or tags (got {len(text)} characters)")
    return reference_run("yaml", text, _yaml_load)


def _yaml_load(text: str) -> dict:
    from . import introspection

    log = LogSink(log_to_stderr=False)
    try:
        cm = ControllerManager(boards_urdf(YAML_BOARDS, plugin="mock_components/GenericSystem"), params=text, log=log)
    except Exception as exc:  # noqa: BLE001 - the message is the feedback
        return {"error": f"{type(exc).__name__}: {exc}"}
    out = {"update_rate": cm.update_rate}
    for name in YAML_TYPES:
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
        out["wrist_claims"] = [loan.name for loan in wrist.c.command_interfaces]
    return out


def _yaml_loaded(inputs, out) -> dict:
    up = _yaml_bringup(inputs, out)
    if up.get("error"):
        raise CheckFailed(f"the controller manager refused the file: {up['error']}")
    return up


def _yaml_rate(inputs, out):
    up = _yaml_loaded(inputs, out)
    if up["update_rate"] != 200:
        raise CheckFailed(f"controller_manager update_rate is {up['update_rate']} Hz; the exercise asks for 200 "
                          "(controller_manager: ros__parameters: update_rate: 200)")
    return "the manager runs at 200 Hz"


def _yaml_controllers(inputs, out):
    up = _yaml_loaded(inputs, out)
    f = Failures()
    for name, typ in YAML_TYPES.items():
        got = up["controllers"].get(name)
        if got is None:
            f.add(f"'{name}' could not be loaded: declare it under controller_manager's ros__parameters as "
                  f"{name}: {{type: {typ}}}")
        elif got["type"] != typ:
            f.add(f"'{name}' has type {got['type']!r}; expected {typ}")
        elif got["state"] != "active":
            f.add(f"'{name}' was loaded but ended '{got['state']}' after spawning")
    if f.messages and up["errors"]:
        f.add("the manager said: " + " | ".join(up["errors"][:3]))
    return f.done("the three controllers load with their types and become active")


def _yaml_arm(inputs, out):
    arm = _yaml_loaded(inputs, out).get("arm")
    if arm is None:
        raise CheckFailed("arm_controller did not come up, so its joints and interfaces cannot be read")
    f = Failures()
    if arm["joints"] != ["joint1", "joint2"]:
        f.add(f"arm_controller joints {arm['joints']}; expected [joint1, joint2] (the ArmBoard's)")
    if arm["command_interfaces"] != ["position"]:
        f.add(f"arm_controller command_interfaces {arm['command_interfaces']}; the boards take [position]")
    if sorted(arm["state_interfaces"]) != ["position", "velocity"]:
        f.add(f"arm_controller state_interfaces {arm['state_interfaces']}; use [position, velocity]")
    return f.done("the JTC on joint1, joint2 commanding position, reading position and velocity")


def _yaml_constraints(inputs, out):
    arm = _yaml_loaded(inputs, out).get("arm")
    if arm is None:
        raise CheckFailed("arm_controller did not come up, so its constraints cannot be read")
    f = Failures()
    if arm["goal_time"] != 1.0:
        f.add(f"constraints.goal_time is {arm['goal_time']}; expected 1.0 s")
    for j, g in arm["goal"].items():
        if g != 0.01:
            f.add(f"constraints.{j}.goal is {g}; expected 0.01 rad")
    return f.done("goal_time 1.0 s and a 0.01 rad goal tolerance per joint")


def _yaml_wrist(inputs, out):
    claims = _yaml_loaded(inputs, out).get("wrist_claims")
    if claims != ["joint3/position"]:
        raise CheckFailed(f"wrist_controller claims {claims}; expected [joint3/position] (its joints: [joint3])")
    return "the forward controller on joint3"


register("ch04.controllers_yaml", uses=("controllers_yaml",), probe=yaml_probe, time_limit=30,
         schema=Dict(text=Call(Any(max_items=10))), max_bytes=100_000,
         subtests=[SubTest("the manager at 200 Hz", 0.25, _yaml_rate),
                   SubTest("the three controllers, their types, active", 0.75, _yaml_controllers),
                   SubTest("the JTC's joints and interfaces", 0.5, _yaml_arm),
                   SubTest("the JTC's constraints", 0.25, _yaml_constraints),
                   SubTest("the wrist controller", 0.25, _yaml_wrist)])


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


FAULT_ANSWER = Call(Dict(deactivated=List(Str(max_len=100), max_len=50), hardware_state=Str(max_len=40)))


def _fault_cases(inputs, out, results):
    for s, got in zip(inputs["scenarios"], out["answers"]):
        if s["result"] not in results:
            continue
        what = f"{s['failed']}'s {s['stage']}() returned {s['result']}"
        if "raised" in got:
            raise CheckFailed(f"{what}: raised {got['raised']}: {got['message']}")
        yield s, what, got["value"], reference_run("fault", s, fault_truth)


def _fault_stopped(results):
    def judge(inputs, out):
        f = Failures()
        for s, what, value, want in _fault_cases(inputs, out, results):
            names = sorted(value["deactivated"])
            if names == want["deactivated"]:
                continue
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
        return f.done("the controllers that stop, as the manager stops them")
    return judge


def _fault_state(inputs, out):
    f = Failures()
    for s, what, value, want in _fault_cases(inputs, out, ("ERROR", "DEACTIVATE")):
        if value["hardware_state"].lower() != want["hardware_state"]:
            f.add(f"{what}: the component ends '{want['hardware_state']}', not {value['hardware_state']!r}"
                  + (" (ERROR runs on_error; its default SUCCESS leaves it unconfigured)" if s["result"] == "ERROR"
                     else " (DEACTIVATE makes it inactive: read() continues)"))
    return f.done("the component's state afterwards")


register("ch04.read_error", uses=("after_hardware_error",), probe=fault_probe, inputs=_fault_inputs, time_limit=20,
         schema=Dict(answers=List(FAULT_ANSWER, length=lambda inputs: len(inputs["scenarios"]))),
         references=("robocourse.control.manager.controller_manager:ControllerManager",),
         subtests=[SubTest("a read/write ERROR stops the users of its command or state interfaces", 0.75,
                           _fault_stopped(("ERROR",))),
                   SubTest("DEACTIVATE stops only the users of its command interfaces", 0.75,
                           _fault_stopped(("DEACTIVATE",))),
                   SubTest("the component's state afterwards", 0.5, _fault_state)])


# --- exercise 5: a controller of your own (ControllerInterface) ------------------------------------------------------

def _ctrl_inputs(rng):
    initial = {j: round(float(v), 3) for j, v in zip(CTRL_JOINTS, rng.uniform(-1.0, 1.0, len(CTRL_JOINTS)))}
    k = int(rng.integers(2, 4))
    joints = [CTRL_JOINTS[i] for i in rng.permutation(len(CTRL_JOINTS))[:k]]
    if joints == sorted(joints):        # never in sorted order: the claims must follow the parameter's order
        joints.reverse()
    start = np.array([initial[j] for j in joints])
    return {"initial": initial, "joints": joints, "max_velocity": round(float(rng.uniform(0.3, 1.0)), 2),
            "target1": (start + rng.choice([-1, 1], k) * rng.uniform(0.2, 0.6, k)).round(3).tolist(),
            "target2": (start + rng.uniform(-0.3, 0.3, k)).round(3).tolist(),
            "moved": (start + rng.uniform(-0.5, 0.5, k)).round(3).tolist(),
            "slow_rate": int(rng.choice([20, 25, 50]))}


class _ReferenceSlew(ControllerInterface):
    """The judge's reference for exercise 5 (what the solution notebook asks students to write)."""

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


NAMES = List(Str(max_len=200), max_len=64)
CTRL_SCHEMA = Dict(optional={
    "load": MESSAGE, "switch": Int(), "switch_message": MESSAGE, "claimed_commands": NAMES, "claimed_states": NAMES,
    "errors": List(MESSAGE, max_len=20), "switch_alone": Int(), "switch_alone_message": MESSAGE, "hold": ROWS,
    "hold_commands": ROWS, "track": ROWS, "bad_input": ROWS, "bad_input_control": ROWS,
    "state_after_bad_input": Str(max_len=40),
    "reswitch": Int(), "reactivated": ROWS, "slow_load": MESSAGE, "slow_start": Array((None,), finite=False),
    "slow": ROWS, "alloc": ALLOC})


def _ctrl_ref(inputs):
    return reference_run("controller", inputs, lambda i: controller_scenario(i, _ReferenceSlew))


def _ctrl_up(out) -> None:
    if out.get("load"):
        raise CheckFailed(f"the controller did not come up: {out['load']}")
    if out.get("switch") != 0 and out.get("switch_alone") != 0:
        raise CheckFailed("it could not be activated: " + (out.get("switch_alone_message") or out.get("switch_message")
                                                            or "").replace("\n", " "))


def _ctrl_claims(inputs, out):
    _ctrl_up(out)
    ref, f = _ctrl_ref(inputs), Failures()
    if out.get("claimed_commands") != ref["claimed_commands"] or out.get("claimed_states") != ref["claimed_states"]:
        f.add(f"with joints {inputs['joints']} it claimed command interfaces {out.get('claimed_commands')} and state "
              f"interfaces {out.get('claimed_states')}; expected {ref['claimed_commands']} and {ref['claimed_states']}, "
              "in the order of the 'joints' parameter (INDIVIDUAL, '<joint>/position')")
    if out.get("switch") != 0:
        f.add("it could not be activated next to a controller on the other joints (alone it activated: it claims "
              "interfaces it does not need, e.g. ALL): " + (out.get("switch_message") or "").replace("\n", " "))
    return f.done("its joints' position interfaces, in order, beside another controller")


def _ctrl_jump(inputs, out):
    _ctrl_up(out)
    start = [inputs["initial"][j] for j in inputs["joints"]]
    hold = out.get("hold")
    if hold is None or _rows_differ(hold, [start] * len(_ctrl_ref(inputs)["hold"])) is not None:
        moved = float(np.nanmax(np.abs(hold - start))) if hold is not None and hold.size else math.nan
        raise CheckFailed(f"the activation jump: activated with no target, the joints moved up to {moved:.3f} rad from "
                          f"{start}. on_activate must copy each joint's measured position (state interface) into the "
                          "command it writes")
    return "no jump on activation"


def slew_break(rows, start, target, step, updates=None):
    """Where the answer's own commands break ``cmd_k = prev + clip(target - prev, -step, step)`` (``prev``: its own
    previous command, ``start`` before the first row; with ``updates``, rows off an update cycle keep ``prev``):
    (index, got, expected) of the first break, or None."""
    rows = np.asarray(rows, dtype=float)
    prev, target = np.asarray(start, dtype=float), np.asarray(target, dtype=float)
    for k, row in enumerate(rows):
        moving = updates is None or k in updates
        expected = prev + np.clip(target - prev, -step, step) if moving else prev
        if row.shape != expected.shape or not np.all(np.abs(row - expected) <= 1e-9):
            return k, row, expected
        prev = row
    return None


def _start_of(commands, positions):
    """Where the controller's commands stood: its own last command where written (finite), else the position."""
    c, p = np.asarray(commands, dtype=float), np.asarray(positions, dtype=float)
    return np.where(np.isfinite(c), c, p)


def _ctrl_slew(inputs, out):
    _ctrl_up(out)
    rows, hold = out.get("track"), out.get("hold")
    if rows is None or hold is None or len(rows) == 0:
        raise CheckFailed("the controller did not run long enough to follow a target")
    step = inputs["max_velocity"] * 0.01
    broke = slew_break(rows, _start_of(out["hold_commands"][-1], hold[-1]), inputs["target1"], step)
    if broke is not None:
        k, got, want = broke
        raise CheckFailed(f"each update moves every command toward the newest target by at most max_velocity * period "
                          f"({inputs['max_velocity']:g} rad/s x 0.01 s) and stops on it. Target {inputs['target1']}, "
                          f"cycle {k + 1}: commands {_row([got], 0)}, expected {_row([want], 0)} from the previous "
                          "command")
    if _rows_differ(rows[-1:], [inputs["target1"]]) is not None:
        raise CheckFailed(f"after {len(rows) / 100:g} s the commands are {_row(rows, -1)}, not on the target "
                          f"{inputs['target1']} they slew toward (each joint's command goes to its own target)")
    return f"slews toward the newest target at {inputs['max_velocity']:g} rad/s"


def _ctrl_bad_input(inputs, out):
    _ctrl_up(out)
    rows, track = out.get("bad_input"), out.get("track")
    if rows is None or track is None or len(track) == 0:
        raise CheckFailed("the controller did not run long enough to be sent bad messages")
    control = out.get("bad_input_control")
    d = _rows_differ(rows, control) if control is not None else (0, math.inf)
    if d is not None or not np.isfinite(np.asarray(rows, dtype=float)).all() \
            or out.get("state_after_bad_input") != "active":
        k = d[0] if d else 0
        raise CheckFailed(f"a message with a NaN, or with {len(inputs['joints']) + 1} values, must be ignored: the "
                          f"controller keeps its last valid target {inputs['target2']} and stays active (it is "
                          f"'{out.get('state_after_bad_input')}'). Cycle {k + 1} after the new target: commands "
                          f"{_row(rows, k)}, while the same controller sent no bad message commanded "
                          f"{_row(control, k) if control is not None else 'nothing (it did not come up)'}")
    return "NaN and wrong-size messages ignored"


def _ctrl_reactivation(inputs, out):
    _ctrl_up(out)
    rows = out.get("reactivated")
    if out.get("reswitch") != 0 or rows is None or _rows_differ(rows, [inputs["moved"]] * len(rows)) is not None:
        raise CheckFailed("copy the measured positions in on_activate every time, not once in on_configure: "
                          f"deactivated, moved to {inputs['moved']} by another controller and activated again, it drove "
                          f"the joints to {_row(rows, -1) if rows is not None else 'nowhere'} instead of holding there")
    return "starts from the measured positions at every activation"


def _ctrl_period(inputs, out):
    _ctrl_up(out)
    if out.get("slow_load"):
        raise CheckFailed(f"with update_rate: {inputs['slow_rate']} the controller did not come up: {out['slow_load']}")
    rows, ref = out.get("slow"), _ctrl_ref(inputs)["slow"]
    if rows is None:
        raise CheckFailed(f"with update_rate: {inputs['slow_rate']} the controller could not be activated")
    step = inputs["max_velocity"] / inputs["slow_rate"]
    rows = np.asarray(rows, dtype=float)
    moves = np.abs(np.diff(rows, axis=0))      # from its first update on: where it started is the activation's business
    if not (moves > 1e-12).any():
        raise CheckFailed(f"with update_rate: {inputs['slow_rate']} and a target {inputs['target1']} the commands "
                          f"never moved after the first update: {_row(rows, 0)}")
    for j, name in enumerate(inputs["joints"]):
        steps = moves[:, j][moves[:, j] > 1e-12]
        # a slew at max_velocity: every step the same, period x max_velocity, but the last one (which lands)
        if len(steps) and (np.any(np.abs(steps[:-1] - step) > 1e-9) or steps[-1] > step + 1e-9):
            raise CheckFailed(f"Use the period argument, not a fixed step: with update_rate: {inputs['slow_rate']} under "
                              f"a 100 Hz manager, update() runs every {100 // inputs['slow_rate']} cycles with period "
                              f"{1 / inputs['slow_rate']:g} s, so {name} moves {step:.4g} rad per update; it moved "
                              f"{np.round(steps[:4], 5).tolist()} rad in its first updates")
    # the rate, judged on the answer's own rows: cycles in which its commands changed lie as far apart as the
    # reference's (counting them instead charged a controller that started elsewhere for its longer slew)
    def tightest_gap(r):
        changed = np.nonzero(np.abs(np.diff(np.asarray(r, dtype=float), axis=0)).max(axis=1) > 1e-12)[0]
        return int(np.diff(changed).min()) if len(changed) > 1 else None

    gap, ref_gap = tightest_gap(rows), tightest_gap(ref)
    if gap is not None and ref_gap is not None and gap < ref_gap:
        raise CheckFailed(f"with update_rate: {inputs['slow_rate']} the commands changed {gap} cycles apart: update() "
                          f"runs every {100 // inputs['slow_rate']} cycles of a 100 Hz manager, so they change at most "
                          "once per update")
    return "uses the period it is given"


def _ctrl_allocation(inputs, out):
    why = allocation_verdict("update()", out.get("alloc", "not measured: the controller did not come up"))
    if why:
        raise CheckFailed(why)
    return "update() allocates no buffer"


register("ch04.controller", uses=("SlewRateController",), probe=controller_probe, inputs=_ctrl_inputs,
         time_limit=90, judge_time_limit=90, schema=CTRL_SCHEMA, references=("robocourse.control.checks:_ReferenceSlew",),
         subtests=[SubTest("claims its joints' position interfaces, in order, beside another controller", 0.75,
                           _ctrl_claims),
                   SubTest("no jump on activation", 0.5, _ctrl_jump),
                   SubTest("slews toward the newest target at max_velocity", 0.75, _ctrl_slew),
                   SubTest("ignores NaN and wrong-size messages", 0.5, _ctrl_bad_input),
                   SubTest("copies the state at every activation", 0.5, _ctrl_reactivation),
                   SubTest("uses the period it is given", 0.5, _ctrl_period),
                   SubTest("update() allocates no buffer", 0.5, _ctrl_allocation)])


# --- exercise 6: a chainable controller after the JTC (a joint limiter) --------------------------------------------

def _lim_inputs(rng):
    n = int(rng.integers(2, 4))
    joints = [f"joint{i + 1}" for i in range(n)]
    lo, hi = (-rng.uniform(0.3, 0.8, n)).round(3), rng.uniform(0.3, 0.8, n).round(3)
    initial = (rng.uniform(0.2, 0.6, n) * np.where(rng.random(n) < 0.5, lo, hi)).round(3)
    rate = int(rng.choice([200, 250]))      # never 100 Hz: a limiter stepping 0.01 s must show
    vmax = round(float(rng.uniform(0.4, 1.0)), 2)
    beyond = (hi + rng.uniform(0.1, 0.4, n)).round(3)                 # every joint asked past its upper limit
    # A: hold (the limiter is transparent); B: joint 1 past its limit, long enough to ramp up to the limit and
    # rest on it; C: NaN on the last joint (it holds); D: a slow wave inside the limits
    ramp_s = (hi[0] - initial[0]) / vmax + 0.3
    phases = [10, int(np.ceil(ramp_s * rate)), 8, int(rate * 0.8)]
    script = [initial.tolist()] * phases[0]
    script += [np.where(np.arange(n) == 0, beyond, initial).tolist()] * phases[1]
    script += [np.where(np.arange(n) == n - 1, np.nan, beyond).tolist()] * phases[2]
    t = np.arange(phases[3]) / rate
    wave = 0.5 * np.outer(np.sin(2 * np.pi * 0.5 * t), (hi - lo) / 2 * 0.5) + (lo + hi) / 2
    script += wave.round(6).tolist()
    jtc_goal = np.where(np.arange(n) % 2 == 0, beyond, lo + (hi - lo) * 0.3).round(3)
    # the JTC's run lasts until the limiter, at max_velocity, has reached every clamped goal and rested there
    jtc_s = float(np.max(np.abs(np.clip(jtc_goal, lo, hi) - initial))) / vmax + 0.3
    return {"joints": joints, "min": lo.tolist(), "max": hi.tolist(), "initial": initial.tolist(), "rate": rate,
            "max_velocity": vmax, "script": script, "phases": phases, "jtc_goal": jtc_goal.tolist(),
            "jtc_cycles": int(np.ceil(max(jtc_s, 0.6) * rate))}


def _reference_limiter():
    """The judge's reference for exercise 6 (built lazily: the chainable base lives in the manager package)."""
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


SWITCH = List(OneOf(Int(), MESSAGE), length=2)
LIM_SCHEMA = Dict(optional={
    "load": MESSAGE, "chainable": Bool(), "exported": NAMES, "jtc_loaded": Bool(), "jtc_alone": SWITCH,
    "limiter_alone": SWITCH, "errors": List(MESSAGE, max_len=20), "hold": ROWS, "chained_alone": Bool(),
    "jtc_after": SWITCH, "order": NAMES, "chained_with_jtc": Bool(), "limiter_under_jtc": SWITCH, "jtc_run": ROWS,
    "jtc_refs": ROWS, "jtc_start": Array((None,), finite=False),
    "jtc_off": SWITCH, "chained_after_jtc": Bool(), "after_jtc": ROWS, "state": Str(max_len=40),
    "scripted_load": MESSAGE, "writer_switch": SWITCH, "scripted": ROWS, "alloc": ALLOC})


def _lim_ref(inputs):
    return reference_run("limiter", inputs, lambda i: limiter_scenario(i, _reference_limiter()))


def _lim_up(out) -> None:
    if out.get("load"):
        raise CheckFailed(f"the limiter did not come up: {out['load']}")


def _lim_exports(inputs, out):
    _lim_up(out)
    refs = [f"{LIM_NAME}/{j}/position" for j in inputs["joints"]]
    if not out.get("chainable"):
        raise CheckFailed("is_chainable() is False: derive the limiter from ChainableControllerInterface")
    if out.get("exported") != refs:
        raise CheckFailed("reference interfaces: on_export_reference_interfaces returns '<joint>/position' for each "
                          f"joint, in order (the manager adds the controller's name); the JTC needs {refs}, got "
                          f"{out.get('exported')}")
    return "exports <joint>/position reference interfaces"


def _lim_rules(inputs, out):
    _lim_up(out)
    ref, f = _lim_ref(inputs), Failures()
    if (out.get("jtc_alone") or [0])[0] == 0:
        f.add("the JTC was activated while the limiter it writes into was inactive (its reference interfaces must "
              "exist, and be unavailable until the limiter is active)")
    if (out.get("limiter_alone") or [1])[0] != 0:
        f.add(f"the limiter alone could not be activated: {(out.get('limiter_alone') or ['', ''])[1]}")
    if (out.get("jtc_after") or [1])[0] != 0:
        f.add(f"with the limiter active the JTC could not be activated: {(out.get('jtc_after') or ['', ''])[1]}")
    elif out.get("order") != ref["order"] or not out.get("chained_with_jtc"):
        f.add(f"the manager's update order is {out.get('order')} and the limiter's chained mode "
              f"{out.get('chained_with_jtc')}; expected {ref['order']} and True (on_set_chained_mode must accept)")
    if (out.get("limiter_under_jtc") or [0])[0] == 0:
        f.add("the limiter was deactivated while the JTC still wrote into it")
    if out.get("chained_after_jtc") not in (False, None):
        f.add("after the JTC was deactivated the limiter still says it is in chained mode")
    return f.done("the chain's activation rules hold: limiter first, JTC updated first, no deactivation under it")


def _lim_jump(inputs, out):
    _lim_up(out)
    hold = out.get("hold")
    if hold is None or _rows_differ(hold, [inputs["initial"]] * len(_lim_ref(inputs)["hold"])) is not None:
        raise CheckFailed(f"activated before any reference was written, the joints moved from {inputs['initial']} to "
                          f"{_row(hold, -1) if hold is not None else 'nowhere (it did not activate)'}: on_activate must "
                          "start the command (and the reference interfaces) at the measured positions; the reference "
                          "interfaces start as NaN")
    return "no jump on activation"


def limit_break(rows, start, refs, lo, hi, step):
    """Where the answer's own commands break the limiter's rule, reference by reference: a NaN reference keeps the
    previous command, else ``prev + clip(clip(ref, lo, hi) - prev, -step, step)``; (index, got, expected) or None."""
    prev, lo, hi = np.asarray(start, dtype=float), np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
    for k, (row, ref) in enumerate(zip(np.asarray(rows, dtype=float), np.asarray(refs, dtype=float))):
        goal = np.where(np.isnan(ref), prev, np.clip(ref, lo, hi))
        expected = prev + np.clip(goal - prev, -step, step)
        if row.shape != expected.shape or not np.all(np.abs(row - expected) <= 1e-9):
            return k, row, expected
        prev = row
    return None


def _lim_behind_jtc(inputs, out):
    _lim_up(out)
    rows, refs, start = out.get("jtc_run"), out.get("jtc_refs"), out.get("jtc_start")
    if rows is None or refs is None or start is None:
        raise CheckFailed("the JTC could not be chained in front of the limiter, so its trajectory could not be limited")
    broke = limit_break(rows, _start_of(start, out["hold"][-1]), refs, inputs["min"], inputs["max"],
                        inputs["max_velocity"] / inputs["rate"])
    if broke is not None:
        k, got, want = broke
        raise CheckFailed(f"behind the JTC: clamp each reference to [min_position, max_position], then move the command "
                          f"toward it by at most max_velocity * period ({inputs['max_velocity']:g} rad/s at "
                          f"{inputs['rate']} Hz). Cycle {k + 1}, the JTC's reference {_row(refs, k)}: commands "
                          f"{_row([got], 0)}, expected {_row([want], 0)} from the previous command")
    return "limits the JTC's trajectory"


def _lim_phase(what: str, phase: int):
    def judge(inputs, out):
        _lim_up(out)
        script, refs = out.get("scripted"), np.asarray(inputs["script"], dtype=float)
        if script is None:
            raise CheckFailed(f"the scripted preceding controller could not chain to the limiter: "
                              f"{out.get('writer_switch') or out.get('scripted_load')}")
        edges = np.cumsum([0] + list(inputs["phases"]))
        a, b = int(edges[phase]), int(edges[phase + 1])
        start = inputs["initial"] if a == 0 else script[a - 1]       # its own command before the phase
        if phase == 2:      # the NaN joint only: the others are the ramp's business
            last = np.asarray(script[a:b], dtype=float)[:, -1]
            held = np.isfinite(last) & (np.abs(last - start[-1]) <= 1e-12)
            broke = None if held.all() else (int(np.argmin(held)), script[a + int(np.argmin(held))],
                                             np.r_[script[a + int(np.argmin(held))][:-1], start[-1]])
        else:
            broke = limit_break(script[a:b], start, refs[a:b], inputs["min"], inputs["max"],
                                inputs["max_velocity"] / inputs["rate"])
        if broke is not None:
            k = a + broke[0]
            raise CheckFailed(f"{what}: script step {k + 1}, reference {_row(refs, k)}, limits {inputs['min']}.."
                              f"{inputs['max']}: commands {_row([broke[1]], 0)}, expected {_row([broke[2]], 0)}")
        return what
    return judge


def _lim_allocation(inputs, out):
    why = allocation_verdict("update()", out.get("alloc", "not measured: the limiter did not come up"))
    if why:
        raise CheckFailed(why)
    return "update() allocates no buffer"


register("ch04.chainable", uses=("JointLimiter",), probe=limiter_probe, inputs=_lim_inputs, time_limit=120,
         judge_time_limit=120, schema=LIM_SCHEMA, max_bytes=1_000_000,
         subtests=[SubTest("exports <joint>/position reference interfaces", 0.5, _lim_exports),
                   SubTest("the chain's activation rules hold", 0.75, _lim_rules),
                   SubTest("no jump on activation", 0.5, _lim_jump),
                   SubTest("limits a JTC's trajectory", 0.5, _lim_behind_jtc),
                   SubTest("transparent inside the limits", 0.25,
                           _lim_phase("transparent while the reference is inside the limits", 0)),
                   SubTest("past a limit: ramps at max_velocity, stops at the limit", 0.5,
                           _lim_phase("past the upper limit: ramp at max_velocity, then stop at max_position", 1)),
                   SubTest("a NaN reference holds the joint", 0.5,
                           _lim_phase("a NaN reference: that joint holds its last command", 2)),
                   SubTest("update() allocates no buffer", 0.5, _lim_allocation)])
