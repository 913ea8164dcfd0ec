"""robocourse.control.manager: switching (STRICT / BEST_EFFORT), chaining, rates, fallbacks, faults.

Cases follow upstream's controller_manager tests (test_controller_manager.cpp,
test_controller_manager_srvs.cpp, test_controllers_chaining_with_controller_manager.cpp,
test_controller_manager_hardware_error_handling.cpp) on a mock_components/GenericSystem.
"""

from __future__ import annotations

import threading
import time

import pytest
from control_robots import STANDARD_2DOF, TestChainable, TestController, generic, urdf

from robocourse.control import (
    ACTIVE,
    BEST_EFFORT,
    INACTIVE,
    STRICT,
    UNCONFIGURED,
    ControllerManager,
    SystemInterface,
    return_type,
)
from robocourse.control.log import LogSink
from robocourse.msgs.builtin_interfaces import Duration

P1, V1, P2, V2 = "joint1/position", "joint1/velocity", "joint2/position", "joint2/velocity"


def make_cm(params=None, components=None, body=STANDARD_2DOF, name="GenericSystem2dof", **kw) -> ControllerManager:
    return ControllerManager(urdf(generic(name, body=body)), params=params, components=components,
                             log=LogSink(log_to_stderr=False), **kw)


def add(cm, name, ctrl, configure=True):
    assert cm.load_controller(name, controller=ctrl) is ctrl
    if configure:
        assert cm.configure_controller(name) == return_type.OK
    return ctrl


def state(cm, name):
    return cm.controllers[name].state


# --- lifecycle and the moment a switch takes effect ----------------------------------------------------------
def test_controller_lifecycle_updates_only_while_active():
    cm = make_cm()
    c = add(cm, "c", TestController([P1], [P1]), configure=False)
    assert state(cm, "c") == UNCONFIGURED
    cm.step(2)
    assert c.updates == []
    assert cm.configure_controller("c") == return_type.OK and state(cm, "c") == INACTIVE
    assert cm.switch_controller(["c"], [], STRICT) == return_type.OK
    assert state(cm, "c") == ACTIVE and cm.rm.command_interface_is_claimed(P1)
    cm.step(3)
    assert [round(t, 6) for t, _ in c.updates] == [0.03, 0.04, 0.05]
    assert cm.rm.value(P1) == 1.0                      # GenericSystem mirrored the command
    assert cm.switch_controller([], ["c"], STRICT) == return_type.OK
    cm.step(2)
    assert len(c.updates) == 3 and not cm.rm.command_interface_is_claimed(P1)


def test_switch_in_realtime_mode_waits_for_the_loop_and_applies_at_the_end_of_an_update():
    cm = make_cm(update_rate=200)

    class Seen(TestController):
        """Which cycle activated it, on which thread, and the cycle of each update (cm.cycles counts
        the cycles completed; the switch is applied at the end of an update, before that cycle counts)."""

        def on_activate(self, s):
            self.activated = (cm.cycles, threading.current_thread())
            return super().on_activate(s)

        def update(self, time, period):
            self.cycles_seen.append(cm.cycles)
            return super().update(time, period)

    c = add(cm, "c", Seen([P1]))
    c.cycles_seen = []
    result = {}

    def switcher():
        time.sleep(0.05)
        result["ret"] = cm.switch_controller(["c"], [], STRICT, timeout=5.0)
        result["active_at_return"] = state(cm, "c")

    t = threading.Thread(target=switcher)
    t.start()
    loop_thread = threading.current_thread()
    cm.run_realtime(0.3)
    t.join()
    assert result["ret"] == return_type.OK and result["active_at_return"] == ACTIVE   # it waited for the loop
    activated_in, thread = c.activated
    assert thread is loop_thread                       # the loop applied it, not the caller's thread
    # never updated in the cycle that activated it; updated in the very next one, and every one after
    assert c.cycles_seen[0] == activated_in + 1, (activated_in, c.cycles_seen[:3])
    assert c.cycles_seen == list(range(activated_in + 1, cm.cycles))


def test_switch_times_out_when_the_loop_is_stalled():
    class Slow(SystemInterface):
        def read(self, t, p):
            time.sleep(0.4)
            return return_type.OK

        def write(self, t, p):
            return return_type.OK

    cm = make_cm(components={"GenericSystem2dof": Slow()})
    add(cm, "c", TestController([P1]))
    out = {}
    t = threading.Thread(target=lambda: out.setdefault("ret", cm.switch_controller(["c"], [], STRICT, timeout=0.1)))
    loop = threading.Thread(target=lambda: cm.run_realtime(0.02, spin_bus=False))
    loop.start()
    time.sleep(0.05)
    t.start()
    t.join()
    loop.join()
    assert out["ret"] == return_type.ERROR
    assert cm.last_switch_message.endswith("Switch controller timed out after 0.1 seconds!")
    cm.step(1)
    assert state(cm, "c") == INACTIVE                  # the abandoned request is not applied later


def test_timeout_zero_uses_default_one_second():
    cm = make_cm()
    add(cm, "c", TestController([P1]))
    cm.switch_controller(["c"], [], STRICT, timeout=0)
    assert cm.log.count("Switch controller timeout is set to 0, using default 1s!") == 1


# --- STRICT / BEST_EFFORT -------------------------------------------------------------------------------
def test_strict_unknown_controller_aborts_everything():
    cm = make_cm()
    add(cm, "c", TestController([P1]))
    assert cm.switch_controller(["c", "ghost"], [], STRICT) == return_type.ERROR
    assert state(cm, "c") == INACTIVE
    assert ("Could not activate controller with name 'ghost' because no controller with this name exists\n"
            "Aborting, no controller is switched! ('STRICT' switch)") in cm.last_switch_message


def test_best_effort_skips_unknown_and_switches_the_rest():
    cm = make_cm()
    add(cm, "c", TestController([P1]))
    assert cm.switch_controller(["c", "ghost"], [], BEST_EFFORT) == return_type.OK
    assert state(cm, "c") == ACTIVE
    assert cm.last_switch_message.startswith("Successfully switched controllers!\nDeactivated controllers: [  ]\n"
                                             "Activated controllers: [ c ]")
    assert cm.switch_controller(["ghost1", "ghost2"], [], BEST_EFFORT) == return_type.ERROR


