"""Chapter 6's answer bank: plausible wrong answers (one per stated property) and correct ones.

Every answer runs in the student's place in the grading sandbox; the reference is the solution
notebook's cell (robocourse.grading.bank). The deployment loop runs on the wall clock against the
scripted arm (``timing=True``: CI repeats it under chapter 1's CPU load); its answers use exercise
3's ``MiniBridge``, so that exercise's reference cell is part of the setup here.
"""

from pathlib import Path

from robocourse.grading.bank import Answer, Exercise, notebook_parts

NB = "06_policy_deployment_exercises"
_SOLUTIONS = Path(__file__).resolve().parents[2] / "solutions"
_SETUP, _BRIDGE = notebook_parts(_SOLUTIONS, NB, ("MiniBridge",))

FOLD = Exercise(
    "ch06.fold_normalizer", NB,
    right=[Answer("a loop over the columns", code='''
def fold_normalizer(W, b, mean, std, eps):
    W = np.array(W, dtype=float)
    folded = np.empty_like(W)
    for j in range(W.shape[1]):
        folded[:, j] = W[:, j] / (std[j] + eps)
    return folded, np.array(b, dtype=float) - folded.dot(mean)
''')],
    wrong=[
        Answer("forgets the bias", replace=[("b_folded = np.asarray(b, dtype=float) - W_folded @ np.asarray(mean, dtype=float)",
                                             "b_folded = np.asarray(b, dtype=float)")],
               score=1.0, property="the mean moves into the bias", says="b - W' @ mean"),
        Answer("adds the mean", replace=[("np.asarray(b, dtype=float) - W_folded @", "np.asarray(b, dtype=float) + W_folded @")],
               score=1.0, property="b' = b - W' mean (the sign)", says="b - W' @ mean"),
        Answer("divides by std without eps", replace=[("(np.asarray(std, dtype=float) + eps)", "np.asarray(std, dtype=float)")],
               score=0.0, property="the scale is std + eps", says="std[j] + eps"),
        Answer("multiplies by the scale", replace=[("W_folded = np.asarray(W, dtype=float) / (", "W_folded = np.asarray(W, dtype=float) * (")],
               score=0.0, property="divide each column by its scale", says="divide each column"),
        Answer("calls the library's fold_normalizer", code='''
from robocourse.rl.export import fold_normalizer
''', property="written by the student"),
    ])

EMA = Exercise(
    "ch06.ema_clip", NB,
    right=[Answer("per joint, in a loop", code='''
def ema_clip(action, y_prev, default, scale, alpha, lower, upper):
    y, target, n = [], [], 0
    for a, yp, d, lo, hi in zip(action, y_prev, default, lower, upper):
        v = alpha * yp + (1 - alpha) * (d + scale * a)
        t = min(max(v, lo), hi)
        n += t != v
        y.append(v)
        target.append(t)
    return np.array(y), np.array(target), int(n)
''')],
    wrong=[
        Answer("alpha weighs the new value", replace=[("y = alpha * np.asarray(y_prev, dtype=float) + (1.0 - alpha) * x",
                                                       "y = (1.0 - alpha) * np.asarray(y_prev, dtype=float) + alpha * x")],
               score=1.0, property="alpha weighs the previous value", says="alpha weighs the previous value"),
        Answer("keeps the clipped value as the state", replace=[("return y, target, int(np.count_nonzero(target != y))",
                                                                 "return target, target, int(np.count_nonzero(target != y))")],
               score={"target: y clipped to [lower, upper] per joint": 0.5},
               property="the state is the unclipped filtered value", says="filter the unclipped value"),
        Answer("clips before filtering", replace=[("x = np.asarray(default, dtype=float) + scale * np.asarray(action, dtype=float)",
                                                   "x = np.clip(np.asarray(default, dtype=float) + scale * np.asarray(action, dtype=float), lower, upper)")],
               score=1.0, property="filter first, clip only the target", says="clip only the target"),
        Answer("counts the joints not clipped", replace=[("int(np.count_nonzero(target != y))",
                                                          "int(np.count_nonzero(target == y))")],
               score=1.5, property="n_clipped counts this call's clipped joints", says="n_clipped"),
    ])

