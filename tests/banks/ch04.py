"""Chapter 4's answer bank: plausible wrong answers (one per stated property) and differently written correct ones.

Every answer runs in the student's place in the grading sandbox (solutions/04_ros2_control_exercises.ipynb's
import cell, then the answer, then the check cell); the reference is the solution notebook's cell. A wrong
answer scores the sub-tests its mistake does not touch: ``score`` is that total, and ``says`` the words of the
sub-test that catches it. Where one mistake breaks two stated properties (a claim in the wrong order moves
the wrong joints) both sub-tests fail, and the property names the mistake.
"""

from robocourse.grading.bank import Answer, Exercise

NB = "04_ros2_control_exercises"

URDF = Exercise(
    "ch04.ros2_control_urdf", NB,
    right=[Answer("written out by hand, attributes and children in another order", code='''
def rrbot_ros2_control(initial_positions):
    j1, j2 = initial_positions["joint1"], initial_positions["joint2"]
    return f"""<ros2_control type="system" name="RRBot">
      <hardware>
        <param name="calculate_dynamics">True</param>
        <plugin>mock_components/GenericSystem</plugin>
      </hardware>
      <joint name="joint1">
        <state_interface name="position"><param name="initial_value">{j1!r}</param></state_interface>
        <state_interface name="velocity"/>
        <command_interface name="velocity"><param name="max">3.0</param><param name="min">-3.0</param></command_interface>
        <command_interface name="position"><param name="max">1.0</param><param name="min">-1.0</param></command_interface>
      </joint>
      <joint name="joint2">
        <command_interface name="velocity"><param name="min">-3</param><param name="max">3</param></command_interface>
        <state_interface name="position"><param name="initial_value">{j2!r}</param></state_interface>
        <state_interface name="velocity"/>
      </joint>
      <sensor name="tool_fts">
        <state_interface name="force.x"/><state_interface name="force.y"/><state_interface name="force.z"/>
        <state_interface name="torque.x"/><state_interface name="torque.y"/><state_interface name="torque.z"/>
        <param name="frame_id">tool_link</param>
      </sensor>
    </ros2_control>"""
''')],
    wrong=[
        Answer("no initial_value", replace=[('<param name="initial_value">', '<param name="start">')], score=2.5,
               property="the position states start at initial_positions", says="initial_value"),
        Answer("no calculate_dynamics", replace=[('    <param name="calculate_dynamics">true</param>\n', "")],
               score=2.25, property="the mock integrates velocity commands (calculate_dynamics)",
               says="calculate_dynamics"),
        Answer("joint2 takes a position command too",
               replace=[('{joint("joint2", [("velocity", (-3, 3))])}',
                         '{joint("joint2", [("position", (-1, 1)), ("velocity", (-3, 3))])}')],
               score=2.5, property="joint2 takes a velocity command only", says="the driver takes ['velocity']"),
        Answer("sensor interfaces with underscores", replace=[('name="{a}.{x}"', 'name="{a}_{x}"')], score=2.75,
               property="a force/torque sensor reports force.x .. torque.z", says="a force/torque sensor reports"),
        Answer("velocity limits swapped", replace=[('("velocity", (-3, 3))', '("velocity", (3, -3))')], score=2.5,
               property="min/max of each command interface", says="expected -3 .. 3"),
        Answer("an actuator", replace=[('type="system"', 'type="actuator"')], score=1.75,
               property="one system component", says="one system named 'RRBot'"),
        Answer("an unclosed sensor tag", replace=[("{fts}</sensor>", "{fts}")],
               property="an element ros2_control's parser accepts", says="parser refuses it"),
        Answer("no frame_id", replace=[('<param name="frame_id">tool_link</param>', "")], score=2.75,
               property="the sensor's frame_id parameter", says="frame_id"),
    ])