def test_unconfigured_controller_strict_fails_best_effort_drops_it():
    cm = make_cm()
    add(cm, "u", TestController([P2]), configure=False)
    add(cm, "c", TestController([P1]))
    msg = ("Controller with name 'u' is in 'unconfigured' state. The controller needs to be configured to be in "
           "'inactive' state before it can be checked and activated.")
    assert cm.switch_controller(["c", "u"], [], STRICT) == return_type.ERROR and msg in cm.last_switch_message
    assert state(cm, "c") == INACTIVE
    assert cm.switch_controller(["c", "u"], [], BEST_EFFORT) == return_type.OK
    assert (state(cm, "c"), state(cm, "u")) == (ACTIVE, UNCONFIGURED)


def test_already_active_and_not_active_messages():
    cm = make_cm()
    add(cm, "c", TestController([P1]))
    add(cm, "d", TestController([P2]))
    cm.switch_controller(["c"], [], STRICT)
    assert cm.switch_controller(["c"], [], STRICT) == return_type.ERROR
    assert "Controller with name 'c' is already active." in cm.last_switch_message
    assert cm.switch_controller([], ["d"], STRICT) == return_type.ERROR
    assert "Controller with name 'd' can not be deactivated since it is not active." in cm.last_switch_message
    assert cm.switch_controller(["c"], [], BEST_EFFORT) == return_type.OK
    assert cm.last_switch_message == "After checking the controllers, no controllers need to be activated or deactivated."


def test_restart_active_controller_when_in_both_lists():
    cm = make_cm()
    c = add(cm, "c", TestController([P1]))
    cm.switch_controller(["c"], [], STRICT)
    cm.step(1)
    assert cm.switch_controller(["c"], ["c"], STRICT) == return_type.OK and state(cm, "c") == ACTIVE
    cm.step(1)
    assert len(c.updates) == 2


def test_claimed_interface_fails_whatever_the_strictness_unless_released_in_the_same_request():
    cm = make_cm()
    add(cm, "a", TestController([P1]))
    add(cm, "b", TestController([P1, P2]))
    cm.switch_controller(["a"], [], STRICT)
    for strictness in (STRICT, BEST_EFFORT):
        assert cm.switch_controller(["b"], [], strictness) == return_type.ERROR
        assert ("Unable to activate controller 'b' since the command interface 'joint1/position' is currently "
                "claimed by another controller.") in cm.last_switch_message
    assert cm.switch_controller(["b"], ["a"], STRICT) == return_type.OK
    assert (state(cm, "a"), state(cm, "b")) == (INACTIVE, ACTIVE)
    assert cm.rm.claimed == {P1: "b", P2: "b"}


def test_two_controllers_activated_together_on_one_interface():
    cm = make_cm()
    add(cm, "a", TestController([P1]))
    add(cm, "b", TestController([P1]))
    assert cm.switch_controller(["a", "b"], [], BEST_EFFORT) == return_type.ERROR
    assert ("Unable to activate controller 'b' since the command interface 'joint1/position' will be used by "
            "another controller that is being activated.") in cm.last_switch_message


def test_nonexistent_command_and_state_interfaces_are_not_available():
    cm = make_cm()
    add(cm, "a", TestController(["joint3/position"]))
    add(cm, "b", TestController([], ["joint1/effort"]))
    assert cm.switch_controller(["a"], [], STRICT) == return_type.ERROR
    assert ("Unable to activate controller 'a' since the command interface 'joint3/position' is not available."
            in cm.last_switch_message)
    assert cm.switch_controller(["b"], [], STRICT) == return_type.ERROR
    assert "since the state interface 'joint1/effort' is not available." in cm.last_switch_message


def test_state_interfaces_are_shared():
    cm = make_cm()
    add(cm, "a", TestController([P1], [P1, V1]))
    add(cm, "b", TestController([P2], [P1]))
    assert cm.switch_controller(["a", "b"], [], STRICT) == return_type.OK


# --- loading and parameters -------------------------------------------------------------------------------
PARAMS = """
controller_manager:
  ros__parameters:
    update_rate: 100
    fwd:
      type: forward_command_controller/ForwardCommandController
    bad:
      type: forward_command_controller/ForwardCommandController
    typo:
      type: forward_command_controller/ForwardCommandControler
fwd:
  ros__parameters:
    joints: [joint1, joint2]
    interface_name: position
bad:
  ros__parameters:
    joints: joint1
    interface_name: position
"""


def test_load_errors_are_upstreams_messages():
    cm = make_cm(PARAMS)
    assert cm.load_controller("nothing") is None
    assert cm.log.count("The 'type' param was not defined for 'nothing'.") == 1
    assert cm.load_controller("typo") is None
    assert cm.log.count("Loader for controller 'typo' (type 'forward_command_controller/ForwardCommandControler') "
                        "not found.") == 1
    assert cm.load_controller("bad") is None
    assert cm.log.count("parameter 'joints' has invalid type: Wrong parameter type, parameter {joints} is of type "
                        "{string_array}, setting it to {string} is not allowed.") == 1
    assert cm.load_controller("fwd") is not None and cm.load_controller("fwd") is None
    assert cm.log.count("Controller 'fwd' already loaded, skipping load_controller") == 1


def test_switching_and_unloading_a_controller_that_is_not_loaded():
    cm = make_cm(PARAMS)
    assert cm.switch_controller(["fwd"], [], STRICT) == return_type.ERROR
    assert "Could not activate controller with name 'fwd' because no controller with this name exists" in \
        cm.last_switch_message
    assert cm.unload_controller("fwd") == return_type.ERROR
    cm.load_and_configure("fwd")
    cm.switch_controller(["fwd"], [], STRICT)
    assert cm.unload_controller("fwd") == return_type.ERROR
    assert cm.log.count("Could not unload controller with name 'fwd' because it is still in active state") == 1
    cm.switch_controller([], ["fwd"], STRICT)
    assert cm.unload_controller("fwd") == return_type.OK and "fwd" not in cm.controllers


def test_cm_parameters_wrong_type_and_out_of_bounds():
    with pytest.raises(Exception, match=r"Parameter 'update_rate' with the value '0' must be greater than '0'"):
        make_cm("controller_manager:\n  ros__parameters:\n    update_rate: 0\n")
    with pytest.raises(Exception, match=r"parameter \{update_rate\} is of type \{integer\}, setting it to \{double\}"):
        make_cm("controller_manager:\n  ros__parameters:\n    update_rate: 100.0\n")
    with pytest.raises(Exception, match=r"is not in the set '\{strict, best_effort\}'"):
        make_cm("controller_manager:\n  ros__parameters:\n    defaults:\n      switch_controller:\n"
                "        strictness: lenient\n")


