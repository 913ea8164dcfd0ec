"""The shipped robots: URDF facts, the <ros2_control> element, and RobotSim's physics in numbers."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from robocourse.sim import robots
from robocourse.sim.robots import GraspObject, Kinematics, RobotSim, ServoGains, Wall

mujoco = pytest.importorskip("mujoco")

UR_JOINTS = ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint",
             "wrist_3_joint"]
G = 9.81  # MuJoCo's default |gravity|, m/s^2
TOOL_MASS = 0.73 + 2 * 0.015  # gripper hand + two fingers, kg


def ur5e_dh_flange(q) -> np.ndarray:
    """UR5e flange pose from UR's published standard DH table, written out independently here."""
    d = [0.1625, 0.0, 0.0, 0.1333, 0.0997, 0.0996]
    a = [0.0, -0.425, -0.3922, 0.0, 0.0, 0.0]
    alpha = [math.pi / 2, 0.0, 0.0, math.pi / 2, -math.pi / 2, 0.0]
    T = np.eye(4)
    for th, di, ai, al in zip(q, d, a, alpha):
        ct, st, ca, sa = math.cos(th), math.sin(th), math.cos(al), math.sin(al)
        T = T @ np.array([[ct, -st * ca, st * sa, ai * ct],
                          [st, ct * ca, -ct * sa, ai * st],
                          [0.0, sa, ca, di],
                          [0.0, 0.0, 0.0, 1.0]])
    return T


# --- URDF facts -----------------------------------------------------------------------------

@pytest.mark.parametrize("q", [[0, 0, 0, 0, 0, 0], [0, -math.pi / 2, math.pi / 2, -math.pi / 2, -math.pi / 2, 0],
                               [0.3, -1.1, 1.9, -0.4, 1.2, -2.5], [-2.0, -0.3, -1.4, 2.2, -0.7, 0.9]])
def test_ur5e_flange_matches_published_dh_forward_kinematics_within_1_mm(q):
    sim = RobotSim("ur5e")
    sim.reset(dict(zip(UR_JOINTS, q)))
    pos, rot = sim.link_pose("tool0")
    T = ur5e_dh_flange(q)
    assert np.linalg.norm(pos - T[:3, 3]) < 1e-3
    np.testing.assert_allclose(pos, T[:3, 3], atol=1e-9)  # in fact exact
    np.testing.assert_allclose(rot, T[:3, :3], atol=1e-9)


def test_ur5e_link_masses_are_the_published_ones_17_7_kg_in_all():
    m = RobotSim("ur5e").model
    masses = [m.body(b).mass[0] for b in ("shoulder_link", "upper_arm_link", "forearm_link", "wrist_1_link",
                                          "wrist_2_link", "wrist_3_link")]
    assert masses == [3.761, 8.058, 2.846, 1.37, 1.3, 0.365]
    assert sum(masses) == pytest.approx(17.7, abs=1e-12)
    assert m.body("base_link").mass[0] == 0.0  # fixed base: no mass in the model
    assert m.body("tool0").subtreemass[0] == pytest.approx(TOOL_MASS)


def test_ur5e_joint_limits_are_urs():
    lim = robots.joint_limits("ur5e")
    assert list(lim) == UR_JOINTS + ["finger_joint", "right_finger_joint"]
    for j in UR_JOINTS:
        span = math.pi if j == "elbow_joint" else 2 * math.pi
        assert (lim[j].lower, lim[j].upper) == (-span, span)
        assert lim[j].velocity == pytest.approx(math.pi)  # 180 deg/s
    assert [lim[j].effort for j in UR_JOINTS] == [150, 150, 150, 28, 28, 28]
    f = lim["finger_joint"]
    assert (f.type, f.lower, f.upper, f.effort, f.velocity, f.mimic) == ("prismatic", 0.0, 0.04, 20.0, 0.2, None)
    assert lim["right_finger_joint"].mimic == "finger_joint"
    # MuJoCo read the same limits from the same file
    m = RobotSim("ur5e").model
    np.testing.assert_allclose(m.jnt_range[m.joint("elbow_joint").id], (-math.pi, math.pi))
    np.testing.assert_allclose(m.jnt_actfrcrange[m.joint("wrist_2_joint").id], (-28, 28))


