"""Issue 17's "done when": headless-Chromium screenshots of chapter 2's pendulum and chapter 3's
car (the navigation recording, the teleop's recorded fallback, the live teleop view) show the
robot large and inside the frame, at the recording's first and last frames. The scenes are
built by the same calls the notebooks make (the real MuJoCo models, MujocoDrawer, sim.run,
robocourse.mycar.view.record_navigation, live_teleop)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scene_shots import (
    colour_mask,
    largest_blob,
    needs_chromium,
    notebook_size,
    pixel_of,
    screen_reach,
    screenshot,
)

from robocourse import viz

pytestmark = needs_chromium

#: the models' colours (rgba in robocourse.sim.models.pendulum_xml and robocourse.sim.car.car_xml)
BOB_RGBA = (0.9, 0.3, 0.1, 1)
CHASSIS_RGBA = (0.2, 0.5, 0.9, 1)

#: past the end of any recording here: the animation clamps at its last frame
END_S = 1e3


def inside(bbox, img, margin=3):
    """The blob does not touch the screenshot's edges (so it is not cut off)."""
    r0, r1, c0, c1 = bbox
    return r0 >= margin and c0 >= margin and r1 <= img.shape[0] - 1 - margin and c1 <= img.shape[1] - 1 - margin


def covers(bbox, pixel):
    """``pixel`` (row, col) lies within the blob's bounding box: the thing is drawn where it was."""
    r0, r1, c0, c1 = bbox
    return r0 <= pixel[0] <= r1 and c0 <= pixel[1] <= c1


def pendulum_scene(seconds=2.0):
    """Chapter 2, section 7's second scene: the seed pendulum released at 0.3 rad under a PD torque."""
    import mujoco

    from robocourse.sim import models
    from robocourse.sim import run as sim_run

    pend = models.pendulum(timestep=0.001)
    pdata = mujoco.MjData(pend)
    pdata.qpos[0] = 0.3
    mujoco.mj_forward(pend, pdata)
    bob = mujoco.mj_name2id(pend, mujoco.mjtObj.mjOBJ_GEOM, "bob")
    first = pdata.geom_xpos[bob].copy()
    pivot = pdata.xpos[mujoco.mj_name2id(pend, mujoco.mjtObj.mjOBJ_BODY, "arm")].copy()
    scene = viz.Scene(live=False)
    drawer = viz.MujocoDrawer(scene, pend, prefix="pendulum")
    scene.start_recording(fps=30)
    sim_run(pend, pdata, lambda t, d: [-(0.1 * d.qpos[0] + 0.02 * d.qvel[0])], duration=seconds,
            control_period=0.001, drawer=drawer, draw_every=33)
    scene.stop_recording()
    return scene, pivot, first, pdata.geom_xpos[bob].copy()


def test_chromium_shows_the_pendulum_tall_and_inside_the_frame_first_to_last(tmp_path):
    scene, pivot, bob_first, bob_last = pendulum_scene()
    size = notebook_size(300)                                  # chapter 2 publishes it 300 px tall
    centres = []
    for name, at_s, bob_world in (("first", 0.0, bob_first), ("last", END_S, bob_last)):
        img = screenshot(scene, tmp_path, name, at_s=at_s, size=size)
        area, bbox, centre = largest_blob(colour_mask(img, BOB_RGBA))
        assert area > 0.001 * img[..., 0].size and inside(bbox, img), (name, area, bbox)  # the 3 cm bob: ~20 px across
        assert covers(bbox, pixel_of(scene, bob_world, size)), (name, bbox, pixel_of(scene, bob_world, size))
        centres.append(centre)
    assert screen_reach(scene, size[0] / size[1]) <= 0.8 + 1e-6   # every recorded pose inside 80 % of the view
    top, bot = pixel_of(scene, pivot, size), pixel_of(scene, bob_first, size)
    assert math.dist(top, bot) > 0.5 * size[1]                 # the arm spans over half the view's height
    assert math.dist(*centres) > 2 * (bbox[3] - bbox[2] + 1)   # the swing is seen: the bob moved 2+ of its widths


@pytest.fixture(scope="module")
def car():
    """Chapter 3 at section 5b: the launched car, driven once to (0.5, -0.2) in odom (section 5a's
    goal), ready for the recorded drive home."""
    from robocourse.bus import introspection
    from robocourse.mycar.launch import launch
    from robocourse.mycar.msgs import NavigateToPose

    car = launch(overrides={"navigation_server": {"timeout": 20.0}})
    car.context.log_to_stderr = False
    goal = {"target_pose": {"header": {"frame_id": "odom"}, "pose": {"position": {"x": 0.5, "y": -0.2},
                                                                     "orientation": {"w": 1.0}}}}
    status, _result, _ = introspection.action_send_goal(car.context, "/navigate_to_pose", NavigateToPose, goal,
                                                        car.executor, feedback=False, quiet=True)
    assert status == 4                                         # STATUS_SUCCEEDED
    yield car
    car.context.try_shutdown()