BOARD = Exercise(
    "ch04.motor_board", NB,
    right=[Answer("python loops over preallocated storage", code='''
class BoardSystem(SystemInterface):
    SUPPORTED_COMMAND_INTERFACES = ("position",)
    SUPPORTED_STATE_INTERFACES = ("position", "velocity")

    def __init__(self, board):
        super().__init__()
        self.board = board

    def on_init(self, info):
        result = super().on_init(info)
        if result != CallbackReturn.SUCCESS:
            return result
        return CallbackReturn.SUCCESS if len(info.joints) == self.board.n else CallbackReturn.ERROR

    def on_configure(self, previous_state):
        names = [j.name for j in self.info.joints]
        self.slots = [(self.state_index[f"{n}/position"], self.state_index[f"{n}/velocity"],
                       self.command_index[f"{n}/position"]) for n in names]
        self.q, self.dq, self.out = np.zeros(len(names)), np.zeros(len(names)), np.zeros(len(names))
        return CallbackReturn.SUCCESS

    def on_activate(self, previous_state):
        if not self.board.read(self.board.time or 0.0, self.q, self.dq):
            return CallbackReturn.ERROR
        for k, (_, _, c) in enumerate(self.slots):
            self.command_values[c] = self.q[k]
        return CallbackReturn.SUCCESS

    def read(self, time, period):
        if not self.board.read(time, self.q, self.dq):
            return return_type.ERROR
        for k, (p, v, _) in enumerate(self.slots):
            self.state_values[p] = self.q[k]
            self.state_values[v] = self.dq[k]
        return return_type.OK

    def write(self, time, period):
        for k, (_, _, c) in enumerate(self.slots):
            self.out[k] = self.command_values[c]
        return return_type.OK if self.board.write(self.out) else return_type.ERROR
''')],
    wrong=[
        Answer("forgets the activation copy", replace=[(
            "        self.command_values[self.c_idx] = self.q     # hold where the motors are: no activation jump\n", "")],
            score=2.75, property="on_activate copies the measured positions into the commands", says="activation jump"),
        Answer("swallows a failed read", replace=[(
            "        ok = self.board.read(time, self.q, self.dq)\n        if ok:",
            "        ok = self.board.read(time, self.q, self.dq) or True\n        if ok:")], score=3.5,
            property="a failed board.read() returns ERROR", says="not swallow it and return OK"),
        Answer("raises on a failed read", replace=[(
            "        ok = self.board.read(time, self.q, self.dq)\n",
            "        ok = self.board.read(time, self.q, self.dq)\n        if not ok:\n"
            "            raise OSError('board not answering')\n")], score=3.5,
            property="read() never raises", says="never raise in the loop"),
        Answer("ignores a refused write", replace=[(
            "        return return_type.OK if self.board.write(self.out) else return_type.ERROR",
            "        self.board.write(self.out)\n        return return_type.OK")], score=3.75,
            property="a refused board.write() returns ERROR", says="board.write() returned False) but write() returned OK"),
        Answer("logs every write", replace=[(
            '        np.take(self.command_values, self.c_idx, out=self.out, mode="clip")\n',
            '        np.take(self.command_values, self.c_idx, out=self.out, mode="clip")\n'
            '        self.get_logger().info(f"writing {self.out}")\n')], score=3.25,
            property="no logging in read()/write()", says="must not log"),
        Answer("trusts the URDF", replace=[(
            "        if super().on_init(info) != CallbackReturn.SUCCESS or len(info.joints) != self.board.n:",
            "        if super().on_init(info) != CallbackReturn.SUCCESS:")], score=3.75,
            property="on_init refuses a URDF that does not match the board", says="on_init must compare len(info.joints)"),
        Answer("never fills the states", replace=[(
            "            self.state_values[self.p_idx] = self.q\n            self.state_values[self.v_idx] = self.dq\n",
            "            pass\n")], score=3.5, property="read() fills the position and velocity states",
            says="read() must copy"),
        Answer("positions only", replace=[("            self.state_values[self.v_idx] = self.dq\n", "")], score=3.5,
               property="read() fills the velocity states", says="velocity state interfaces did not follow"),
        Answer("fresh arrays in every read", replace=[(
            "        ok = self.board.read(time, self.q, self.dq)\n        if ok:\n"
            "            self.state_values[self.p_idx] = self.q\n            self.state_values[self.v_idx] = self.dq\n",
            "        q, dq = np.zeros(len(self.q)), np.zeros(len(self.dq))\n        ok = self.board.read(time, q, dq)\n"
            "        if ok:\n            self.state_values[self.p_idx] = q\n            self.state_values[self.v_idx] = dq\n")],
            score=3.5, property="read() allocates no buffer per cycle", says="read() allocates a buffer every cycle"),
        Answer("fancy indexing in write", replace=[(
            '        np.take(self.command_values, self.c_idx, out=self.out, mode="clip")\n'
            "        return return_type.OK if self.board.write(self.out) else return_type.ERROR",
            "        return return_type.OK if self.board.write(self.command_values[self.c_idx]) else return_type.ERROR")],
            score=3.5, property="write() allocates no buffer per cycle", says="write() allocates a buffer every cycle"),
        Answer("copies only on the first activation", replace=[(
            "        now = 0.0 if self.board.time is None else self.board.time\n",
            "        if getattr(self, 'activated', False):\n            return CallbackReturn.SUCCESS\n"
            "        self.activated = True\n        now = 0.0 if self.board.time is None else self.board.time\n")],
            score=3.5, property="on_activate copies every time", says="every time, not only the first"),
    ])

