"""The viewer: float64 transforms, static HTML with scene + animation, Chromium, live server."""

from __future__ import annotations

import base64
import re
import socket
import urllib.request

import numpy as np
import pytest
from scene_shots import needs_chromium, screenshot

from robocourse import viz
from robocourse.viz import transforms as tf

PENDULUM = """
<mujoco><worldbody>
  <geom name="floor" type="plane" size="1 1 .1"/>
  <body name="pole" pos="0 0 1"><joint name="hinge" type="hinge" axis="0 1 0"/>
    <geom name="rod" type="capsule" fromto="0 0 0 0 0 -0.5" size="0.02" rgba="0.1 0.3 0.9 1"/>
    <geom name="bob" type="sphere" pos="0 0 -0.5" size="0.06" rgba="0.9 0.2 0.1 1"/>
    <geom name="plate" type="box" pos="0 0 -0.25" size=".05 .05 .01"/>
    <geom name="drum" type="cylinder" pos="0 0 -.1" size=".03 .02"/>
  </body></worldbody></mujoco>"""


def decode_commands(page: str) -> list[dict]:
    import umsgpack

    return [umsgpack.unpackb(base64.b64decode(b)) for b in re.findall(r"octet-binary;base64,([A-Za-z0-9+/=]+)", page)]


def test_quaternion_round_trip_and_known_rotation():
    rng = np.random.default_rng(0)
    for _ in range(50):
        q = rng.normal(size=4)
        q /= np.linalg.norm(q)
        q = q if q[0] >= 0 else -q
        np.testing.assert_allclose(tf.quaternion_from_rotation(tf.rotation_from_quaternion(q)), q, atol=1e-12)
    np.testing.assert_allclose(tf.rotation_from_quaternion([np.cos(np.pi / 4), 0, 0, np.sin(np.pi / 4)]),
                               tf.rot_z(np.pi / 2), atol=1e-12)


@pytest.mark.parametrize("bad, match", [((1, 2), "3 numbers"), ((0, np.nan, 0), "finite")])
def test_bad_positions_are_refused(bad, match):
    with pytest.raises(ValueError, match=match):
        tf.transform(bad)


def test_a_non_rotation_is_refused():
    with pytest.raises(ValueError, match="not a proper rotation"):
        tf.transform(rotation=np.zeros((3, 3)))
    with pytest.raises(ValueError, match="not a proper rotation"):
        tf.transform(rotation=np.diag([1.0, 1.0, -1.0]))


def test_float32_and_lists_are_accepted_as_float64():
    m = tf.transform(np.array([1, 2, 3], dtype=np.float32), quat_wxyz=[1, 0, 0, 0])
    assert m.dtype == np.float64 and m[2, 3] == 3.0


@pytest.fixture
def recorded():
    import mujoco

    model = mujoco.MjModel.from_xml_string(PENDULUM)
    data = mujoco.MjData(model)
    data.qpos[0] = 0.6
    scene = viz.Scene(live=False)
    drawer = viz.MujocoDrawer(scene, model, prefix="pendulum")
    with pytest.raises(ValueError, match="mj_forward"):
        drawer.update(data)  # poses not computed yet
    mujoco.mj_forward(model, data)
    scene.start_recording(fps=30)
    for k in range(45):
        scene.set_time(k / 30)
        while data.time < k / 30:
            mujoco.mj_step(model, data)
        drawer.update(data)
    scene.trace("trail", np.c_[np.linspace(0, 1, 20), np.zeros(20), np.ones(20)])
    scene.stop_recording()
    return scene, drawer


def test_static_html_holds_scene_and_animation(recorded):
    scene, drawer = recorded
    page = scene.html()
    assert "MeshCat.Viewer" in page and len(page) > 500_000  # the viewer JS is inlined
    cmds = decode_commands(page)
    objects = {c["path"] for c in cmds if c["type"] == "set_object"}
    for geom in ("floor", "rod", "bob", "plate", "drum"):
        assert f"/pendulum/{geom}/geometry" in objects
    assert "/pendulum/rod/cap0" in objects and "/trail/geometry" in objects
    [anim] = [c for c in cmds if c["type"] == "set_animation"]
    clips = {a["path"]: a["clip"] for a in anim["animations"]}
    assert set(clips) == {"/pendulum/rod", "/pendulum/bob", "/pendulum/plate", "/pendulum/drum"}  # the floor never moves
    keys = clips["/pendulum/bob"]["tracks"][0]["keys"]
    assert [k["time"] for k in keys] == list(range(45)) and clips["/pendulum/bob"]["fps"] == 30
    xs = [k["value"][0] for k in keys]
    assert max(xs) - min(xs) > 0.3  # the bob really swings in the recording
    assert scene.frames_recorded() == 45


def test_static_display_object_escapes_the_page(recorded):
    scene, _ = recorded
    html = scene.static(height=300).data
    assert html.startswith('<div style="height:300px') and "srcdoc=" in html and "<script>" not in html


def test_delete_removes_a_subtree(recorded):
    scene, _ = recorded
    scene.delete("pendulum")
    paths = {c["path"] for c in decode_commands(scene.html()) if c["type"] == "set_object"}
    assert not any(p.startswith("/pendulum") for p in paths) and "/trail/geometry" in paths


def test_recording_misuse_is_clear():
    scene = viz.Scene(live=False)
    with pytest.raises(RuntimeError, match="start_recording"):
        scene.set_frame(3)
    with pytest.raises(RuntimeError, match="without start_recording"):
        scene.stop_recording()
    with pytest.raises(ValueError, match="N x 3"):
        scene.trace("t", [[0, 0, 0]])
    with pytest.raises(ValueError, match="rgba values"):
        scene.box("b", (1, 1, 1), (2, 0, 0, 1))


def test_headless_scene_starts_no_server():
    assert viz.Scene().live is False and viz.Scene()._server is None


@needs_chromium
def test_chromium_renders_the_recording(recorded, tmp_path):
    scene, _ = recorded
    img = screenshot(scene, tmp_path)
    # meshcat's default background is a blue gradient; our red bob (0.9, 0.2, 0.1) must show up
    red = (img[..., 0] > 0.6) & (img[..., 1] < 0.35) & (img[..., 2] < 0.35)
    assert red.sum() > 20, f"only {red.sum()} bob-coloured pixels: the scene did not render"


def _port_open(port: int) -> bool:
    with socket.socket() as s:
        s.settimeout(0.5)
        return s.connect_ex(("127.0.0.1", port)) == 0


def test_live_mode_serves_the_viewer_and_frees_its_port():
    scene = viz.Scene(live=True)
    try:
        port = int(re.search(r":(\d+)/", scene.web_url).group(1))
        scene.box("live/box", (0.1, 0.1, 0.1))  # goes to the server and to the local tree
        body = urllib.request.urlopen(scene.web_url, timeout=10).read().decode()
        assert "meshcat" in body.lower()
        assert "iframe" in scene.show().data
    finally:
        scene.close()
    assert not _port_open(port)