def test_default_strictness_parameter_best_effort():
    cm = make_cm("controller_manager:\n  ros__parameters:\n    defaults:\n      switch_controller:\n"
                 "        strictness: best_effort\n")
    add(cm, "c", TestController([P1]))
    assert cm.switch_controller(["c", "ghost"], []) == return_type.OK and state(cm, "c") == ACTIVE


# --- rates --------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("rate, ticks, effective", [(50, 2, 50), (30, 3, 33), (100, 1, 100), (200, 1, 100), (0, 1, 100)])
def test_controller_update_rate_ticks_and_period(rate, ticks, effective):
    cm = make_cm(update_rate=100)
    c = TestController([P1])
    assert cm.load_controller("c", controller=c) is c
    c.update_rate = rate or 100
    cm.configure_controller("c")
    assert (cm.controllers["c"].ticks, c.update_rate) == (ticks, effective)
    cm.switch_controller(["c"], [], STRICT)
    cm.step(12)
    assert len(c.updates) == 12 // ticks
    assert c.updates[-1][1] == pytest.approx(ticks * 0.01)


# --- faults: controllers --------------------------------------------------------------------------------------
def test_update_error_deactivates_and_activates_fallback_controllers():
    cm = make_cm("controller_manager:\n  ros__parameters:\n    main:\n      fallback_controllers: [safe]\n")
    main = add(cm, "main", TestController([P1], value=1.0))
    safe = add(cm, "safe", TestController([P1], value=-1.0))
    cm.switch_controller(["main"], [], STRICT)
    cm.step(1)
    main.result = return_type.ERROR
    cm.step(1)
    assert (state(cm, "main"), state(cm, "safe")) == (INACTIVE, ACTIVE)
    cm.step(1)
    assert cm.rm.components["GenericSystem2dof"].impl.get_command(P1) == -1.0 and len(safe.updates) == 1
    assert cm.log.count("Deactivating following controllers as their update resulted in an error : [ main ]") == 1
    assert cm.log.count("Activating fallback controllers : [ safe ]") == 1


def test_update_raising_is_caught_logged_once_and_the_loop_continues():
    cm = make_cm()
    bad = add(cm, "bad", TestController([P1]))
    good = add(cm, "good", TestController([P2]))
    cm.switch_controller(["bad", "good"], [], STRICT)
    bad.raise_in_update = ZeroDivisionError("division by zero")
    cm.step(5)
    assert state(cm, "bad") == INACTIVE and len(good.updates) == 5
    assert cm.log.count("Caught exception of type : ZeroDivisionError while updating controller 'bad'") == 1


def test_update_overrun_is_logged_once_and_counted():
    cm = make_cm(update_rate=1000)
    slow = add(cm, "slow", TestController([P1]))
    cm.switch_controller(["slow"], [], STRICT)
    slow.sleep_s = 0.002
    cm.step(3)
    assert cm.controllers["slow"].overruns == 3 and state(cm, "slow") == ACTIVE
    assert cm.log.count("Controller 'slow' overran its period") == 1


def test_update_overrun_warning_obeys_overruns_print_warnings_false():
    # upstream's `overruns.print_warnings` (ros2_control PR #2546) silences the warning, not the count
    cm = make_cm(params={"controller_manager": {"overruns.print_warnings": False}},
                 update_rate=1000)
    slow = add(cm, "slow", TestController([P1]))
    cm.switch_controller(["slow"], [], STRICT)
    slow.sleep_s = 0.002
    cm.step(2)
    assert cm.controllers["slow"].overruns == 2
    assert cm.log.count("overran its period") == 0


# --- faults: hardware --------------------------------------------------------------------------------------
class Faulty(SystemInterface):
    """read()/write() results chosen by the test."""

    def __init__(self):
        super().__init__()
        self.read_result, self.write_result, self.read_raises, self.nan = return_type.OK, return_type.OK, None, False

    def on_configure(self, s):
        self.state_values[:] = 0.0
        return 0

    def read(self, t, p):
        if self.read_raises:
            raise self.read_raises
        if self.nan:
            self.set_state("joint1/position", float("nan"))
        return self.read_result

    def write(self, t, p):
        return self.write_result


def faulty_cm():
    hw = Faulty()
    cm = make_cm(components={"GenericSystem2dof": hw})
    add(cm, "cmd", TestController([P1]))
    add(cm, "obs", TestController([], [P2]))
    cm.switch_controller(["cmd", "obs"], [], STRICT)
    return cm, hw


@pytest.mark.parametrize("fault", ["error", "raise"])
def test_hardware_read_error_deactivates_every_controller_using_it(fault):
    cm, hw = faulty_cm()
    if fault == "error":
        hw.read_result = return_type.ERROR
    else:
        hw.read_raises = OSError("bus timeout")
    cm.step(3)
    assert (state(cm, "cmd"), state(cm, "obs")) == (INACTIVE, INACTIVE)
    assert cm.rm.get_components_status()["GenericSystem2dof"] == UNCONFIGURED
    assert cm.log.count("Deactivating following hardware components as their read cycle resulted in an error: "
                        "[ GenericSystem2dof ]") == 1
    if fault == "raise":
        assert cm.log.count("Exception of type : OSError occurred while reading from hardware 'GenericSystem2dof': "
                            "bus timeout") == 1


def test_hardware_write_deactivate_only_stops_command_holders():
    cm, hw = faulty_cm()
    hw.write_result = return_type.DEACTIVATE
    cm.step(3)
    assert (state(cm, "cmd"), state(cm, "obs")) == (INACTIVE, ACTIVE)
    assert cm.rm.get_components_status()["GenericSystem2dof"] == INACTIVE
    assert cm.log.count("because its write() returned DEACTIVATE") == 1


def test_hardware_read_nan_is_logged_once_and_passed_on():
    cm, hw = faulty_cm()
    hw.nan = True
    cm.step(4)
    assert (state(cm, "cmd"), state(cm, "obs")) == (ACTIVE, ACTIVE)
    assert cm.log.count("read NaN into state interface(s) ['joint1/position']") == 1


