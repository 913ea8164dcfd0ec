"""Diff-drive kinematics (property-based), odometry, motor drivers and the MuJoCo car."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from robocourse.mycar import kinematics as k
from robocourse.mycar.drivers import MujocoMotorDriver, SimulatedMotorDriver

speeds = st.floats(-2.0, 2.0, allow_nan=False)
rates = st.floats(-20.0, 20.0, allow_nan=False)


@settings(deadline=None)   # hypothesis's 200 ms per example is a timed assertion (a loaded machine fails it)
@given(speeds, rates)
def test_inverse_then_forward_is_identity(v, w):
    left, right = k.twist_to_wheel_speeds(v, w)
    v2, w2 = k.wheel_speeds_to_twist(left, right)
    assert v2 == pytest.approx(v, abs=1e-9) and w2 == pytest.approx(w, abs=1e-9)


@settings(deadline=None)
@given(speeds, rates)
def test_motor_commands_stay_in_range_and_keep_the_arc(v, w):
    left, right = k.twist_to_motor_commands(v, w)
    assert -1.0 <= left <= 1.0 and -1.0 <= right <= 1.0
    v2, w2 = k.motor_commands_to_twist(left, right)
    if abs(v) > 1e-3 and abs(v2) > 1e-6:
        assert w2 / v2 == pytest.approx(w / v, rel=1e-6)  # same curvature, maybe slower


def test_seed_numbers():
    # 0.2 m/s forward, 1 rad/s: wheels 0.2 -+ 0.075 m/s; normalised by 0.5 m/s
    assert k.twist_to_wheel_speeds(0.2, 1.0) == pytest.approx((0.125, 0.275))
    assert k.twist_to_motor_commands(0.2, 1.0) == pytest.approx((0.25, 0.55))
    with pytest.raises(ValueError, match="finite"):
        k.twist_to_wheel_speeds(float("nan"), 0.0)
    with pytest.raises(ValueError, match="wheel_base"):
        k.DiffDriveGeometry(wheel_base=0)


@settings(deadline=None)
@given(st.floats(0.05, 1.0), st.floats(0.2, 3.0), st.integers(1, 50))
def test_exact_arc_integration_is_step_independent(v, w, n):
    one = k.integrate_pose(0.0, 0.0, 0.0, v, w, 1.0)
    pose = (0.0, 0.0, 0.0)
    for _ in range(n):
        pose = k.integrate_pose(*pose, v, w, 1.0 / n)
    assert pose == pytest.approx(one, abs=1e-9)
    # and the car stays on its circle of radius v / w around (0, v / w)
    assert math.hypot(one[0], one[1] - v / w) == pytest.approx(v / w)


@settings(deadline=None)
@given(st.floats(-math.pi, math.pi))
def test_yaw_quaternion_round_trip(yaw):
    assert k.wrap_angle(k.quaternion_to_yaw(*k.yaw_to_quaternion(yaw)) - yaw) == pytest.approx(0.0, abs=1e-9)


def test_driver_clamps_requires_init_and_stops():
    d = SimulatedMotorDriver()
    with pytest.raises(RuntimeError, match="before init"):
        d.set_motor_speeds(0.1, 0.1)
    d.init()
    assert d.set_motor_speeds(1.7, -3.0) == (1.0, -1.0)
    assert d.history[-1] == (4095, True, 4095, False)
    d.set_motor_speeds(0.5, 0.25)
    assert d.history[-1] == (round(0.5 * 4095), True, round(0.25 * 4095), True)
    d.emergency_stop()
    assert d.stopped and (d.left, d.right) == (0.0, 0.0) and d.history[-1] == (0, True, 0, True)
    with pytest.raises(ValueError, match="left motor speed"):
        d.set_motor_speeds(float("nan"), 0.0)


def test_mujoco_car_drives_straight_at_the_commanded_speed():
    from robocourse.sim.car import MujocoCar

    car = MujocoCar()
    drv = MujocoMotorDriver(car)
    drv.init()
    drv.set_motor_speeds(*k.twist_to_motor_commands(0.3, 0.0))
    car.step(1.0)  # spin up
    x0, y0, _ = car.pose()
    car.step(2.0)
    x1, y1, yaw = car.pose()
    assert (x1 - x0) / 2.0 == pytest.approx(0.3, rel=0.05)
    assert abs(y1) < 0.01 and abs(yaw) < 0.02


def test_wheel_odometry_drifts_from_ground_truth_on_a_circle():
    """Stated bound: after 8 s on a 0.2 m circle, wheel odometry is within 10 cm of the truth."""
    from robocourse.sim.car import MujocoCar

    car = MujocoCar()
    drv = MujocoMotorDriver(car)
    drv.init()
    drv.set_motor_speeds(*k.twist_to_motor_commands(0.2, 1.0))
    odo = (0.0, 0.0, 0.0)
    for _ in range(800):
        car.step(0.01)
        wl, wr = car.wheel_speeds()
        odo = k.integrate_pose(*odo, *k.wheel_speeds_to_twist(wl * 0.0325, wr * 0.0325), 0.01)
    x, y, yaw = car.pose()
    assert math.hypot(x, y - 0.2) == pytest.approx(0.2, rel=0.15)  # it really drives the circle
    err = math.hypot(x - odo[0], y - odo[1])
    assert 0.0 < err < 0.10