YAML = Exercise(
    "ch04.controllers_yaml", NB,
    right=[Answer("block style, sections in another order", code='''
def controllers_yaml():
    return """
# block style, the order of a typical ros2_control_demos file
arm_controller:
  ros__parameters:
    joints:
      - joint1
      - joint2
    command_interfaces:
      - position
    state_interfaces:
      - velocity
      - position
    constraints:
      joint1:
        goal: 0.01
      joint2:
        goal: 0.01
      goal_time: 1.0
wrist_controller:
  ros__parameters:
    joints: [joint3]
controller_manager:
  ros__parameters:
    update_rate: 200  # Hz
    joint_state_broadcaster:
      type: joint_state_broadcaster/JointStateBroadcaster
    arm_controller:
      type: joint_trajectory_controller/JointTrajectoryController
    wrist_controller:
      type: position_controllers/JointGroupPositionController
"""
''')],
    wrong=[
        Answer("100 Hz", replace=[("update_rate: 200", "update_rate: 100")], score=1.75,
               property="the manager at 200 Hz", says="update_rate is 100 Hz"),
        Answer("a type that does not exist",
               replace=[("joint_trajectory_controller/JointTrajectoryController", "joint_trajectory_controller/JTC")],
               score=0.5, property="each controller's type", says="'arm_controller' could not be loaded"),
        Answer("the wrist controller without joints", replace=[("{joints: [joint3]}", "{interface_name: position}")],
               score=1.0, property="the wrist controller on joint3", says="'wrist_controller' was loaded but ended"),
        Answer("a negative goal_time", replace=[("goal_time: 1.0", "goal_time: -1.0")], score=0.5,
               property="values the JTC's schema accepts", says="must be greater than or equal to"),
        Answer("a loose goal tolerance", replace=[("joint2: {goal: 0.01}", "joint2: {goal: 0.1}")], score=1.75,
               property="a 0.01 rad goal tolerance per joint", says="constraints.joint2.goal is 0.1"),
        Answer("no velocity state", replace=[("state_interfaces: [position, velocity]", "state_interfaces: [position]")],
               score=1.5, property="the JTC reads position and velocity", says="state_interfaces ['position']"),
    ])

READ_ERROR = Exercise(
    "ch04.read_error", NB,
    right=[Answer("loops over the controllers", code='''
def after_hardware_error(controllers, hardware, failed, stage, result):
    stopped = []
    for name, used in controllers.items():
        watched = used["command"] if result == "DEACTIVATE" else used["command"] + used["state"]
        if any(itf in hardware[failed] for itf in watched):
            stopped.append(name)
    return {"deactivated": stopped, "hardware_state": {"DEACTIVATE": "inactive"}.get(result, "unconfigured")}
''')],
    wrong=[
        Answer("only the command users stop", replace=[(
            'hit = [n for n, c in controllers.items() if mine & (set(c["command"]) | set(c["state"]))]',
            'hit = [n for n, c in controllers.items() if mine & set(c["command"])]')], score=1.25,
            property="an ERROR stops the users of the component's state interfaces too", says="command OR state interfaces"),
        Answer("DEACTIVATE treated like ERROR", replace=[(
            '        hit = [n for n, c in controllers.items() if mine & set(c["command"])]\n',
            '        hit = [n for n, c in controllers.items() if mine & (set(c["command"]) | set(c["state"]))]\n')],
            score=1.25, property="DEACTIVATE stops only the command users", says="DEACTIVATE only stops the controllers holding"),
        Answer("an ERROR finalizes the component", replace=[(
            'return {"deactivated": sorted(hit), "hardware_state": "unconfigured"}',
            'return {"deactivated": sorted(hit), "hardware_state": "finalized"}')], score=1.5,
            property="on_error's SUCCESS leaves the component unconfigured", says="the component ends 'unconfigured'"),
        Answer("everything stops", code='''
def after_hardware_error(controllers, hardware, failed, stage, result):
    return {"deactivated": sorted(controllers), "hardware_state": "inactive" if result == "DEACTIVATE" else "unconfigured"}
''', score=0.5, property="only the controllers using the failed component stop",
               says="they use no interface of the failed component"),
    ])

