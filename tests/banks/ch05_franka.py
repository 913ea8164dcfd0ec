"""Chapter 5's Franka exercise (ch05.franka_loop): wrong answers, one per stated property, and a
differently written correct one. Each runs pylibfranka against its own simulated FR3 in the
grading sandbox; the lost cycles the machine caused (the loop's thread waiting for a CPU) are
not counted against the answer, so the verdicts hold under chapter 1's CPU load too."""

from robocourse.grading.bank import Answer, Exercise

NB = "05_hardware_drivers_exercises"
ALL_BUT = {"the motion runs to its end through the pauses": 2.0,
           "t is the robot's time (readOnce's durations)": 1.0,
           "starts where the arm is, ends at q0 + offset(seconds)": 0.5,
           "ends with motion_finished": 0.5,
           "a reflex reaches the caller after automatic_error_recovery()": 0.5}


def all_but(name):
    return {k: v for k, v in ALL_BUT.items() if k != name}


FRANKA_LOOP = Exercise(
    "ch05.franka_loop", NB, timing=True,
    right=[Answer("the robot's clock from state.time, a helper class", code='''
import numpy as np
import pylibfranka


class Follower:
    def __init__(self, robot, offset):
        self.robot, self.offset = robot, offset
        self.q0 = np.array(robot.read_once().q)

    def command(self, state):
        if self.t0 is None:
            self.t0 = state.time.to_sec()
        t = state.time.to_sec() - self.t0
        return t, pylibfranka.JointPositions(list(self.q0 + np.array(self.offset(t))))


def run_motion(robot, offset, seconds):
    follower = Follower(robot, offset)
    follower.t0 = None
    control = robot.start_joint_position_control(pylibfranka.ControllerMode.JointImpedance)
    n = 0
    try:
        done = False
        while not done:
            state, _ = control.readOnce()
            t, cmd = follower.command(state)
            done = t >= seconds
            cmd.motion_finished = done
            control.writeOnce(cmd)
            n += 1
    except pylibfranka.ControlException:
        control = None
        robot.automatic_error_recovery()
        raise
    return n
''')],
    wrong=[
        Answer("counts cycles instead of the robot's time", replace=[("t += period.to_sec()", "t += 0.001")],
               score=all_but("t is the robot's time (readOnce's durations)"),
               property="t is the robot's time (after a lost cycle it jumps)", says="not a count of cycles"),
        Answer("commands offset(t) without q0", replace=[("cmd.q = (q0 + np.asarray(offset(t))).tolist()",
                                                          "cmd.q = list(offset(t))")],
               property="command q0 + offset(t), q0 the arm's position", says="run_motion raised ControlException"),
        Answer("blocks 30 ms once in the loop", replace=[("            cycles += 1\n",
                                                          "            cycles += 1\n"
                                                          "            if cycles == 500:\n"
                                                          "                import time\n"
                                                          "                time.sleep(0.03)\n")],
               property="nothing in the loop blocks for 20 cycles", says="communication_constraints_violation"),
        Answer("computes 30 ms once in the loop", replace=[("            cycles += 1\n",
                                                           "            cycles += 1\n"
                                                           "            if cycles == 500:\n"
                                                           "                import time\n"
                                                           "                busy = time.thread_time() + 0.03\n"
                                                           "                while time.thread_time() < busy:\n"
                                                           "                    pass\n")],
               property="nothing in the loop computes for 20 cycles (30 ms of its own CPU time: a planner step)",
               says="communication_constraints_violation"),
        Answer("returns without motion_finished", replace=[("cmd.motion_finished = t >= seconds",
                                                            "cmd.motion_finished = False"),
                                                           ("            if cmd.motion_finished:\n",
                                                            "            if t >= seconds:\n")],
               score=all_but("ends with motion_finished"), property="end with motion_finished",
               says="motion_finished = True"),
        Answer("swallows the reflex", replace=[("        robot.automatic_error_recovery()\n        raise",
                                                "        robot.automatic_error_recovery()\n        return cycles")],
               score=all_but("a reflex reaches the caller after automatic_error_recovery()"),
               property="let the ControlException out", says="let libfranka's ControlException out"),
        Answer("raises without recovering", replace=[("        robot.automatic_error_recovery()\n        raise",
                                                      "        raise")],
               score=all_but("a reflex reaches the caller after automatic_error_recovery()"),
               property="recover before raising", says="automatic_error_recovery()"),
    ])

EXERCISES = [FRANKA_LOOP]