def chassis_height(car):
    import mujoco

    sim = car.simulator.car
    return float(sim.data.geom_xpos[mujoco.mj_name2id(sim.model, mujoco.mjtObj.mjOBJ_GEOM, "chassis")][2])


def assert_car_large_and_inside(scene, img, where, name, min_fraction):
    """The chassis' colour covers ``min_fraction`` of the view in one piece, uncut, where the car was."""
    area, bbox, _centre = largest_blob(colour_mask(img, CHASSIS_RGBA))
    size = (img.shape[1], img.shape[0])
    assert area > min_fraction * img.shape[0] * img.shape[1] and inside(bbox, img), (name, area / img[..., 0].size, bbox)
    assert covers(bbox, pixel_of(scene, where, size)), (name, bbox, pixel_of(scene, where, size))
    return area / img[..., 0].size


def test_chromium_shows_the_navigation_recording_with_the_car_large_first_to_last(car, tmp_path):
    from robocourse.mycar.view import record_navigation

    scene = viz.Scene(live=False)
    home = {"target_pose": {"header": {"frame_id": "odom"},
                            "pose": {"position": {"x": 0.0, "y": 0.0}, "orientation": {"z": 1.0, "w": 0.0}}}}
    _view, status, _result, rec = record_navigation(car, home, scene, height=350)   # chapter 3's cell, the same call
    assert status == 4 and len(rec.trail) > 20
    size = notebook_size(350)
    assert screen_reach(scene, size[0] / size[1]) <= 0.8 + 1e-6   # framed for the notebook's view: all inside
    z = chassis_height(car)
    for name, at_s, (x, y, _) in (("first", 0.0, rec.trail[0]), ("last", END_S, rec.trail[-1])):
        img = screenshot(scene, tmp_path, name, at_s=at_s, size=size)
        assert_car_large_and_inside(scene, img, (x, y, z), name, min_fraction=0.03)
    start, end = pixel_of(scene, (*rec.trail[0][:2], z), size), pixel_of(scene, (*rec.trail[-1][:2], z), size)
    assert math.dist(start, end) > 0.3 * size[0]               # the drive crosses a third of the view


def test_chromium_shows_the_teleop_fallback_recording_with_the_car_large_first_to_last(car, tmp_path):
    from robocourse.mycar.teleop_live import live_teleop

    scene = viz.Scene(live=False)
    teleop, _view = live_teleop(car, scene)                     # no widgets here: the scripted, recorded drive
    teleop.stop()
    assert teleop.watchdog_trips == 1
    size = notebook_size(380)                                   # drive_recorded's view height
    assert screen_reach(scene, size[0] / size[1]) <= 0.8 + 1e-6
    z = chassis_height(car)
    trail = teleop.recording.trail
    for name, at_s, (x, y, _) in (("fallback_first", 0.0, trail[0]), ("fallback_last", END_S, trail[-1])):
        img = screenshot(scene, tmp_path, name, at_s=at_s, size=size)
        assert_car_large_and_inside(scene, img, (x, y, z), name, min_fraction=0.015)


def test_chromium_shows_the_live_teleop_view_following_the_car(car, tmp_path):
    """The background loop's draw() while "forward" is held for 4 s (0.8 m): the camera follows
    in steps, so the car keeps its size and stays near the middle; the page keeps draw()'s camera."""
    from robocourse.mycar.teleop_live import LIVE_VIEW_DIRECTION, LiveTeleop

    size, z = notebook_size(380), chassis_height(car)
    live = LiveTeleop(car, viz.Scene(live=False))
    live.draw()
    live.press("w", hold_s=4.0)
    for _ in range(round(4.4 / live.tick_s)):                   # the hold, then the watchdog's stop
        live.step()
        live.draw()
    live.stop()
    pos, target = live.scene.camera
    assert np.allclose((pos - target) / np.linalg.norm(pos - target), LIVE_VIEW_DIRECTION)
    live.scene.set_camera(pos, target)
    x, y, _ = car.simulator.car.pose()
    img = screenshot(live.scene, tmp_path, "live", size=size)
    assert_car_large_and_inside(live.scene, img, (x, y, z), "live", min_fraction=0.01)
    row, col = pixel_of(live.scene, (x, y, z), size)
    assert abs(col - size[0] / 2) < 0.3 * size[0] and abs(row - size[1] / 2) < 0.3 * size[1], (row, col)