def test_activation_refused_on_inactive_hardware_unless_allowed():
    p = ("controller_manager:\n  ros__parameters:\n    hardware_components_initial_state:\n"
         "      inactive: [GenericSystem2dof]\n")
    cm = make_cm(p)
    add(cm, "c", TestController([P1]))
    assert cm.switch_controller(["c"], [], STRICT) == return_type.ERROR
    assert "belongs to hardware component 'GenericSystem2dof' in state 'inactive'" in cm.last_switch_message
    cm2 = make_cm(p + "    defaults:\n      allow_controller_activation_with_inactive_hardware: true\n")
    add(cm2, "c", TestController([P1]))
    assert cm2.switch_controller(["c"], [], STRICT) == return_type.OK


def test_set_hardware_component_state_deactivates_users_first():
    cm, hw = faulty_cm()
    assert cm.set_hardware_component_state("GenericSystem2dof", "inactive") == return_type.OK
    assert (state(cm, "cmd"), state(cm, "obs")) == (INACTIVE, ACTIVE)
    assert cm.set_hardware_component_state("GenericSystem2dof", "unconfigured") == return_type.OK
    assert state(cm, "obs") == INACTIVE
    assert cm.set_hardware_component_state("GenericSystem2dof", "active") == return_type.OK
    assert cm.switch_controller(["cmd", "obs"], [], STRICT) == return_type.OK


# --- chaining -------------------------------------------------------------------------------------------------
def chain_cm():
    cm = make_cm()
    follower = add(cm, "follower", TestChainable([P1], [P1], ["joint1/position"]))
    preceding = add(cm, "preceding", TestController(["follower/joint1/position"], [P1], value=1.0))
    return cm, preceding, follower


def test_chained_controllers_ordered_preceding_first():
    cm, _, _ = chain_cm()
    assert cm.ordered_controllers() == ["preceding", "follower"]
    assert cm.rm.command_interface_exists("follower/joint1/position")
    assert not cm.rm.command_interface_is_available("follower/joint1/position")


def test_preceding_needs_its_follower_active_or_activated_together():
    cm, pre, fol = chain_cm()
    assert cm.switch_controller(["preceding"], [], STRICT) == return_type.ERROR
    assert ("Unable to activate controller 'preceding' since its following controller 'follower' is not active "
            "and will not be activated") in cm.last_switch_message
    assert cm.switch_controller(["preceding", "follower"], [], STRICT) == return_type.OK
    assert fol.is_in_chained_mode() and cm.rm.command_interface_is_claimed("follower/joint1/position")
    cm.step(1)
    assert cm.rm.components["GenericSystem2dof"].impl.get_command(P1) == 11.0  # 1.0 through the chain, same cycle
    assert fol.from_subscribers == 0 and fol.updates == 1


def test_follower_cannot_be_deactivated_while_preceding_stays_active():
    cm, pre, fol = chain_cm()
    cm.switch_controller(["preceding", "follower"], [], STRICT)
    assert cm.switch_controller([], ["follower"], STRICT) == return_type.ERROR
    assert ("Unable to activate" not in cm.last_switch_message and "Unable to deactivate controller 'follower' since "
            "its preceding controller 'preceding' is active and will not be deactivated") in cm.last_switch_message
    assert cm.switch_controller([], ["preceding"], STRICT) == return_type.OK
    assert not fol.is_in_chained_mode() and state(cm, "follower") == ACTIVE
    cm.step(1)
    assert fol.from_subscribers == 1
    assert cm.switch_controller([], ["follower"], STRICT) == return_type.OK


def test_error_in_follower_deactivates_its_chain_group():
    cm, pre, fol = chain_cm()
    cm.switch_controller(["preceding", "follower"], [], STRICT)

    def broken(t, p):
        return return_type.ERROR

    fol.update_and_write_commands = broken
    cm.step(1)
    assert (state(cm, "preceding"), state(cm, "follower")) == (INACTIVE, INACTIVE)
    assert not cm.rm.command_interface_is_available("follower/joint1/position")


def test_list_controllers_reports_chain_connections():
    cm, pre, fol = chain_cm()
    cm.switch_controller(["preceding", "follower"], [], STRICT)
    by = {c.name: c for c in cm.list_controllers()}
    # list_controllers_srv_cb: a connection's reference_interfaces are the interface parts (after the first "/");
    # exported reference interfaces are listed without the "<controller>/" prefix
    assert by["preceding"].chain_connections[0].name == "follower"
    assert by["preceding"].chain_connections[0].reference_interfaces == ["joint1/position"]
    assert by["follower"].is_chainable and by["follower"].is_chained
    assert by["follower"].reference_interfaces == ["joint1/position"]
    assert by["preceding"].claimed_interfaces == ["follower/joint1/position"]


# --- controller lifecycle, transition by transition --------------------------------------------------------
@pytest.mark.parametrize("result, expected", [
    (0, INACTIVE),               # SUCCESS
    (1, UNCONFIGURED),           # FAILURE: stays
    (2, UNCONFIGURED),           # ERROR: on_error SUCCESS -> unconfigured
])
def test_controller_configure_transition(result, expected):
    cm = make_cm()
    c = add(cm, "c", TestController([P1]), configure=False)
    c.script["on_configure"] = result
    ret = cm.configure_controller("c")
    assert state(cm, "c") == expected and ret == (return_type.OK if expected == INACTIVE else return_type.ERROR)


@pytest.mark.parametrize("result, expected", [(1, INACTIVE), (2, UNCONFIGURED)])
def test_controller_activate_failure_releases_its_claims(result, expected):
    cm = make_cm()
    c = add(cm, "c", TestController([P1]))
    c.script["on_activate"] = result
    assert cm.switch_controller(["c"], [], STRICT) == return_type.ERROR
    assert "Unable to activate controllers: [ c ]" in cm.last_switch_message
    assert state(cm, "c") == expected and not cm.rm.command_interface_is_claimed(P1)
    assert cm.log.count(f"After activation, controller 'c' is in state '{expected.label}'") == 1


def test_configure_from_inactive_cleans_up_first_and_active_is_refused():
    cm = make_cm()
    add(cm, "c", TestController([P1]))
    assert cm.configure_controller("c") == return_type.OK and state(cm, "c") == INACTIVE
    cm.switch_controller(["c"], [], STRICT)
    assert cm.configure_controller("c") == return_type.ERROR
    assert cm.log.count("Controller 'c' can not be configured from 'active' state.") == 1
    cm.switch_controller([], ["c"], STRICT)
    assert cm.cleanup_controller("c") == return_type.OK and state(cm, "c") == UNCONFIGURED


