"""Chapter 4's contact experiment: position control alone presses far harder than through the admittance
chain, which presses with K x; what touches the table and how far the tool tilts are recorded."""

from __future__ import annotations

import numpy as np
import pytest

from robocourse.control.wall_push import ADMITTANCE, JTC, wall_push

SOFT = {"mass": [3.0, 3.0, 3.0, 0.5, 0.5, 0.5], "damping_ratio": [1.0] * 6,
        "stiffness": [300.0, 300.0, 300.0, 50.0, 50.0, 50.0]}


@pytest.fixture(scope="module")
def runs():
    return wall_push(None, seconds=2.5), wall_push(SOFT, seconds=2.5)


def test_position_control_alone_presses_several_times_harder_than_through_the_admittance(runs):
    stiff, soft = runs
    assert stiff.peak > 4 * soft.peak and stiff.steady() > 4 * soft.steady()
    assert soft.cm.ordered_controllers() == [JTC, ADMITTANCE]


def test_the_admittance_presses_with_its_spring_times_how_far_it_holds_the_tool_back(runs):
    _, soft = runs
    x = soft.cm.controllers[ADMITTANCE].c.rule.x[2]
    assert 300.0 * x == pytest.approx(soft.steady(), rel=0.1)


def test_tilt_and_touching_geoms_are_recorded_per_cycle(runs):
    stiff, soft = runs
    for run in runs:
        assert run.tilt_deg.shape == run.t.shape and np.all(np.isfinite(run.tilt_deg))
        assert run.touching and all(name.split("/")[0] in ("left_finger", "right_finger", "gripper_hand")
                                    for name in run.touching)
    assert stiff.tilt_deg[-1] > soft.tilt_deg[-1]      # the harder push twists the wrist further


def test_joints_moving_tool_moves_the_flange_by_the_offset_keeping_its_orientation():
    from robocourse.control.wall_push import joints_moving_tool
    from robocourse.sim.robots import Kinematics

    kin = Kinematics("ur5e")
    q0 = np.array([0.0, -1.5708, 1.5708, -1.5708, -1.5708, 0.0])
    q = joints_moving_tool(q0, (0.02, -0.01, 0.06))
    before, after = kin.calculate_link_transform(q0), kin.calculate_link_transform(q)
    np.testing.assert_allclose(after[:3, 3] - before[:3, 3], [0.02, -0.01, 0.06], atol=1e-6)
    np.testing.assert_allclose(after[:3, :3], before[:3, :3], atol=1e-3)