def test_rrbot_is_the_demo_robot():
    lim = robots.joint_limits("rrbot")
    assert list(lim) == ["joint1", "joint2"] and all(v.type == "continuous" for v in lim.values())
    sim = RobotSim("rrbot")
    m = sim.model
    assert [m.body(b).mass[0] for b in ("link1", "link2")] == [1.0, 1.0]
    np.testing.assert_allclose(m.dof_damping, [0.7, 0.7])
    pos, _ = sim.link_pose("tool_link")  # upright: 1.95 + 0.9 + 1 m, offset 0.2 m in y
    np.testing.assert_allclose(pos, [0.0, 0.2, 3.85], atol=1e-12)


def _ros2_control(text: str) -> ET.Element:
    [element] = ET.fromstring(text).findall("ros2_control")
    return element


def _interfaces(joint: ET.Element, kind: str) -> list[str]:
    return [i.get("name") for i in joint.findall(kind)]


@pytest.mark.parametrize("name, system, joints", [
    ("rrbot", "RRBot", ["joint1", "joint2"]),
    ("ur5e", "UR5e", UR_JOINTS + ["finger_joint"]),
])
def test_ros2_control_element_lists_exactly_the_joints_and_interfaces(name, system, joints):
    rc = _ros2_control(robots.urdf_path(name).read_text())
    assert (rc.get("name"), rc.get("type")) == (system, "system")
    assert rc.find("hardware/plugin").text == "mock_components/GenericSystem"
    commanded = [j for j in rc.findall("joint") if j.get("mimic") != "true"]
    assert [j.get("name") for j in commanded] == joints
    limits = robots.joint_limits(name)
    for j in commanded:
        assert _interfaces(j, "command_interface") == ["position", "velocity", "effort"]
        assert _interfaces(j, "state_interface") == ["position", "velocity", "effort"]
        bounds = {c.get("name"): {p.get("name"): float(p.text) for p in c.findall("param")}
                  for c in j.findall("command_interface")}
        lim = limits[j.get("name")]
        assert bounds["velocity"] == {"min": -lim.velocity, "max": lim.velocity}
        assert bounds["effort"] == {"min": -lim.effort, "max": lim.effort}
        if lim.type != "continuous":
            assert bounds["position"] == {"min": lim.lower, "max": lim.upper}
        else:  # the demo's command range for its continuous joints
            assert bounds["position"] == {"min": -1.0, "max": 1.0}
        init = j.find("state_interface[@name='position']/param[@name='initial_value']")
        assert init is not None and math.isfinite(float(init.text))
    mimics = [j for j in rc.findall("joint") if j.get("mimic") == "true"]
    sensors = rc.findall("sensor")
    if name == "ur5e":
        [mimic] = mimics
        assert mimic.get("name") == "right_finger_joint" and _interfaces(mimic, "command_interface") == []
        assert _interfaces(mimic, "state_interface") == ["position", "velocity"]
        [fts] = sensors
        assert fts.get("name") == "tcp_fts_sensor"
        assert _interfaces(fts, "state_interface") == [f"{a}.{x}" for a in ("force", "torque") for x in "xyz"]
    else:
        assert mimics == [] and sensors == []


def test_initial_values_are_the_sims_reset_pose():
    sim = RobotSim("ur5e")
    np.testing.assert_allclose(sim.positions, [0, -math.pi / 2, math.pi / 2, -math.pi / 2, -math.pi / 2, 0, 0.04])


def test_urdf_text_substitutes_plugin_params_and_initial_positions():
    text = robots.urdf_text("ur5e", plugin="robocourse/MujocoSystem",
                            params={"timestep": 0.001, "gravity_feedforward": True, "label": "arm", "n": 3},
                            initial_positions={"elbow_joint": 1.0})
    rc = _ros2_control(text)
    assert rc.find("hardware/plugin").text == "robocourse/MujocoSystem"
    assert {p.get("name"): p.text for p in rc.findall("hardware/param")} == {
        "timestep": "0.001", "gravity_feedforward": "true", "label": "arm", "n": "3"}
    elbow = rc.find("joint[@name='elbow_joint']/state_interface[@name='position']/param[@name='initial_value']")
    assert float(elbow.text) == 1.0
    original = robots.urdf_path("ur5e").read_text()
    assert robots.urdf_text("ur5e") == original
    cut = original.index("<ros2_control ")
    assert text[:cut] == original[:cut]  # everything before the element is byte for byte the file