BRIDGE = Exercise(
    "ch06.bridge_timeout", NB,
    right=[Answer("a mode string and a counter", code='''
class MiniBridge:
    def __init__(self, n, timeout):
        self.n, self.timeout = n, timeout
        self.mode, self.latest, self.t_latest, self.count, self.count_at_hold, self.hold_q = "hold", None, None, 0, 0, None

    def submit(self, targets, now):
        if np.size(targets) != self.n:
            return False
        self.latest, self.t_latest = np.array(targets, dtype=float).reshape(-1), now
        self.count += 1
        return True

    def update(self, now, q):
        fresh = self.t_latest is not None and now - self.t_latest <= self.timeout
        if self.mode == "run" and not fresh:
            self.mode, self.hold_q, self.count_at_hold = "hold", np.array(q, dtype=float), self.count
        elif self.mode == "hold" and self.hold_q is None:
            self.hold_q, self.count_at_hold = np.array(q, dtype=float), self.count
            if fresh:
                self.mode = "run"
        elif self.mode == "hold" and fresh and self.count > self.count_at_hold:
            self.mode = "run"
        return (self.mode, self.latest if self.mode == "run" else self.hold_q)
''')],
    wrong=[
        Answer("no dimension check", replace=[("        if len(values) != self.n:\n            return False\n", "")],
               score={"no target yet, or none for longer than timeout: hold the position measured then": 1.0,
                      "back to 'run' on a target submitted after the hold began": 0.5},
               property="a target of the wrong size is refused", says="the previous one stays"),
        Answer("never times out", replace=[("        elif not self.holding and not recent:",
                                            "        elif not self.holding and self.received is None:")],
               score=2.0, property="no target for longer than timeout: hold", says="safe mode"),
        Answer("holds the last target", replace=[("            self.held = np.asarray(q, dtype=float).copy()",
                                                   "            self.held = np.asarray(q, dtype=float).copy() if self.target is None else self.target.copy()")],
               score=2.0, property="hold the position measured when the timeout fired", says="safe mode"),
        Answer("holds the newest measured position", replace=[('return ("hold", self.held) if self.holding else ("run", self.target)',
                                                               'return ("hold", np.asarray(q, dtype=float)) if self.holding else ("run", self.target)')],
               score=2.0, property="the same q until a fresh target", says="the same q until a fresh target"),
        Answer("never leaves the safe mode", replace=[("            self.holding = False            # a target that arrived after the timeout fired",
                                                       "            pass")],
               score=0.75, property="a fresh target ends the safe mode (it starts in it: no target yet)",
               says="ends it"),
    ])

OBSERVATION = Exercise(
    "ch06.observation", NB,
    right=[Answer("a dict of positions and velocities", code='''
def reach_observation(joint_state, joint_order, target, last_action, default_pose, tcp_default, dof_vel_scale):
    pos = dict(zip(joint_state.name, joint_state.position))
    vel = dict(zip(joint_state.name, joint_state.velocity))
    q = np.array([pos[j] for j in joint_order]) - default_pose
    dq = np.array([vel[j] for j in joint_order]) * dof_vel_scale
    return np.hstack([q, dq, np.subtract(target, tcp_default), last_action])
''')],
    wrong=[
        Answer("reads /joint_states in its own order", replace=[("idx = [where[j] for j in joint_order]",
                                                                 "idx = list(range(len(joint_order)))")],
               score=1.0, property="each joint looked up by name", says="found by name"),
        Answer("forgets dof_vel_scale", replace=[("dq * dof_vel_scale", "dq")], score=1.5,
               property="dq * dof_vel_scale", says="scaled"),
        Answer("the target in the world frame", replace=[("np.asarray(target, dtype=float) - tcp_default",
                                                          "np.asarray(target, dtype=float)")],
               score=1.5, property="the target relative to the default TCP", says="relative to the default TCP"),
        Answer("velocities first", replace=[("return np.concatenate([q - np.asarray(default_pose, dtype=float), dq * dof_vel_scale,",
                                             "return np.concatenate([dq * dof_vel_scale, q - np.asarray(default_pose, dtype=float),")],
               score=1.0, property="the blocks in the training order", says="entries 0..5 should be q - default_pose"),
        Answer("zeros for the last action", replace=[("np.asarray(last_action, dtype=float)])", "np.zeros(6)])")],
               score=1.5, property="the last action", says="the previous action"),
    ])