CONTROLLER = Exercise(
    "ch04.controller", NB,
    right=[Answer("plain floats and a list as the hand-over", code='''
class SlewRateController(ControllerInterface):
    PARAMS = ParameterSchema.from_yaml("""
slew_rate_controller:
  joints: {type: string_array, validation: {not_empty<>: null, unique<>: null}}
  max_velocity: {type: double, default_value: 0.5, validation: {gt<>: [0.0]}}
""")

    def command_interface_configuration(self):
        return InterfaceConfiguration(ict.INDIVIDUAL, [j + "/position" for j in self.params.joints])

    state_interface_configuration = command_interface_configuration

    def on_configure(self, previous_state):
        self.cmd = [0.0] * len(self.params.joints)
        self.goal = [0.0] * len(self.params.joints)
        self.mailbox = []
        if self._node is None:
            self.get_node().create_subscription(Float64MultiArray, "~/commands", self.receive, 10)
        return CallbackReturn.SUCCESS

    def receive(self, msg):
        values = [float(v) for v in msg.data]
        if len(values) == len(self.goal) and not any(math.isnan(v) or math.isinf(v) for v in values):
            self.mailbox = values

    def on_activate(self, previous_state):
        for i, loan in enumerate(self.state_interfaces):
            self.cmd[i] = self.goal[i] = float(loan.get_value())
        self.mailbox = []
        return CallbackReturn.SUCCESS

    def update(self, time, period):
        box = self.mailbox
        if box:
            self.mailbox = []
            for i, v in enumerate(box):
                self.goal[i] = v
        limit = self.params.max_velocity * period
        for i, loan in enumerate(self.command_interfaces):
            d = self.goal[i] - self.cmd[i]
            self.cmd[i] += limit if d > limit else (-limit if d < -limit else d)
            loan.set_value(self.cmd[i])
        return return_type.OK
''')],
    wrong=[
        Answer("no copy on activation", replace=[(
            "        for k, loan in enumerate(self.state_interfaces):\n            self.command[k] = loan.get_value()\n"
            "        self.target[:] = self.command\n", "        self.target[:] = self.command\n")], score=3.0,
            property="on_activate copies the measured positions", says="the activation jump"),
        Answer("claims every interface, then picks its own", code='''
class SlewRateController(ControllerInterface):
    PARAMS = ParameterSchema.from_yaml("""
slew_rate_controller:
  joints: {type: string_array, validation: {not_empty<>: null, unique<>: null}}
  max_velocity: {type: double, default_value: 0.5, validation: {gt<>: [0.0]}}
""")

    def command_interface_configuration(self):
        return InterfaceConfiguration(ict.ALL)          # every command interface of the robot

    def state_interface_configuration(self):
        return InterfaceConfiguration(ict.ALL)

    def on_configure(self, previous_state):
        n = len(self.params.joints)
        self.command, self.target, self.newest = np.zeros(n), np.zeros(n), None
        if self._node is None:
            self.get_node().create_subscription(Float64MultiArray, "~/commands", self.on_commands, 10)
        return CallbackReturn.SUCCESS

    def on_commands(self, msg):
        if len(msg.data) == len(self.target) and all(math.isfinite(v) for v in msg.data):
            self.newest = np.array(msg.data, dtype=float)

    def on_activate(self, previous_state):
        want = [j + "/position" for j in self.params.joints]
        self.mine = [next(l for l in self.command_interfaces if l.get_name() == w) for w in want]
        states = [next(l for l in self.state_interfaces if l.get_name() == w) for w in want]
        for k, loan in enumerate(states):
            self.command[k] = loan.get_value()
        self.target[:] = self.command
        self.newest = None
        return CallbackReturn.SUCCESS

    def update(self, time, period):
        if self.newest is not None:
            self.target[:] = self.newest
            self.newest = None
        limit = self.params.max_velocity * period
        for k, loan in enumerate(self.mine):
            self.command[k] += min(max(self.target[k] - self.command[k], -limit), limit)
            loan.set_value(self.command[k])
        return return_type.OK
''', score=3.25, property="claims only its joints' position interfaces", says="beside another controller"),
        Answer("joints sorted by name", replace=[('[f"{j}/position" for j in self.params.joints]',
                                                  '[f"{j}/position" for j in sorted(self.params.joints)]')],
               score=2.5, property="interfaces in the order of the joints parameter",
               says="in the order of the 'joints' parameter"),
        Answer("no slew: jumps to the target", replace=[(
            "        np.clip(self.step, -limit, limit, out=self.step)\n", "")], score=2.75,
            property="moves at most max_velocity * period per update", says="by at most max_velocity * period"),
        Answer("a fixed 10 ms step", replace=[("        limit = self.params.max_velocity * period\n",
                                               "        limit = self.params.max_velocity * 0.01\n")], score=3.5,
               property="uses the period the manager passes", says="Use the period argument"),
        Answer("takes a NaN target", replace=[(
            "        if len(msg.data) == len(self.target) and all(math.isfinite(v) for v in msg.data):",
            "        if len(msg.data) == len(self.target):")], score=3.5,
            property="ignores messages with a non-finite value", says="must be ignored"),
        Answer("copies the state once, in on_configure", replace=[(
            "        self.newest = None                           # the callback hands over a new array; update() copies it\n",
            "        self.newest = None\n        self.copied = False\n"), (
            "        for k, loan in enumerate(self.state_interfaces):\n            self.command[k] = loan.get_value()\n"
            "        self.target[:] = self.command\n",
            "        if not self.copied:\n            self.copied = True\n"
            "            for k, loan in enumerate(self.state_interfaces):\n                self.command[k] = loan.get_value()\n"
            "            self.target[:] = self.command\n")], score=3.5,
            property="copies the state at every activation", says="not once in on_configure"),
        Answer("fresh arrays in update", replace=[(
            "        np.subtract(self.target, self.command, out=self.step)\n"
            "        np.clip(self.step, -limit, limit, out=self.step)\n"
            "        np.add(self.command, self.step, out=self.command)\n",
            "        self.command = self.command + np.clip(self.target - self.command, -limit, limit)\n")], score=3.5,
            property="update() allocates no buffer", says="update() allocates a buffer every cycle"),
    ])