def test_mujoco_ignores_the_ros2_control_element():
    with_rc = robots.urdf_text("ur5e", plugin="some_pkg/Other", params={"x": 1})
    without = with_rc[:with_rc.index("<ros2_control ")] + "</robot>\n"
    a, b = mujoco.MjModel.from_xml_string(with_rc), mujoco.MjModel.from_xml_string(without)
    assert (a.nq, a.nbody, a.ngeom, a.neq) == (b.nq, b.nbody, b.ngeom, b.neq) == (8, 13, 12, 1)
    np.testing.assert_array_equal(a.body_mass, b.body_mass)


@pytest.mark.parametrize("kwargs, match", [
    ({"plugin": "GenericSystem"}, "pluginlib class name"),
    ({"plugin": "a/b<c>"}, "pluginlib class name"),
    ({"plugin": 3}, "pluginlib class name"),
    ({"params": ["x"]}, "mapping"),
    ({"params": {"bad name": 1}}, "plain name"),
    ({"params": {"x": [1, 2]}}, "list"),
    ({"params": {"x": "a<b"}}, "may not contain"),
    ({"params": {"x": float("nan")}}, "not finite"),
    ({"initial_positions": {"nope": 0.0}}, "not a commanded joint"),
    ({"initial_positions": {"right_finger_joint": 0.0}}, "not a commanded joint"),
    ({"initial_positions": {"elbow_joint": 4.0}}, "outside the joint's limits"),
    ({"initial_positions": {"elbow_joint": "1"}}, "finite number"),
])
def test_urdf_text_rejects_bad_input_clearly(kwargs, match):
    with pytest.raises(ValueError, match=match):
        robots.urdf_text("ur5e", **kwargs)


def test_unknown_robot_names_the_choices():
    for call in (lambda: robots.urdf_path("ur10"), lambda: robots.urdf_text("ur10"), lambda: RobotSim("ur10")):
        with pytest.raises(ValueError, match="rrbot, ur5e"):
            call()


# --- Kinematics ------------------------------------------------------------------------------

def test_kinematics_chain_is_the_six_arm_joints_and_fk_is_the_dh_table():
    kin = Kinematics("ur5e")
    assert kin.joint_names == tuple(UR_JOINTS) and kin.tip == "tool0"
    q = [0.3, -1.1, 1.9, -0.4, 1.2, -2.5]
    np.testing.assert_allclose(kin.calculate_link_transform(q), ur5e_dh_flange(q), atol=1e-9)
    assert Kinematics("rrbot").joint_names == ("joint1", "joint2")


def test_jacobian_matches_finite_differences_of_the_dh_pose():
    kin = Kinematics("ur5e")
    q = np.array([-0.6, -1.3, 1.4, -1.7, -1.5, 0.4])
    J = kin.calculate_jacobian(q)
    h = 1e-6
    for i in range(6):
        dq = np.zeros(6)
        dq[i] = h
        Tp, Tm = ur5e_dh_flange(q + dq), ur5e_dh_flange(q - dq)
        np.testing.assert_allclose(J[:3, i], (Tp[:3, 3] - Tm[:3, 3]) / (2 * h), atol=1e-6)
        dR = (Tp[:3, :3] - Tm[:3, :3]) / (2 * h) @ ur5e_dh_flange(q)[:3, :3].T  # skew(omega)
        np.testing.assert_allclose(J[3:, i], [dR[2, 1], dR[0, 2], dR[1, 0]], atol=1e-6)


def test_cartesian_and_joint_deltas_convert_both_ways():
    kin = Kinematics("ur5e")
    q = np.array([0.2, -1.2, 1.5, -1.8, -1.6, 0.1])  # away from singularities
    dx = np.array([0.01, -0.02, 0.005, 0.0, 0.01, -0.03])
    dq = kin.convert_cartesian_deltas_to_joint_deltas(q, dx)
    np.testing.assert_allclose(kin.convert_joint_deltas_to_cartesian_deltas(q, dq), dx, atol=1e-12)
    moved = kin.calculate_link_transform(q + dq)[:3, 3] - kin.calculate_link_transform(q)[:3, 3]
    np.testing.assert_allclose(moved, dx[:3], atol=5e-4)  # first order: small deltas move as asked