# --- the wall-clock loop ------------------------------------------------------------------------------------
def test_realtime_run_records_every_stage_and_reports_settings():
    cm = make_cm(update_rate=500)
    add(cm, "c", TestController([P1]))
    cm.switch_controller(["c"], [], STRICT)
    result = cm.run_realtime(0.1, settings={"policy": None, "lock": False, "gc_mode": "freeze"})
    stats = result.times.stats()
    assert result.loop.iterations == 50 and result.times.count == 50
    assert stats["cycle"].count == 50
    assert stats["cycle"].min_us >= stats["read"].min_us and stats["cycle"].max_us > 0
    assert len(result.settings_reports) == 1 and "gc" in str(result.settings_reports[0]).lower()
    assert 0 < result.cpu_fraction and "overruns:" in result.table()
    assert cm.time == pytest.approx(0.1)


def test_deterministic_timing_table():
    cm = make_cm()
    add(cm, "c", TestController([P1]))
    cm.switch_controller(["c"], [], STRICT)
    times = cm.enable_timing(100)
    cm.step(20)
    assert times.count == 20 and times.table().splitlines()[0].split()[:3] == ["stage", "min", "us"]


# --- a student's own component, registered like a pluginlib plugin ---------------------------------------------
from robocourse.control import CallbackReturn, plugin  # noqa: E402


@plugin("my_robot/RRBotSystemPositionOnly")
class RRBotSystemPositionOnly(SystemInterface):
    """ros2_control_demos example_1: the state moves toward the command by (cmd - state) / slowdown."""

    def on_init(self, info):
        super().on_init(info)
        self.slowdown = float(info.hardware_parameters.get("example_param_hw_slowdown", "1.0"))
        return CallbackReturn.SUCCESS

    def on_activate(self, previous_state):
        for j in self.info.joints:          # no jump: commands start at the current positions
            self.set_command(f"{j.name}/position", self.get_state(f"{j.name}/position"))
        return CallbackReturn.SUCCESS

    def read(self, time, period):
        for j in self.info.joints:
            s, c = self.get_state(f"{j.name}/position"), self.get_command(f"{j.name}/position")
            self.set_state(f"{j.name}/position", s + (c - s) / self.slowdown)
        return return_type.OK

    def write(self, time, period):
        return return_type.OK


def test_student_component_by_plugin_name_converges_geometrically():
    body = ("".join(f'<joint name="{j}"><command_interface name="position"/><state_interface name="position">'
                    f'<param name="initial_value">0.0</param></state_interface></joint>' for j in ("joint1", "joint2")))
    text = urdf(generic("RRBot", {"example_param_hw_slowdown": "4.0"}, body=body).replace(
        "mock_components/GenericSystem", "my_robot/RRBotSystemPositionOnly"))
    cm = ControllerManager(text, log=LogSink(log_to_stderr=False))
    c = add(cm, "c", TestController([P1, P2], value=1.0))
    cm.step(1)
    assert cm.rm.components["RRBot"].impl.get_command(P1) == 0.0      # on_activate copied the state
    cm.switch_controller(["c"], [], STRICT)
    cm.step(5)
    # first update writes 1.0, then 4 reads move the state: 1 - (3/4)^4
    assert cm.rm.value(P1) == pytest.approx(1 - 0.75 ** 4)
    assert len(c.updates) == 5


def test_steady_cycle_allocates_no_lasting_memory():
    """2000 cycles of read/update/write with a forward-style controller leave < 16 kB behind (no per-cycle growth)."""
    import tracemalloc

    cm = make_cm()
    add(cm, "c", TestController([P1, P2, V1, V2]))
    cm.switch_controller(["c"], [], STRICT)
    c = cm.controllers["c"].c
    for _ in range(200):
        cm.cycle()
    c.record = False                              # the test controller's own bookkeeping would count
    tracemalloc.start()
    try:
        before, _ = tracemalloc.get_traced_memory()
        for _ in range(2000):
            cm.cycle()
        after, _ = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert after - before < 16_000


# --- robot_description arriving later (test_controller_manager_with_resource_manager.cpp) -----------------------
def test_manager_waits_for_a_valid_robot_description_on_the_topic():
    from robocourse.bus import DurabilityPolicy, QoSProfile
    from robocourse.msgs.std_msgs import String

    cm = ControllerManager(None, log=LogSink(log_to_stderr=False))
    assert not cm.rm.is_initialized
    assert cm.log.count("Waiting for data on 'robot_description' topic to finish initialization") == 1
    assert cm.load_controller("c", controller=TestController([P1])) is None
    assert cm.log.count("Resource Manager is not initialized yet!") == 1
    cm.step(2)                                            # the loop runs with no hardware
    pub = cm.context.create_node("robot_state_publisher").create_publisher(
        String, "/robot_description", QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL))
    valid = urdf(generic(body=STANDARD_2DOF))
    pub.publish(String(data=valid.replace("<plugin>mock_components/GenericSystem</plugin>", "")))
    cm.step(1)
    assert not cm.rm.is_initialized
    assert cm.log.count("Missing <plugin> tag of <hardware> element for 'GenericSystem2dof' in your URDF.") == 1
    pub.publish(String(data=valid))
    cm.step(1)
    assert cm.rm.is_initialized and cm.rm.get_components_status() == {"GenericSystem2dof": ACTIVE}
    add(cm, "c", TestController([P1]))
    assert cm.switch_controller(["c"], [], STRICT) == return_type.OK
    pub.publish(String(data=valid))
    cm.step(1)
    assert cm.log.count("ResourceManager has already loaded a urdf. Ignoring attempt to reload") == 1


def test_cycle_times_plot_has_labelled_axes():
    import matplotlib

    matplotlib.use("Agg")
    cm = make_cm()
    times = cm.enable_timing(50)
    cm.step(50)
    fig = times.plot(period_us=10_000)
    ax, hx = fig.axes
    assert (ax.get_ylabel(), hx.get_xlabel()) == ("duration [us]", "cycle duration [us]")
    assert [line.get_label() for line in ax.get_lines()] == ["read", "update", "write", "cycle", "period"]
    import matplotlib.pyplot as plt

    plt.close(fig)