_PROCESS = '''
def deploy(robot, spec):
    import numpy as np

    from robocourse.bus.zenoh.processes import start_child
    from robocourse.rl.handover import SharedLatestValue

    def policy_process(duration, spec, state_spec, target_spec):
        # paced by its own clock at rate / decimation, not by the ticks
        import time

        import numpy as np

        from robocourse.rl import load_runtime
        from robocourse.rl.handover import SharedLatestValue

        net = load_runtime(**spec["policy"])
        state, out = SharedLatestValue.attach(state_spec), SharedLatestValue.attach(target_spec)
        pj = spec["policy_joints"]
        order = np.array([pj.index(j) for j in spec["command_joints"]])
        d0, rel = np.asarray(spec["default_pose"]), np.asarray(spec["target"]) - np.asarray(spec["tcp_default"])
        period = spec["decimation"] / spec["rate_hz"]
        prev, nxt = np.zeros(len(pj)), time.monotonic()
        while time.monotonic() < nxt + duration:
            nxt += period
            values, seq, stamp = state.read()
            if seq:
                n = len(pj)
                prev = np.clip(net(np.r_[values[:n] - d0, spec["dof_vel_scale"] * values[n:], rel, prev]), -1, 1)
                out.write((d0 + spec["action_scale"] * prev)[order], stamp)
            time.sleep(max(0.0, nxt - time.monotonic()))

    class Cerebellum:
        def __init__(self, timeout):
            self.timeout, self.latest, self.t_latest, self.fresh, self.hold = timeout, None, None, False, None

        def command(self, now, q_cmd, new_target):
            if new_target is not None:
                self.latest, self.t_latest, self.fresh = new_target.copy(), now, True
            stale = self.t_latest is None or now - self.t_latest > self.timeout
            if self.hold is None and stale:
                self.hold, self.fresh = q_cmd.copy(), False
            elif self.hold is not None and self.fresh and not stale:
                self.hold = None
            return self.hold if self.hold is not None else self.latest

    pj, cj = spec["policy_joints"], spec["command_joints"]
    shared_state, shared_target = SharedLatestValue(2 * len(pj)), SharedLatestValue(len(cj))
    proc = start_child(policy_process, connect=[], with_context=False, duration=900.0,
                       args={"spec": spec, "state_spec": shared_state.spec(), "target_spec": shared_target.spec()})
    cb, buf, last_seq = Cerebellum(spec["timeout"]), np.empty(len(cj)), 0
    try:
        while (msg := robot.wait_for_tick()) is not None:
            t = msg.header.stamp.sec + 1e-9 * msg.header.stamp.nanosec
            pos, vel = dict(zip(msg.name, msg.position)), dict(zip(msg.name, msg.velocity))
            shared_state.try_write([pos[j] for j in pj] + [vel[j] for j in pj], t)
            got = shared_target.try_read_into(buf)
            new = None
            if got is not None and got[0] != last_seq:
                last_seq, new = got[0], buf
            robot.command(cb.command(t, np.array([pos[j] for j in cj]), new))
    finally:
        proc.close()
        shared_state.close()
        shared_target.close()
'''

_THREAD_QUEUE = '''
def deploy(robot, spec):
    # a brain thread fed through a FIFO queue of every state (the oldest first)
    import queue
    import threading
    import time

    import numpy as np

    from robocourse.rl import load_runtime

    pj, cj = spec["policy_joints"], spec["command_joints"]
    to_command = [pj.index(j) for j in cj]
    default, target_rel = np.array(spec["default_pose"]), np.subtract(spec["target"], spec["tcp_default"])
    states, stop, lock, out = queue.Queue(), threading.Event(), threading.Lock(), {"target": None}

    def brain():
        runtime = load_runtime(**spec["policy"])
        last = np.zeros(len(pj))
        while not stop.is_set():
            try:
                tick, q, dq = states.get(timeout=0.05)
            except queue.Empty:
                continue
            if tick % spec["decimation"]:
                continue
            last = np.clip(runtime(np.concatenate([q - default, dq * spec["dof_vel_scale"], target_rel, last])), -1, 1)
            with lock:
                out["target"] = (default + spec["action_scale"] * last)[to_command]
            time.sleep(spec["decimation"] / spec["rate_hz"])

    threading.Thread(target=brain, daemon=True).start()
    bridge, seen = MiniBridge(len(cj), spec["timeout"]), None
    while (msg := robot.wait_for_tick()) is not None:
        now = msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9
        by_name = {n: i for i, n in enumerate(msg.name)}
        p = [by_name[j] for j in pj]
        states.put((round(now * spec["rate_hz"]), np.asarray(msg.position)[p], np.asarray(msg.velocity)[p]))
        with lock:
            t = out["target"]
        if t is not None and t is not seen:
            seen = t
            bridge.submit(t, now)
        robot.command(bridge.update(now, np.asarray(msg.position)[[by_name[j] for j in cj]])[1])
    stop.set()
'''