@pytest.mark.parametrize("call, match", [
    (lambda k: k.calculate_link_transform([0.0] * 5), "6 finite numbers"),
    (lambda k: k.calculate_jacobian([0.0] * 5 + [float("nan")]), "6 finite numbers"),
    (lambda k: k.calculate_link_transform([0.0] * 6, "hand"), "not a link"),
    (lambda k: k.convert_cartesian_deltas_to_joint_deltas([0.0] * 6, [0.0] * 3), "6 finite numbers"),
    (lambda k: k.convert_joint_deltas_to_cartesian_deltas([0.0] * 6, [0.0] * 7), "6 finite numbers"),
])
def test_kinematics_refuses_bad_vectors(call, match):
    with pytest.raises(ValueError, match=match):
        call(Kinematics("ur5e"))


def test_a_chain_through_the_mimic_finger_is_refused():
    with pytest.raises(ValueError, match="mimic joint"):
        Kinematics("ur5e", tip="right_finger")


# --- RobotSim -----------------------------------------------------------------------------

def test_state_views_are_current_read_only_and_never_reallocated():
    sim = RobotSim("ur5e")
    p, v, e, c = sim.positions, sim.velocities, sim.efforts, sim.commands
    sim.commands[1] += 0.2
    sim.step(50)
    assert sim.positions is p and sim.velocities is v and sim.efforts is e and sim.commands is c
    assert p[1] == sim.data.qpos[1] and v[1] == sim.data.qvel[1] and v[1] != 0.0
    assert e[1] == sim.data.actuator_force[1] and sim.time == pytest.approx(0.05)
    for view in (p, v, e, sim.mimic_positions, sim.mimic_velocities):
        with pytest.raises(ValueError, match="read-only"):
            view[0] = 1.0
    assert p.dtype == v.dtype == e.dtype == c.dtype == np.float64


def test_step_allocates_nothing_that_outlives_it():
    import tracemalloc

    sim = RobotSim("ur5e")
    sim.set_mode("wrist_3_joint", "effort")  # the masked feed-forward path as well
    sim.step(10)
    tracemalloc.start()
    try:
        for _ in range(2000):
            sim.step()
        current, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert peak < 2048  # bytes over 2000 steps: nothing accumulates per step


@pytest.mark.parametrize("name, timestep", [("ur5e", 0.001), ("rrbot", 0.001), ("ur5e", 0.0005), ("ur5e", 0.005)])
def test_position_servo_reaches_a_target_within_1_mrad_in_1_5_s(name, timestep):
    sim = RobotSim(name, timestep=timestep)
    n = len(sim.joint_names)
    target = sim.positions.copy()
    target[:min(n, 6)] += 0.3 * np.array([1, -1, 1, -1, 1, -1][:min(n, 6)])
    sim.commands[:] = target
    sim.step(round(1.5 / timestep))
    np.testing.assert_allclose(sim.positions, target, atol=1e-3)
    assert np.max(np.abs(sim.velocities)) < 1e-2


def test_position_servo_respects_the_effort_limit():
    sim = RobotSim("ur5e")
    sim.commands[0] += 1.0  # a big step on the base joint saturates its 150 N m
    peak = 0.0
    for _ in range(100):
        sim.step()
        peak = max(peak, abs(sim.efforts[0]))
    assert peak == pytest.approx(150.0)


def test_effort_mode_with_gravity_torques_holds_still_and_without_falls():
    sim = RobotSim("ur5e")
    sim.set_mode(UR_JOINTS, "effort")
    q0 = sim.positions.copy()
    for _ in range(2000):
        sim.commands[:6] = sim.gravity_torques()[:6]
        sim.step()
    assert np.max(np.abs(sim.positions - q0)) < 1e-4
    assert sim.gravity_torques()[1] == pytest.approx(sim.efforts[1])
    sim.reset()
    for _ in range(300):  # commands 0: gravity wins
        sim.step()
    assert np.max(np.abs(sim.positions - q0)) > 0.1