CHAINABLE = Exercise(
    "ch04.chainable", NB,
    right=[Answer("per joint with python floats", code='''
class JointLimiter(ChainableControllerInterface):
    PARAMS = ParameterSchema.from_yaml("""
joint_limiter:
  joints: {type: string_array, validation: {not_empty<>: null, unique<>: null}}
  max_velocity: {type: double, default_value: 1.0, validation: {gt<>: [0.0]}}
  min_position: {type: double_array, default_value: []}
  max_position: {type: double_array, default_value: []}
""")

    def on_configure(self, previous_state):
        p = self.params
        if len(p.min_position) != len(p.joints) or len(p.max_position) != len(p.joints):
            return CallbackReturn.ERROR
        self.bounds = list(zip(p.min_position, p.max_position))
        self.out = [0.0] * len(p.joints)
        return CallbackReturn.SUCCESS

    def command_interface_configuration(self):
        return InterfaceConfiguration(ict.INDIVIDUAL, [name + "/position" for name in self.params.joints])

    def state_interface_configuration(self):
        return InterfaceConfiguration(ict.INDIVIDUAL, [name + "/position" for name in self.params.joints])

    def on_export_reference_interfaces(self):
        return [name + "/position" for name in self.params.joints]

    def on_activate(self, previous_state):
        for i, loan in enumerate(self.state_interfaces):
            self.out[i] = float(loan.get_value())
            self.reference_interfaces[i] = self.out[i]
        return CallbackReturn.SUCCESS

    def update_reference_from_subscribers(self, time, period):
        return return_type.OK

    def update_and_write_commands(self, time, period):
        step = self.params.max_velocity * period
        for i, loan in enumerate(self.command_interfaces):
            ref = self.reference_interfaces[i]
            if ref == ref:                               # not NaN
                lo, hi = self.bounds[i]
                goal = min(max(float(ref), lo), hi)
                self.out[i] += min(max(goal - self.out[i], -step), step)
            loan.set_value(self.out[i])
        return return_type.OK
''')],
    wrong=[
        Answer("clamps but never rate-limits", replace=[(
            "        np.subtract(self.wanted, self.command, out=self.wanted)\n"
            "        np.clip(self.wanted, -step, step, out=self.wanted)\n"
            "        np.add(self.command, self.wanted, out=self.command)\n",
            "        np.copyto(self.command, self.wanted)\n")], score=3.0,
            property="ramps at max_velocity", says="ramp at max_velocity"),
        Answer("a fixed 10 ms period", replace=[("        step = self.params.max_velocity * period\n",
                                                 "        step = self.params.max_velocity * 0.01\n")], score=3.0,
               property="uses the period it is given", says="ramp at max_velocity"),
        Answer("passes a NaN reference on", replace=[(
            "        np.copyto(self.wanted, self.command, where=~np.isfinite(self.wanted))   # NaN: hold\n", "")],
            score=3.5, property="a NaN reference holds the joint", says="a NaN reference: that joint holds"),
        Answer("no copy on activation", replace=[(
            "        for k, loan in enumerate(self.state_interfaces):\n            self.command[k] = loan.get_value()\n"
            "        self.reference_interfaces[:] = self.command       # not NaN: hold until someone writes\n", "")],
            score=3.25, property="starts at the measured positions", says="activated before any reference was written"),
        Answer("exports prefixed names", replace=[(
            '        return [f"{j}/position" for j in self.params.joints]\n        ### END SOLUTION\n\n    def on_activate',
            '        return [f"{self.name}/{j}/position" for j in self.params.joints]\n        ### END SOLUTION\n\n'
            "    def on_activate")], score=1.0,
            property="reference interfaces named <joint>/position", says="the manager adds the controller's name"),
        Answer(
            "refuses chained mode", replace=[(
                "    def update_reference_from_subscribers(self, time, period):",
                "    def on_set_chained_mode(self, chained_mode):\n        return False\n\n"
                "    def update_reference_from_subscribers(self, time, period):")], score=3.25,
            property="accepts chained mode", says="on_set_chained_mode must accept"),
        Answer("no position limits", replace=[("        np.clip(self.wanted, self.lo, self.hi, out=self.wanted)\n", "")],
               score=3.0, property="clamps to [min_position, max_position]",
               says="clamp each reference to [min_position, max_position]"),
        Answer("fresh arrays in update", replace=[(
            "        np.copyto(self.wanted, self.reference_interfaces)\n"
            "        np.copyto(self.wanted, self.command, where=~np.isfinite(self.wanted))   # NaN: hold\n"
            "        np.clip(self.wanted, self.lo, self.hi, out=self.wanted)\n"
            "        np.subtract(self.wanted, self.command, out=self.wanted)\n"
            "        np.clip(self.wanted, -step, step, out=self.wanted)\n"
            "        np.add(self.command, self.wanted, out=self.command)\n",
            "        wanted = np.where(np.isfinite(self.reference_interfaces), self.reference_interfaces, self.command)\n"
            "        self.command = self.command + np.clip(np.clip(wanted, self.lo, self.hi) - self.command, -step, step)\n")],
            score=3.5, property="update() allocates no buffer", says="update() allocates a buffer every cycle"),
    ])