_IN_LOOP = [('''    brain_process = start_child(brain, connect=[], with_context=False, duration=900.0, name="brain",
                                args={"state": state.spec(), "targets": targets.spec(), "spec": spec})''',
             '''    from robocourse.rl import load_runtime
    runtime = load_runtime(**spec["policy"])
    to_command = [policy_joints.index(j) for j in command_joints]
    default, target_rel = np.array(spec["default_pose"]), np.subtract(spec["target"], spec["tcp_default"])
    last = np.zeros(len(policy_joints))
    brain_process = None'''),
            ('''            state.try_write(np.concatenate([position[p], velocity[p]]), round(now * spec["rate_hz"]))
            got = targets.try_read_into(received)                            # never waits for the brain
            if got is not None and got[0] != seen:
                seen = got[0]
                bridge.submit(received, now)''',
             '''            if round(now * spec["rate_hz"]) % spec["decimation"] == 0:
                obs = np.concatenate([position[p] - default, velocity[p] * spec["dof_vel_scale"], target_rel, last])
                last = np.clip(runtime(obs), -1.0, 1.0)
                bridge.submit((default + spec["action_scale"] * last)[to_command], now)'''),
            ("        brain_process.close()\n", "")]

_SUB = {"every": "a command every tick, from the first (hold while the brain starts)",
        "name": "targets from /joint_states by name, in the controller's joint order",
        "dec": "the policy runs once every `decimation` ticks",
        "latest": "the brain gets the newest state (a latest-value hand-over)",
        "safe": "timeout: the last target, then hold the measured position until a fresh target",
        "thread": "the policy never runs in the control loop's thread",
        "process": "the policy runs in a process of its own (no GIL shared with the loop)",
        "ticking": "the control loop keeps ticking while the brain is stuck"}
_W = {"every": 0.5, "name": 1.0, "dec": 0.5, "latest": 0.5, "safe": 1.0, "thread": 0.5, "process": 0.5, "ticking": 0.5}


_SAME = [("    bridge = MiniBridge(", "    bridge = MiniBridge(")]   # the reference deploy, a broken MiniBridge


def _bridge_with(*edits):
    code = _BRIDGE
    for old, new in edits:
        assert old in code, old
        code = code.replace(old, new)
    return code


def _all_but(*failed):
    return {_SUB[k]: w for k, w in _W.items() if k not in failed}


DEPLOY = Exercise(
    "ch06.deployment_loop", NB, setup=_SETUP + "\n\n" + _BRIDGE, timing=True,
    right=[Answer("a time-paced brain process and a cerebellum class", code=_PROCESS)],
    wrong=[
        Answer("the policy inside the control loop", replace=_IN_LOOP,
               score=_all_but("safe", "thread", "process", "ticking"),
               property="the brain outside the real-time loop", says="outside the real-time loop"),
        Answer("the brain in a thread of the loop's process", replace=[
            ('''    brain_process = start_child(brain, connect=[], with_context=False, duration=900.0, name="brain",
                                args={"state": state.spec(), "targets": targets.spec(), "spec": spec})''',
             '''    import threading
    threading.Thread(target=brain, kwargs=dict(duration=900.0, state=state.spec(), targets=targets.spec(), spec=spec),
                     daemon=True).start()
    brain_process = None'''), ("        brain_process.close()\n", "")],
               score=_all_but("process"), property="the brain in a process of its own", says="shares the loop's GIL"),
        Answer("/joint_states by index", replace=[("            p = [by_name[j] for j in policy_joints]",
                                                   "            p = list(range(len(policy_joints)))")],
               score=_all_but("name"), property="each joint looked up by name", says="look every joint up by name"),
        Answer("targets in the policy's order", replace=[("        to_command = [policy_joints.index(j) for j in command_joints]",
                                                          "        to_command = list(range(len(policy_joints)))")],
               score=_all_but("name"), property="targets in the controller's joint order", says="map each joint by name"),
        Answer("a queue of states to a thread", code=_THREAD_QUEUE, score=_all_but("latest", "process"),
               property="a latest-value hand-over", says="not the oldest queued one"),
        Answer("the policy on every tick", replace=[('int(tick) % spec["decimation"] == 0', "True")],
               score=_all_but("dec"), property="once every decimation ticks", says="asks for"),
        Answer("no timeout", replace=_SAME, setup=_bridge_with(("        elif not self.holding and not recent:",
                                                                "        elif not self.holding and self.received is None:")),
               score=_all_but("safe"), property="hold after timeout s without a target", says="hold the measured position"),
        Answer("holds the last target", replace=_SAME, setup=_bridge_with((
            "            self.held = np.asarray(q, dtype=float).copy()",
            "            self.held = np.asarray(q, dtype=float).copy() if self.target is None else self.target.copy()")),
               score=_all_but("safe"), property="hold the measured position", says="hold the measured position"),
        Answer("no command before the first target", replace=[("            robot.command(command)",
                                                               '            if mode == "run" or bridge.n_accepted > 0:\n'
                                                               '                robot.command(command)')],
               score=_all_but("every"), property="a command every tick from the first", says="from the first tick on"),
    ])

EXERCISES = [FOLD, EMA, BRIDGE, OBSERVATION, DEPLOY]