def test_gravity_torques_match_mujocos_inverse_dynamics_at_rest():
    sim = RobotSim("ur5e")
    sim.reset(dict(zip(UR_JOINTS, [0.4, -1.0, 1.2, -0.7, 0.9, 0.3])))
    d = mujoco.MjData(sim.model)
    d.qpos[:] = sim.data.qpos
    mujoco.mj_inverse(sim.model, d)  # qacc = qvel = 0: what the joints must supply
    np.testing.assert_allclose(sim.gravity_torques()[:6], d.qfrc_inverse[:6], atol=1e-9)
    assert abs(sim.gravity_torques()[1]) > 10  # the shoulder really carries the arm


def test_velocity_mode_tracks_a_commanded_velocity():
    sim = RobotSim("ur5e")
    sim.set_mode(["shoulder_pan_joint", "wrist_3_joint"], "velocity")
    sim.commands[0], sim.commands[5] = 0.5, -1.0
    sim.step(500)
    q_half = sim.positions.copy()
    sim.step(500)
    np.testing.assert_allclose(sim.velocities[[0, 5]], [0.5, -1.0], rtol=1e-2)
    np.testing.assert_allclose((sim.positions - q_half)[[0, 5]], [0.25, -0.5], rtol=1e-2)
    assert abs(sim.positions[2] - math.pi / 2) < 1e-3  # position-mode joints keep holding


def test_set_mode_holds_the_current_position():
    sim = RobotSim("ur5e")
    sim.set_mode("elbow_joint", "velocity")
    sim.commands[2] = 0.4
    sim.step(250)
    sim.set_mode("elbow_joint", "position")
    assert sim.commands[2] == sim.positions[2] and sim.mode("elbow_joint") == "position"
    q = sim.positions[2]
    sim.step(500)
    assert abs(sim.positions[2] - q) < 0.02  # stops near where it was, no jump back
    assert sim.modes == dict.fromkeys(sim.joint_names, "position")


def test_reset_puts_joints_and_the_mimic_finger_where_asked():
    sim = RobotSim("ur5e")
    sim.step(100)
    sim.reset({"finger_joint": 0.013, "wrist_3_joint": 1.0})
    assert sim.time == 0.0 and not sim.velocities.any()
    assert sim.positions[5] == 1.0 and sim.commands[5] == 1.0  # position mode holds the new pose
    assert sim.positions[6] == 0.013 and sim.mimic_positions[0] == 0.013


def test_ft_sensor_reads_a_hanging_payload_weight_along_world_minus_z():
    base, loaded = RobotSim("ur5e"), RobotSim("ur5e", payload_mass=2.0)
    for s in (base, loaded):
        s.step(500)
        _, rot = s.link_pose("tool0")
        s.world_force = rot @ s.wrench[:3]
    np.testing.assert_allclose(base.world_force, [0, 0, -TOOL_MASS * G], atol=1e-3)
    np.testing.assert_allclose(loaded.world_force - base.world_force, [0, 0, -2.0 * G], atol=1e-3)
    # the payload hangs 0.0834 m out along tool0's z axis: torque = r x F in the flange frame
    _, rot = loaded.link_pose("tool0")
    f_payload = rot.T @ np.array([0, 0, -2.0 * G])
    expected = np.cross([0, 0, 0.0834], f_payload)
    np.testing.assert_allclose(loaded.wrench[3:] - base.wrench[3:], expected, atol=1e-3)


def test_ft_sensor_at_rest_reads_the_tool_weight_and_its_moment_in_any_pose():
    sim = RobotSim("ur5e", payload_mass=0.5)
    sim.reset(dict(zip(UR_JOINTS, [0.5, -1.2, 1.0, -0.3, 0.8, 1.1])))
    sim.step(800)
    mass, com = sim.tool_mass_properties()
    assert mass == pytest.approx(TOOL_MASS + 0.5)
    assert com[:2] == pytest.approx([0.0, 0.0], abs=1e-6) and 0.03 < com[2] < 0.0834
    _, rot = sim.link_pose("tool0")
    weight = rot.T @ np.array([0.0, 0.0, -mass * G])  # in the flange frame
    np.testing.assert_allclose(sim.wrench, np.r_[weight, np.cross(com, weight)], atol=2e-3)