# --- interface configurations and exported state interfaces -------------------------------------------------
class AllCommands(TestController):
    __test__ = False

    def command_interface_configuration(self):
        from robocourse.control import InterfaceConfiguration, interface_configuration_type

        return InterfaceConfiguration(interface_configuration_type.ALL)

    def state_interface_configuration(self):
        from robocourse.control import InterfaceConfiguration, interface_configuration_type

        return InterfaceConfiguration(interface_configuration_type.NONE)


def test_all_configuration_claims_every_hardware_command_interface_and_none_claims_nothing():
    cm = make_cm()
    c = add(cm, "all", AllCommands())
    assert cm.switch_controller(["all"], [], STRICT) == return_type.OK
    assert [loan.name for loan in c.command_interfaces] == [P1, V1, P2, V2] and c.state_interfaces == []
    assert sorted(cm.rm.claimed) == sorted([P1, V1, P2, V2])


class Estimator(TestChainable):
    """Exports a state interface ``<name>/joint1/estimate`` = measured position * 2."""

    __test__ = False

    def on_export_state_interfaces(self):
        return ["joint1/estimate"]

    def update_and_write_commands(self, time, period):
        self.exported_state_interfaces[0] = 2.0 * self.state_interfaces[0].get_value()
        return return_type.OK


def test_exported_state_interfaces_are_read_by_later_controllers():
    cm = make_cm()
    reader = add(cm, "reader", TestController([P2], ["estimator/joint1/estimate"]))
    est = add(cm, "estimator", Estimator([], [P1]))
    assert cm.ordered_controllers() == ["estimator", "reader"]            # the exporter updates first
    assert cm.switch_controller(["reader"], [], STRICT) == return_type.ERROR
    assert "state interface 'estimator/joint1/estimate' is not available" in cm.last_switch_message
    assert cm.switch_controller(["reader", "estimator"], [], STRICT) == return_type.OK
    cm.step(1)
    assert reader.state_interfaces[0].get_value() == pytest.approx(2 * 3.45)
    assert est.from_subscribers == 1 and not est.is_in_chained_mode()   # read, not chained


def test_interface_configuration_that_raises_fails_the_switch_not_the_manager():
    class Broken(TestController):
        __test__ = False

        def command_interface_configuration(self):
            raise KeyError("joints")

    cm = make_cm()
    add(cm, "b", Broken())
    assert cm.switch_controller(["b"], [], STRICT) == return_type.ERROR
    assert "Unable to activate controller 'b': its interface configuration raised KeyError('joints')" in \
        cm.last_switch_message


# --- run_realtime hands the bus back (regressions: services unanswered after / during a real-time run) ---------------


def _rrbot_cm():
    from robocourse.control.bringup import bringup

    return bringup("rrbot", spawn=["joint_state_broadcaster"], inactive=["forward_position_controller"],
                   log=LogSink(log_to_stderr=False))


def test_services_answer_after_realtime_runs():
    """After run_realtime the manager's nodes are back on its executor: list/switch services answer (twice over)."""
    from robocourse.control import introspection
    from robocourse.control.msgs import ListControllers, SwitchController

    cm = _rrbot_cm()
    nodes_before = {n.get_name() for n in cm.executor.get_nodes()}
    for _ in range(2):
        cm.run_realtime(0.05)
        assert {n.get_name() for n in cm.executor.get_nodes()} == nodes_before
        assert all(n._executor is cm.executor for n in cm.executor.get_nodes())
        names = [c.name for c in introspection.call(cm, ListControllers, "list_controllers", timeout_sec=2).controller]
        assert names == ["joint_state_broadcaster", "forward_position_controller"]
    resp = introspection.call(cm, SwitchController, "switch_controller", timeout_sec=2, request=SwitchController.Request(
        activate_controllers=["forward_position_controller"], strictness=STRICT))
    cm.step()
    assert resp.ok and cm.controllers["forward_position_controller"].state == ACTIVE


def test_services_and_new_controllers_work_during_a_realtime_run():
    """``ros2 control load/configure/switch`` while the loop runs: answered, and the new controller's topic is heard.

    Before: the new controller's node joined the manager's idle executor (its ~/commands went unheard until
    the run ended) and a caller on a simulated-time context gave up at once (its executor jumped the clock).
    """
    from robocourse.control import introspection
    from robocourse.control.msgs import (
        ConfigureController,
        LoadController,
        SwitchController,
        UnloadController,
    )
    from robocourse.msgs.std_msgs import Float64MultiArray

    cm = _rrbot_cm()
    cm.unload_controller("forward_position_controller")
    out = {}

    def operator():
        time.sleep(0.05)
        name = "forward_position_controller"
        out["load"] = introspection.call(cm, LoadController, "load_controller", LoadController.Request(name=name)).ok
        out["configure"] = introspection.call(cm, ConfigureController, "configure_controller",
                                              ConfigureController.Request(name=name)).ok
        out["switch"] = introspection.call(cm, SwitchController, "switch_controller", SwitchController.Request(
            activate_controllers=[name], strictness=STRICT, timeout=Duration(sec=2))).ok
        pub = cm.context.create_node("operator").create_publisher(Float64MultiArray, f"/{name}/commands", 10)
        pub.publish(Float64MultiArray(data=[0.3, -0.2]))
        deadline = time.monotonic() + 3.0
        loans = cm.controllers[name].c.command_interfaces
        while time.monotonic() < deadline and [loan.get_value() for loan in loans] != [0.3, -0.2]:
            time.sleep(0.01)
        out["during"] = [loan.get_value() for loan in loans]
        out["switch_off"] = introspection.call(cm, SwitchController, "switch_controller", SwitchController.Request(
            deactivate_controllers=[name], strictness=STRICT, timeout=Duration(sec=2))).ok
        out["unload"] = introspection.call(cm, UnloadController, "unload_controller",
                                           UnloadController.Request(name=name)).ok
        out["running_at_end"] = cm.rt_thread_running

    t = threading.Thread(target=operator)
    t.start()
    cm.run_realtime(3.0)
    t.join()
    assert out["running_at_end"], "the operator's calls must all land while the loop runs (machine too slow?)"
    assert out["load"] and out["configure"] and out["switch"] and out["switch_off"] and out["unload"], out
    assert out["during"] == [0.3, -0.2]
    # the unloaded controller's node was destroyed, not handed back to the manager's executor
    assert sorted(n.get_name() for n in cm.executor.get_nodes()) == ["controller_manager", "joint_state_broadcaster"]


