"""One Meshcat scene per notebook: live in JupyterLab, recorded and static everywhere else.

Mirrors Drake's MeshcatVisualizer workflow (set poses, StartRecording / StopRecording /
PublishRecording) on meshcat-python 0.3.2. The scene tree is kept here, in-process, with the
server's own semantics (object, transform, properties per path; delete drops a subtree), so
static HTML (meshcat's viewer JS inlined plus every drawing command, animation included) is
built without a server: headless runs start no server, open no port and never wait for a
browser. Live mode additionally forwards every command to a real meshcat server whose port
is freed at exit. meshcat's ``wait()``, ``get_image()`` and ``close()`` are never called.
"""

from __future__ import annotations

import atexit
import base64
import html as html_lib
import warnings
from pathlib import Path

import numpy as np

from ..notebook import running_as_test
from . import transforms as tf


def _import_meshcat():
    """Import meshcat with pyzmq's ioloop DeprecationWarning filtered (meshcat 0.3.2 + pyzmq >= 25)."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", category=DeprecationWarning)
        import meshcat
        import meshcat.animation
        import meshcat.commands
        import meshcat.geometry
        import umsgpack
    return meshcat, umsgpack


def _in_kernel() -> bool:
    try:
        from IPython import get_ipython
    except ImportError:
        return False
    shell = get_ipython()
    return shell is not None and shell.__class__.__name__ == "ZMQInteractiveShell"


def _rgba_material(g, rgba):
    r, gg, b, a = (float(v) for v in tf._vec(rgba, 4, "rgba"))
    if not all(0.0 <= v <= 1.0 for v in (r, gg, b, a)):
        raise ValueError(f"rgba values must be in [0, 1], got {rgba!r}")
    color = (int(r * 255) << 16) | (int(gg * 255) << 8) | int(b * 255)
    return g.MeshLambertMaterial(color=color, opacity=a, transparent=a < 1.0)


class _Node:
    __slots__ = ("children", "object", "transform", "properties", "animation")

    def __init__(self):
        self.children: dict[str, _Node] = {}
        self.object = None
        self.transform = None
        self.properties: list[bytes] = []
        self.animation = None

    def find(self, parts):
        node = self
        for p in parts:
            node = node.children.setdefault(p, _Node())
        return node

    def walk(self):
        yield self
        for child in self.children.values():
            yield from child.walk()


def _parts(path: str) -> list[str]:
    if not isinstance(path, str):
        raise ValueError(f"a scene path is a string like 'cartpole/pole', got {path!r}")
    return [p for p in path.split("/") if p]


class Scene:
    """A Meshcat scene (counterpart: Drake's ``Meshcat`` + ``MeshcatVisualizer``).

    ``live=None`` picks live mode inside an interactive Jupyter kernel and offline mode under
    test (nbmake, CI, the grader) or in a plain script. Use :func:`get_scene` to share one
    scene (one server) per notebook.
    """

    def __init__(self, live: bool | None = None, fps: int = 30):
        self._meshcat, self._msgpack = _import_meshcat()
        self.live = (_in_kernel() and not running_as_test()) if live is None else bool(live)
        self.fps = int(fps)
        self._tree = _Node()
        self._vis = None
        self._server = None
        self._anim = None
        self._frame = 0
        self._last_animation = None
        if self.live:
            self._start_server()

    # -- plumbing -------------------------------------------------------------------------
    def _start_server(self):
        from meshcat.servers.zmqserver import start_zmq_server_as_subprocess

        proc, zmq_url, web_url = start_zmq_server_as_subprocess()
        self._server = proc
        self._vis = self._meshcat.Visualizer(zmq_url=zmq_url)
        self.web_url = web_url
        atexit.register(self.close)

    def _send(self, command):
        data = command.lower()
        packed = self._msgpack.packb(data)
        kind = data["type"]
        parts = _parts(data["path"])
        if kind == "set_object":
            node = self._tree.find(parts)
            node.object, node.properties = packed, []
        elif kind == "set_transform":
            self._tree.find(parts).transform = packed
        elif kind == "set_property":
            self._tree.find(parts).properties.append(packed)
        elif kind == "set_animation":
            self._tree.animation = packed
        elif kind == "delete":
            if parts:
                parent = self._tree.find(parts[:-1])
                parent.children.pop(parts[-1], None)
            else:
                self._tree = _Node()
        if self._vis is not None:
            self._vis.window.send(command)

    def _path(self, path):
        from meshcat.path import Path as MPath

        return MPath(tuple(_parts(path)))

    def _set_object(self, path, geometry, material):
        cmds = self._meshcat.commands
        self._send(cmds.SetObject(geometry, material, self._path(path)))

    # -- primitives -----------------------------------------------------------------------
    def box(self, path, size, rgba=(0.6, 0.6, 0.6, 1.0)):
        """A box with full side lengths ``size`` (x, y, z), centred on the node ``path``."""
        g = self._meshcat.geometry
        self._set_object(f"{path}/geometry", g.Box([float(v) for v in tf._vec(size, 3, "box size")]), _rgba_material(g, rgba))

    def sphere(self, path, radius, rgba=(0.6, 0.6, 0.6, 1.0)):
        g = self._meshcat.geometry
        self._set_object(f"{path}/geometry", g.Sphere(_positive(radius, "radius")), _rgba_material(g, rgba))

    def cylinder(self, path, length, radius, rgba=(0.6, 0.6, 0.6, 1.0)):
        """A cylinder along the node's z axis (meshcat's own cylinder is along y: rotated here)."""
        g = self._meshcat.geometry
        self._set_object(f"{path}/geometry", g.Cylinder(_positive(length, "length"), _positive(radius, "radius")),
                         _rgba_material(g, rgba))
        self.set_transform(f"{path}/geometry", tf.transform(rotation=tf.rot_x(np.pi / 2)), _static=True)

    def capsule(self, path, length, radius, rgba=(0.6, 0.6, 0.6, 1.0)):
        """A capsule along z: a cylinder of ``length`` with two caps of ``radius`` (MuJoCo's capsule)."""
        self.cylinder(path, length, radius, rgba)
        g = self._meshcat.geometry
        for i, z in enumerate((-length / 2, length / 2)):
            self._set_object(f"{path}/cap{i}", g.Sphere(_positive(radius, "radius")), _rgba_material(g, rgba))
            self.set_transform(f"{path}/cap{i}", tf.transform((0.0, 0.0, z)), _static=True)

    def mesh(self, path, vertices, faces, rgba=(0.6, 0.6, 0.6, 1.0)):
        g = self._meshcat.geometry
        v = np.asarray(vertices, dtype=np.float64).reshape(-1, 3)
        f = np.asarray(faces, dtype=np.uint32).reshape(-1, 3)
        if f.size and f.max() >= len(v):
            raise ValueError(f"mesh face index {int(f.max())} is out of range for {len(v)} vertices")
        self._set_object(f"{path}/geometry", g.TriangularMeshGeometry(v, f), _rgba_material(g, rgba))

    def trace(self, path, points, rgba=(0.9, 0.2, 0.2, 1.0)):
        """A polyline through ``points`` (N x 3), e.g. a trajectory an end effector followed."""
        g = self._meshcat.geometry
        pts = np.asarray(points, dtype=np.float64)
        if pts.ndim != 2 or pts.shape[1] != 3 or len(pts) < 2:
            raise ValueError(f"trace points must be an N x 3 array with N >= 2, got shape {pts.shape}")
        if not np.all(np.isfinite(pts)):
            raise ValueError("trace points contain NaN or inf; drop those samples first")
        r, gg, b, _ = tf._vec(rgba, 4, "rgba")
        color = (int(r * 255) << 16) | (int(gg * 255) << 8) | int(b * 255)
        line = g.Line(g.PointsGeometry(np.ascontiguousarray(pts.T, dtype=np.float32)), g.LineBasicMaterial(color=color))
        self._send(self._meshcat.commands.SetObject(line, path=self._path(f"{path}/geometry")))

    def delete(self, path: str = ""):
        """Remove ``path`` and everything under it (the whole scene for "")."""
        self._send(self._meshcat.commands.Delete(self._path(path)))

    # -- poses and recording ----------------------------------------------------------------
    def set_transform(self, path, matrix, _static=False):
        m = tf.as_matrix(matrix)
        if self._anim is not None and not _static:
            clip_path = self._path(path)
            clip = self._anim.clips.get(clip_path)
            if clip is None:
                clip = self._anim.clips[clip_path] = self._meshcat.animation.AnimationClip(fps=self.fps)
            q = tf.quaternion_from_rotation(m[:3, :3])
            clip.set_property(self._frame, "position", "vector3", [float(v) for v in m[:3, 3]])
            clip.set_property(self._frame, "quaternion", "quaternion", [float(q[1]), float(q[2]), float(q[3]), float(q[0])])
            if self._vis is None and self._frame > 0:
                return  # offline: frame 0 also sets the still pose, later frames live in the clip
        self._send(self._meshcat.commands.SetTransform(m, self._path(path)))

    def set_pose(self, path, position=(0.0, 0.0, 0.0), quat_wxyz=None, rotation=None):
        """Place node ``path`` at ``position`` with a (w, x, y, z) quaternion or a 3x3 rotation."""
        self.set_transform(path, tf.transform(position, quat_wxyz, rotation))

    def set_camera(self, position, target=(0.0, 0.0, 0.0)):
        """Look at ``target`` from ``position`` (both m, world frame, z up).

        Meshcat's camera orbits the origin of ``/Cameras/default``; its position lives in the
        y-up ``rotated`` frame below it, so world (dx, dy, dz) is (dx, dz, -dy) there.
        """
        t = tf._vec(target, 3, "camera target")
        d = tf._vec(position, 3, "camera position") - t
        if not np.linalg.norm(d) > 0:
            raise ValueError(f"camera position {tuple(position)} equals the target: step back, e.g. position=(2, -2, 1.5)")
        self._send(self._meshcat.commands.SetTransform(tf.transform(t), self._path("/Cameras/default")))
        self._send(self._meshcat.commands.SetProperty("position", [float(d[0]), float(d[2]), float(-d[1])],
                                                      self._path("/Cameras/default/rotated/<object>")))

    def start_recording(self, fps: int | None = None):
        """Start recording poses into an animation (Drake: ``StartRecording``)."""
        self.fps = int(fps or self.fps)
        if self.fps <= 0:
            raise ValueError(f"fps must be positive, got {fps}")
        self._anim = self._meshcat.animation.Animation(default_framerate=self.fps)
        self._frame = 0

    @property
    def recording(self) -> bool:
        return self._anim is not None

    def set_frame(self, frame: int):
        if self._anim is None:
            raise RuntimeError("set_frame() outside a recording: call scene.start_recording() first")
        self._frame = int(frame)

    def set_time(self, t: float):
        """Select the animation frame for simulation time ``t`` seconds (frame = round(t * fps))."""
        self.set_frame(round(float(t) * self.fps))

    def stop_recording(self, play: bool = True, repetitions: int = 1):
        """Stop recording and attach the animation to the scene (Drake: ``StopRecording``)."""
        if self._anim is None:
            raise RuntimeError("stop_recording() without start_recording()")
        anim, self._anim = self._anim, None
        self._last_animation = anim
        self._send(self._meshcat.commands.SetAnimation(anim, play=play, repetitions=repetitions))
        return anim

    def frames_recorded(self) -> int:
        anim = self._anim or self._last_animation
        if anim is None:
            return 0
        keys = {k for clip in anim.clips.values() for track in clip.tracks.values() for k in track.frames}
        return len(keys)

    # -- output -----------------------------------------------------------------------------
    def html(self) -> str:
        """The whole scene (animation included) as one self-contained HTML page."""
        js_path = Path(self._meshcat.__file__).parent / "viewer" / "dist" / "main.min.js"
        commands = []
        for node in self._tree.walk():
            for blob in ([node.object] if node.object else []) + node.properties + (
                    [node.transform] if node.transform else []) + ([node.animation] if node.animation else []):
                commands.append(
                    'fetch("data:application/octet-binary;base64,' + base64.b64encode(blob).decode("ascii")
                    + '").then(r => r.arrayBuffer()).then(b => viewer.handle_command_bytearray(new Uint8Array(b)));')
        return ("<!DOCTYPE html>\n<html><head><meta charset=utf-8><title>robocourse scene</title>"
                "<style>body{margin:0}#meshcat-pane{width:100vw;height:100vh;overflow:hidden}</style></head>"
                "<body><div id=\"meshcat-pane\"></div><script>" + js_path.read_text(encoding="utf-8")
                + "</script><script>var viewer = new MeshCat.Viewer(document.getElementById(\"meshcat-pane\"));\n"
                + "\n".join(commands) + "\n</script></body></html>\n")

    def save_html(self, path) -> Path:
        path = Path(path)
        path.write_text(self.html(), encoding="utf-8")
        return path

    def static(self, height: int = 400):
        """An IPython display object with the static scene, which a saved notebook keeps."""
        from IPython.display import HTML

        doc = html_lib.escape(self.html(), quote=True)
        return HTML(f'<div style="height:{int(height)}px;width:100%;resize:both;overflow:hidden">'
                    f'<iframe srcdoc="{doc}" style="width:100%;height:100%;border:none"></iframe></div>')

    def show(self, height: int = 400):
        """Live mode: an iframe to the running server. Offline: the static scene."""
        if self._vis is not None:
            return self._vis.jupyter_cell(height=height)
        return self.static(height)

    def publish_recording(self, height: int = 400, play: bool = True, repetitions: int = 1):
        """Stop a running recording and return it as static HTML (Drake: ``PublishRecording``)."""
        if self._anim is not None:
            self.stop_recording(play=play, repetitions=repetitions)
        return self.static(height)

    def close(self):
        """Stop the live server (meshcat's own ``Visualizer.close()`` is broken in 0.3.2)."""
        if self._server is not None and self._server.poll() is None:
            self._server.kill()
            self._server.wait()
        self._server = None
        self._vis = None


def _positive(value, name) -> float:
    v = float(value)
    if not (np.isfinite(v) and v > 0):
        raise ValueError(f"{name} must be a positive finite number of metres, got {value!r}")
    return v


_SCENE: Scene | None = None


def get_scene(live: bool | None = None) -> Scene:
    """The notebook's one scene (and one server, in live mode); created on first call."""
    global _SCENE
    if _SCENE is None:
        _SCENE = Scene(live=live)
    return _SCENE


def reset_scene() -> None:
    """Close and forget the shared scene (tests)."""
    global _SCENE
    if _SCENE is not None:
        _SCENE.close()
    _SCENE = None