def test_ft_sensor_reads_the_contact_force_of_a_table_pushing_back():
    # home pose: tool pointing down at x=-0.492, y=-0.133; fingertips at z=0.380
    table = Wall(point=(-0.49, -0.13, 0.37), normal=(0.0, 0.0, 1.0), half_size=(0.02, 0.2, 0.2))
    sim = RobotSim("ur5e", wall=table)
    free = RobotSim("ur5e")
    for s in (sim, free):
        s.commands[3] += 0.15  # wrist 1 tips the hand down into the table
        s.step(1500)
    _, rot = sim.link_pose("tool0")
    f_world = rot @ sim.wrench[:3]
    contact = -sim.contact_force("wall")  # what the table exerts on the fingers
    assert contact[2] > 5.0  # the table really pushes up on the fingers
    np.testing.assert_allclose(f_world, contact + [0, 0, -TOOL_MASS * G], atol=0.05 * np.linalg.norm(contact))
    _, rot_free = free.link_pose("tool0")
    assert (rot_free @ free.wrench[:3])[2] == pytest.approx(-TOOL_MASS * G, abs=1e-3)  # in the air: weight only


def test_gripper_closes_on_an_object_and_holds_it():
    probe = RobotSim("ur5e")
    tcp, _ = probe.link_pose("tool_center_point")
    box = GraspObject(position=tuple(tcp), half_size=(0.02, 0.02, 0.025), mass=0.1)
    sim = RobotSim("ur5e", grasp_object=box)
    sim.commands[6] = 0.0  # close completely: the object stops the fingers
    sim.step(300)  # closing at 0.2 m/s takes 0.1 s: the box drops a little meanwhile
    obj = sim.model.body("object").id
    z_grasped = sim.data.xpos[obj][2]
    sim.step(500)
    fz = []
    for _ in range(200):  # contact points come and go: average the F/T reading over 0.2 s
        sim.step()
        _, rot = sim.link_pose("tool0")
        fz.append((rot @ sim.wrench[:3])[2])
    finger = sim.joint_names.index("finger_joint")
    assert sim.positions[finger] == pytest.approx(0.02, abs=1e-3)  # half the 0.04 m box width
    assert sim.efforts[finger] == pytest.approx(-20.0)  # squeezing at the effort limit
    assert sim.mimic_joint_names == ("right_finger_joint",)
    assert sim.mimic_positions[0] == pytest.approx(sim.positions[finger], abs=1e-3)  # the coupling holds
    assert abs(sim.data.xpos[obj][2] - z_grasped) < 1e-3  # held in 0.7 s: not slipping out
    assert np.mean(fz) == pytest.approx(-(TOOL_MASS + 0.1) * G, rel=0.01)  # tool + held object


def _box_on_a_table(half=(0.015, 0.015, 0.025)):
    tcp, _ = RobotSim("ur5e").link_pose("tool_center_point")
    table_z = float(tcp[2] - 0.04)
    sim = RobotSim("ur5e", wall=Wall(point=(tcp[0], tcp[1], table_z), normal=(0.0, 0.0, 1.0), half_size=(0.02, 0.2, 0.2)),
                   grasp_object=GraspObject(position=(tcp[0], tcp[1], table_z + half[2]), half_size=half))
    return sim, sim.model.body("object").id, np.array([tcp[0], tcp[1], table_z + half[2]])


def test_a_box_on_a_table_has_its_centre_of_mass_at_its_centre_and_stays_at_rest():
    sim, obj, start = _box_on_a_table()
    np.testing.assert_allclose(sim.data.xipos[obj], start, atol=1e-12)  # was 2x pos: the box hopped and spun
    sim.step(1000)
    assert np.abs(sim.data.xpos[obj] - start).max() < 1e-4  # settles < 0.1 mm into the table, no drift
    assert np.linalg.norm(sim.data.qvel[-6:]) < 1e-3
    assert sim.data.xquat[obj][0] == pytest.approx(1.0, abs=1e-6)  # not tilted
    assert sim.touching("wall") == ["object"] and sim.touching("object") == ["wall"]
    with pytest.raises(ValueError, match="no geom 'table'"):
        sim.touching("table")