def test_realtime_run_on_a_sim_time_context_advances_the_sim_clock_with_the_cycles():
    """Nodes on the manager's simulated-time context see the cycles' time during run_realtime, as in step()."""
    cm = _rrbot_cm()
    assert cm.context.sim is not None
    node = cm.context.create_node("watcher")
    ticks = []
    node.create_timer(0.05, lambda: ticks.append(node.get_clock().now().nanoseconds))
    cm.executor.add_node(node)
    cm.step(10)
    t_before = cm.time
    cm.run_realtime(0.3)
    assert cm.context.sim.ns == round(cm.time * 1e9)
    assert abs(cm.time - t_before - 0.3) < 1e-6
    assert node.get_clock().now().nanoseconds == round(cm.time * 1e9)
    # the timer fired during the run, on the simulated clock: its callbacks run on the executor's own
    # thread (as in ros2_control_node), so now() there may be a cycle or more past the timer's due time
    # on a loaded machine, but never outside the run's simulated span (a wall-clock timer would read ~1e18 ns)
    start, end = round(t_before * 1e9), round(cm.time * 1e9)
    during = [t for t in ticks if t > start]
    assert during and all(start + 50_000_000 <= t <= end for t in during) and during == sorted(during)


def test_orderly_shutdown_logs_info_not_error():
    # mirrors upstream's ControllerManager::shutdown_controllers() as a ros2_control_node logs it on Ctrl-C
    # ("Shutting down all controllers in the controller manager." then "Deactivating controller 'x'", all INFO);
    # no upstream unit test checks these lines
    from robocourse.control.log import LoggingSeverity

    cm = make_cm()
    add(cm, "c", TestController([P1], [P1]))
    assert cm.switch_controller(["c"], [], STRICT) == return_type.OK
    cm.step(1)
    cm.shutdown()
    assert state(cm, "c") == INACTIVE
    assert cm.log.messages("controller_manager", LoggingSeverity.ERROR) == []
    info = cm.log.messages("controller_manager", LoggingSeverity.INFO)
    assert info[-2:] == ["Shutting down all controllers in the controller manager.", "Deactivating controller 'c'"]


# --- issue 30: the last upstream divergences ---------------------------------------------------------------------
def test_update_returns_error_in_the_cycle_a_controller_fails():
    # controller_manager.cpp update(): `ret = controller_ret` for a failing controller, returned after the fallbacks
    cm = make_cm("controller_manager:\n  ros__parameters:\n    main:\n      fallback_controllers: [safe]\n")
    main = add(cm, "main", TestController([P1], value=1.0))
    add(cm, "safe", TestController([P1], value=-1.0))
    cm.switch_controller(["main"], [], STRICT)
    assert cm.update(0.01, 0.01) == return_type.OK
    main.result = return_type.ERROR
    assert cm.update(0.02, 0.01) == return_type.ERROR
    assert (state(cm, "main"), state(cm, "safe")) == (INACTIVE, ACTIVE)
    assert cm.update(0.03, 0.01) == return_type.OK          # the fallback runs fine
    cm2 = make_cm()
    bad = add(cm2, "bad", TestController([P1]))
    cm2.switch_controller(["bad"], [], STRICT)
    bad.raise_in_update = ZeroDivisionError("x")
    assert cm2.cycle() == return_type.ERROR                 # raising counts as ERROR; cycle() passes it on
    assert cm2.cycle() == return_type.OK                    # nothing active any more
    cm2.enable_timing(10)
    assert cm2.cycle() == return_type.OK


class LateExports(TestChainable):
    """Knows its reference interface names only in on_configure (as upstream controllers reading parameters)."""

    def on_configure(self, previous_state):
        self.references = ["computed/position"]
        return 0


def test_reference_interfaces_are_exported_at_configure_not_at_load():
    # controller_manager.cpp configure_controller(): export_reference_interfaces() after on_configure; cleanup removes
    # them (test_controllers_chaining_with_controller_manager.cpp checks the interfaces exist only once configured)
    cm = make_cm()
    c = add(cm, "late", LateExports([P1], [P1], []), configure=False)
    assert not cm.rm.command_interface_exists("late/computed/position")
    assert cm.configure_controller("late") == return_type.OK
    assert cm.rm.command_interface_exists("late/computed/position")
    assert not cm.rm.command_interface_is_available("late/computed/position")   # until it is active
    assert c.reference_interface_names == ["late/computed/position"]
    assert cm.configure_controller("late") == return_type.OK          # re-configure: cleaned up and exported again
    assert cm.rm.command_interface_keys().count("late/computed/position") == 1
    assert cm.cleanup_controller("late") == return_type.OK
    assert not cm.rm.command_interface_exists("late/computed/position")


def test_a_controller_cannot_be_its_own_fallback():
    # controller_manager.cpp load_controller(): "Controller '%s' cannot be a fallback controller for itself."
    cm = make_cm("controller_manager:\n  ros__parameters:\n    main:\n      fallback_controllers: [safe, main]\n")
    assert cm.load_controller("main", controller=TestController([P1])) is None
    assert cm.log.count("Controller 'main' cannot be a fallback controller for itself.") == 1
    assert "main" not in cm.controllers


@pytest.mark.parametrize("strictness", [STRICT, BEST_EFFORT])
def test_activation_checks_the_fallback_controllers_first(strictness):
    # controller_manager.cpp check_fallback_controllers_state_pre_activation(), run for every controller to activate
    # (test_controller_manager.cpp fallback tests): missing / unconfigured fallbacks refuse the activation
    p = "controller_manager:\n  ros__parameters:\n    main:\n      fallback_controllers: [safe]\n"
    cm = make_cm(p)
    add(cm, "main", TestController([P1]))
    # STRICT aborts; BEST_EFFORT drops 'main', leaving nothing to switch (upstream answers OK then)
    refused = return_type.ERROR if strictness == STRICT else return_type.OK
    assert cm.switch_controller(["main"], [], strictness) == refused
    assert cm.log.count("Unable to find the fallback controller : 'safe' of the controller : 'main' within the "
                        "controller list") == 1
    assert state(cm, "main") == INACTIVE
    add(cm, "safe", TestController([P2]), configure=False)           # loaded, unconfigured
    assert cm.switch_controller(["main"], [], strictness) == refused
    assert cm.log.count("Controller with name 'main' cannot be activated, as its fallback controller : 'safe' need "
                        "to be configured and be in inactive/active state!") == 1
    assert state(cm, "main") == INACTIVE
    assert cm.configure_controller("safe") == return_type.OK
    assert cm.switch_controller(["main"], [], strictness) == return_type.OK and state(cm, "main") == ACTIVE