CUBIC = Exercise(
    "ch04.cubic", NB,
    right=[Answer("the Hermite basis", code='''
def cubic_sample(p0, v0, p1, v1, T, t):
    s = t / T
    h = np.array([2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s, -2 * s**3 + 3 * s**2, s**3 - s**2])
    dh = np.array([6 * s**2 - 6 * s, 3 * s**2 - 4 * s + 1, -6 * s**2 + 6 * s, 3 * s**2 - 2 * s]) / T
    ddh = np.array([12 * s - 6, 6 * s - 4, -12 * s + 6, 6 * s - 2]) / T**2
    cols = np.array([np.asarray(p0, float), np.asarray(v0, float) * T, np.asarray(p1, float), np.asarray(v1, float) * T])
    return h @ cols, dh @ cols, ddh @ cols
''')],
    wrong=[
        Answer("a3 without v1", replace=[("a3 = (2.0 * (p0 - p1) + (v0 + v1) * T) / T**3",
                                          "a3 = (2.0 * (p0 - p1) + v0 * T) / T**3")], score=0.25,
               property="q'(T) = v1", says="q'(T) = v1"),
        Answer("no acceleration", replace=[("2.0 * a2 + 6.0 * a3 * t)", "0.0 * p0)")], score=1.5,
               property="the acceleration is the second derivative", says="acceleration wrong"),
        Answer("the first joint only", replace=[(
            "    return (p0 + v0 * t + a2 * t**2 + a3 * t**3, v0 + 2.0 * a2 * t + 3.0 * a3 * t**2, 2.0 * a2 + 6.0 * a3 * t)",
            "    q, dq, ddq = (p0 + v0 * t + a2 * t**2 + a3 * t**3, v0 + 2.0 * a2 * t + 3.0 * a3 * t**2, 2.0 * a2 + 6.0 * a3 * t)\n"
            "    return float(q[0]), float(dq[0]), float(ddq[0])")],
            property="one value per joint", says="one value per joint"),
        Answer("linear interpolation", code='''
def cubic_sample(p0, v0, p1, v1, T, t):
    p0, p1 = np.asarray(p0, float), np.asarray(p1, float)
    return p0 + (p1 - p0) * t / T, (p1 - p0) / T, np.zeros_like(p0)
''', score=0.25, property="a cubic through both velocities", says="q'(0) = v0"),
    ])