def test_fingers_closing_on_a_box_on_a_table_stop_at_its_width_and_do_not_tip_it():
    sim, obj, start = _box_on_a_table()
    finger = sim.joint_names.index("finger_joint")
    sim.commands[:] = sim.positions
    for _ in range(400):  # close at the servo's 0.2 m/s from 40 mm: ~0.13 s, then squeeze
        sim.commands[finger] = max(0.0, sim.commands[finger] - 0.0001)
        sim.step()
    sim.step(600)
    assert sim.positions[finger] == pytest.approx(0.015, abs=5e-4)  # the box is 30 mm wide: 15 mm per finger
    assert sim.mimic_positions[0] == pytest.approx(0.015, abs=5e-4)
    assert sim.efforts[finger] == pytest.approx(-20.0)  # squeezing at the effort limit
    tilt = 2 * np.degrees(np.arccos(min(1.0, abs(sim.data.xquat[obj][0]))))
    assert tilt < 1.0 and np.abs(sim.data.xpos[obj] - start).max() < 1e-3


def test_viz_draws_both_robots_into_a_recording():
    from test_viz import decode_commands

    from robocourse import viz

    scene = viz.Scene(live=False)
    drawers = {}
    sims = {"ur5e": RobotSim("ur5e"), "rrbot": RobotSim("rrbot")}
    for name, sim in sims.items():
        drawers[name] = viz.MujocoDrawer(scene, sim.model, prefix=name)
    sims["ur5e"].commands[0] += 1.0
    scene.start_recording(fps=20)
    for k in range(20):
        scene.set_time(k / 20)
        for name, sim in sims.items():
            sim.step(50)
            drawers[name].update(sim.data)
    scene.stop_recording()
    cmds = decode_commands(scene.html())
    objects = {c["path"] for c in cmds if c["type"] == "set_object"}
    for link in ("base_link/0", "shoulder_link/0", "upper_arm_link/1", "forearm_link/0", "wrist_3_link/0",
                 "gripper_hand/0", "left_finger/0", "right_finger/0"):
        assert f"/ur5e/{link}/geometry" in objects
    for link in ("base_link/0", "link1/0", "link2/0"):
        assert f"/rrbot/{link}/geometry" in objects
    [anim] = [c for c in cmds if c["type"] == "set_animation"]
    clips = {a["path"]: a["clip"] for a in anim["animations"]}
    keys = clips["/ur5e/upper_arm_link/1"]["tracks"][0]["keys"]
    assert len(keys) == 20
    moved = np.subtract(keys[-1]["value"], keys[0]["value"])
    assert np.linalg.norm(moved) > 0.1  # the base joint turned the upper arm


@pytest.mark.parametrize("call, match", [
    (lambda: RobotSim("ur5e", timestep=0.0), "timestep"),
    (lambda: RobotSim("ur5e", timestep=0.01), r"must be in \(0, 0.005\]"),
    (lambda: RobotSim("ur5e", payload_mass=-1.0), "payload_mass"),
    (lambda: RobotSim("rrbot", payload_mass=1.0), "no flange"),
    (lambda: RobotSim("ur5e", gains={"elbow": ServoGains(1, 1, 1)}), "unknown joint"),
    (lambda: ServoGains(kp=-1.0, kd=0.0, kv=0.0), "finite number >= 0"),
    (lambda: RobotSim("ur5e", wall=Wall(normal=(0, 0, 0))), "non-zero"),
    (lambda: RobotSim("ur5e").set_mode("elbow_joint", "torque"), "not one of position, velocity, effort"),
    (lambda: RobotSim("ur5e").set_mode("right_finger_joint", "position"), "not a commanded joint"),
    (lambda: RobotSim("ur5e").reset({"elbow_joint": 4.0}), "outside its limits"),
    (lambda: RobotSim("ur5e").reset([0.0] * 6), "7 finite numbers"),
    (lambda: RobotSim("ur5e").step(0), "int >= 1"),
    (lambda: RobotSim("rrbot").wrench, "no force/torque sensor"),
    (lambda: RobotSim("rrbot").tool_mass_properties(), "no force/torque sensor"),
    (lambda: RobotSim("ur5e").link_pose("hand"), "not a link"),
    (lambda: RobotSim("ur5e").contact_force("wall"), "no geom 'wall'"),
])
def test_bad_input_is_refused_with_the_rule(call, match):
    with pytest.raises((ValueError, AttributeError), match=match):
        call()


def test_a_non_finite_command_is_refused_before_stepping():
    sim = RobotSim("ur5e")
    sim.commands[2] = float("nan")
    with pytest.raises(ValueError, match=r"non-finite command \[\('elbow_joint', nan\)\]"):
        sim.step()
    assert sim.time == 0.0