def test_fallback_whose_interfaces_are_missing_refuses_the_activation():
    # check_fallback_controllers_state_pre_activation(): "... not all of its fallback controller's : '{}' command
    # interfaces are currently available!"
    p = "controller_manager:\n  ros__parameters:\n    main:\n      fallback_controllers: [safe]\n"
    cm = make_cm(p)
    add(cm, "main", TestController([P1]))
    add(cm, "safe", TestController(["joint9/position"]))
    assert cm.switch_controller(["main"], [], STRICT) == return_type.ERROR
    assert cm.log.count("Controller with name 'main' cannot be activated, as not all of its fallback controller's "
                        ": 'safe' command interfaces are currently available!") == 1


def test_hardware_read_deactivate_is_treated_as_error():
    # resource_manager.cpp read(): "DEACTIVATE returned from read cycle is treated the same as ERROR."; the component
    # goes through on_error and every controller using it (command or state) is deactivated
    cm, hw = faulty_cm()
    hw.read_result = return_type.DEACTIVATE
    cm.step(2)
    assert (state(cm, "cmd"), state(cm, "obs")) == (INACTIVE, INACTIVE)
    assert cm.rm.get_components_status()["GenericSystem2dof"] == UNCONFIGURED
    assert cm.log.count("DEACTIVATE returned from read cycle is treated the same as ERROR.") == 1
    assert cm.log.count("Deactivating following hardware components as their read cycle resulted in an error: "
                        "[ GenericSystem2dof ]") == 1


def test_list_controllers_reports_required_interfaces_only_when_configured():
    # list_controllers_srv_cb(): required interfaces (and chain data) only for an 'inactive' or 'active' controller
    cm = make_cm()
    add(cm, "c", TestController([P1], [P2]), configure=False)
    add(cm, "f", TestChainable([P2], [P2], ["joint2/position"]), configure=False)
    by = {c.name: c for c in cm.list_controllers()}
    assert by["c"].state == "unconfigured"
    assert (by["c"].required_command_interfaces, by["c"].required_state_interfaces) == ([], [])
    assert by["f"].reference_interfaces == [] and by["f"].is_chainable
    cm.configure_controller("c")
    cm.configure_controller("f")
    by = {c.name: c for c in cm.list_controllers()}
    assert (by["c"].required_command_interfaces, by["c"].required_state_interfaces) == ([P1], [P2])
    assert by["f"].reference_interfaces == ["joint2/position"] and not by["f"].is_chained
    cm.switch_controller(["c"], [], STRICT)
    by = {c.name: c for c in cm.list_controllers()}
    assert by["c"].claimed_interfaces == [P1] and by["c"].required_command_interfaces == [P1]


# --- issue 30: using it -------------------------------------------------------------------------------------------
def test_params_dict_shaped_like_a_parameter_file_is_read_like_the_file():
    text = ("controller_manager:\n  ros__parameters:\n    update_rate: 250\n    main:\n      type: x/Y\n"
            "main:\n  ros__parameters:\n    gain: 2.0\n")
    as_dict = {"controller_manager": {"ros__parameters": {"update_rate": 250, "main": {"type": "x/Y"}}},
               "main": {"ros__parameters": {"gain": 2.0}}}
    a, b = make_cm(text), make_cm(as_dict)
    assert a.update_rate == b.update_rate == 250
    assert a.controller_entries == b.controller_entries == {"main": {"type": "x/Y"}}
    assert b.controller_parameters("main") == {"gain": 2.0}
    assert b.log.count("is not a controller_manager parameter") == 0
    nested = make_cm({"controller_manager": {"update_rate": 200, "main": {"type": "x/Y"}}})   # per node, nested
    assert nested.update_rate == 200 and nested.controller_entries == {"main": {"type": "x/Y"}}


@pytest.mark.parametrize("bad, words", [
    ({"ros__parameters": {"update_rate": 100}}, "must sit under a node name"),
    ({"controller_manager": {"ros__parameters": {"update_rate": 100}}, "stray": 5}, "outside any 'ros__parameters'"),
    ({"controller_manager": 100}, "give each node a dict of its parameters"),
])
def test_params_dict_that_is_neither_layout_is_refused_with_the_fix(bad, words):
    with pytest.raises(ValueError, match=words):
        make_cm(bad)


def test_command_value_reads_what_the_controllers_wrote():
    cm = make_cm()
    add(cm, "c", TestController([P1], value=0.25))
    cm.switch_controller(["c"], [], STRICT)
    cm.step(1)
    assert cm.rm.command_value(P1) == 0.25
    with pytest.raises(KeyError, match="no command interface 'joint9/position'"):
        cm.rm.command_value("joint9/position")


def test_spin_until_future_complete_steps_the_loop_until_the_answer():
    from robocourse.control.msgs import ListControllers

    cm = make_cm()
    add(cm, "c", TestController([P1]))
    node = cm.context.create_node("cli")
    cm.executor.add_node(node)
    assert cm.node.get_name() == "controller_manager"        # the manager's node (and services) exist once used
    client = node.create_client(ListControllers, "/controller_manager/list_controllers")
    fut = client.call_async(ListControllers.Request())
    t0 = cm.time
    assert cm.spin_until_future_complete(fut, timeout_sec=1.0) is True
    assert [c.name for c in fut.result().controller] == ["c"] and cm.time - t0 < 1.0
    from robocourse.bus import Future

    never = Future()
    assert cm.spin_until_future_complete(never, timeout_sec=0.05) is False
    assert cm.time - t0 == pytest.approx(0.05, abs=0.011)
    with pytest.raises(ValueError, match="timeout_sec"):
        cm.spin_until_future_complete(never, timeout_sec=-1)


def test_introspection_is_part_of_the_package():
    import robocourse.control as control

    assert callable(control.introspection.list_controllers) and "introspection" in control.__all__