ADMITTANCE = Exercise(
    "ch04.admittance", NB,
    right=[Answer("the multiple by Newton's method", code='''
def tune_admittance(force, deflection, settle):
    u = 6.0
    for _ in range(50):
        u -= ((1 + u) * math.exp(-u) - 0.02) / (-u * math.exp(-u))
    stiffness = force / deflection
    mass = stiffness * settle**2 / u**2
    return {"stiffness": stiffness, "mass": mass, "damping_ratio": 1.0, "damping": 2.0 * math.sqrt(mass * stiffness)}
'''), Answer("slightly overdamped, its own closed form", code='''
def tune_admittance(force, deflection, settle):
    from scipy.optimize import brentq

    zeta, k = 1.05, force / deflection
    r = math.sqrt(zeta**2 - 1)

    def error(u):
        a, b = -(zeta - r), -(zeta + r)
        return abs((b * math.exp(a * u) - a * math.exp(b * u)) / (a - b))

    u = brentq(lambda u: error(u) - 0.02, 1.0, 40.0)
    mass = k * (0.97 * settle / u) ** 2
    return {"mass": mass, "stiffness": k, "damping_ratio": zeta, "damping": 2 * zeta * math.sqrt(mass * k)}
''')],
    wrong=[
        Answer("slightly underdamped", replace=[("    zeta = 1.0 ", "    zeta = 0.95 ")], score=1.0,
               property="no overshoot at all", says="overshoots the rest point"),
        Answer("K = F x", replace=[("    k = force / deflection ", "    k = force * deflection ")], score=1.5,
               property="rests at F / K = deflection", says="F / K"),
        Answer("the 4 / w rule of thumb", replace=[(
            "    wt = brentq(lambda u: (1.0 + u) * math.exp(-u) - 0.02, 1.0, 20.0)\n", "    wt = 4.0\n")], score=1.5,
            property="settles in the asked time (2 % band)", says="later than"),
        Answer("a unit virtual mass", replace=[("    mass = k * (settle / wt) ** 2 ", "    mass = 1.0 ")], score=1.5,
               property="the mass sets the settle time", says="settles after"),
        Answer("damping without the mass", replace=[(
            '"damping": 2.0 * zeta * math.sqrt(mass * k)}', '"damping": 2.0 * zeta * math.sqrt(k / mass)}')],
            score=1.5, property="D = 2 zeta sqrt(M K)", says="D = 2 zeta sqrt(M K)"),
        Answer("overdamped at the critical mass", replace=[("    zeta = 1.0 ", "    zeta = 1.5 ")], score=1.5,
               property="settles in the asked time, not later", says="later than"),
        Answer("too light", replace=[("    mass = k * (settle / wt) ** 2 ", "    mass = k * (0.6 * settle / wt) ** 2 ")],
               score=1.5, property="not sooner than asked", says="sooner than"),
    ])

EXERCISES = [URDF, BOARD, YAML, READ_ERROR, CONTROLLER, CHAINABLE, CUBIC, ADMITTANCE]
