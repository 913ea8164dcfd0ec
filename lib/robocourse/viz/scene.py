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
import contextlib
import html as html_lib
import io
import math
import os
import warnings
from pathlib import Path

import numpy as np

from ..notebook import running_as_test
from . import framing
from . import transforms as tf

#: the width a notebook output area gives a scene (JupyterLab at common window sizes: 800-1100 px);
#: the static view frames for this width over its height, the narrow end so nothing is cut off
CELL_WIDTH_PX = 800

#: scene path of the framing helpers (grid, scale bar): never framed themselves
VIEW_PATH = "robocourse_view"


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


def _interactive_frontend() -> bool:
    """A kernel a person looks at: started by a Jupyter server for a session (JupyterLab,
    Notebook, VS Code set ``JPY_SESSION_NAME``), not by ``jupyter nbconvert --execute`` or
    papermill, whose saved outputs must not point at a server that is gone by then."""
    return _in_kernel() and bool(os.environ.get("JPY_SESSION_NAME"))


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

    ``live=None`` picks live mode inside a Jupyter kernel a person is looking at (started by a
    Jupyter server) and offline mode under test (nbmake, CI, the grader), under
    ``nbconvert --execute``/papermill, or in a plain script. Use :func:`get_scene` to share one
    scene (one server) per notebook.
    """

    def __init__(self, live: bool | None = None, fps: int = 30):
        self._meshcat, self._msgpack = _import_meshcat()
        self.live = (_interactive_frontend() and not running_as_test()) if live is None else bool(live)
        self.fps = int(fps)
        self._tree = _Node()
        self._vis = None
        self._server = None
        self._anim = None
        self._frame = 0
        self._last_animation = None
        self._animation_options = (True, 1)      # (play, repetitions) of the last stop_recording
        self._radius: dict[str, float] = {}      # node path -> bounding radius of its geometry (m)
        self._where: dict[str, np.ndarray] = {}  # moving node path -> last position outside recordings
        self._fixed: set[str] = set()            # world-fixed nodes: framed only if small (a post, not a floor)
        self._fixed_where: dict[str, np.ndarray] = {}
        self._extra: dict[str, np.ndarray] = {}  # traces: points that belong to the motion
        self.camera_auto = True                  # frame the motion on show()/html() until set_camera()
        self.view_direction = None               # optional (from target towards camera) for framing
        self.floor_z = None                      # m: where the grid goes (MujocoDrawer sets it)
        self.camera = None                       # (position, target) last placed, world m
        self.grid_spacing = None                 # m, of the grid drawn by the last framing
        self.scale_length = None                 # m, of the scale bar drawn by the last framing
        if self.live:
            self._start_server()

    # -- plumbing -------------------------------------------------------------------------
    def _start_server(self):
        from meshcat.servers.zmqserver import start_zmq_server_as_subprocess

        proc, zmq_url, web_url = start_zmq_server_as_subprocess()
        self._server = proc
        with contextlib.redirect_stdout(io.StringIO()):  # meshcat prints its URL: dead once the kernel stops
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
            self._forget(parts)
            if parts:
                parent = self._tree.find(parts[:-1])
                parent.children.pop(parts[-1], None)
            else:
                self._tree = _Node()
        if self._vis is not None:
            self._vis.window.send(command)

    def _forget(self, parts):
        prefix = "/" + "/".join(parts)
        for book in (self._radius, self._where, self._extra, self._fixed_where):
            for key in [k for k in book if k == prefix or k.startswith(prefix.rstrip("/") + "/")]:
                del book[key]
        self._fixed = {k for k in self._fixed if not (k == prefix or k.startswith(prefix.rstrip("/") + "/"))}

    def _note_size(self, path, radius):
        """Remember the bounding radius of the geometry drawn at node ``path`` (for framing)."""
        if not _parts(path) or _parts(path)[0] == VIEW_PATH:
            return
        self._radius["/" + "/".join(_parts(path))] = float(radius)

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
        sz = [float(v) for v in tf._vec(size, 3, "box size")]
        self._set_object(f"{path}/geometry", g.Box(sz), _rgba_material(g, rgba))
        self._note_size(path, 0.5 * math.sqrt(sum(v * v for v in sz)))

    def sphere(self, path, radius, rgba=(0.6, 0.6, 0.6, 1.0)):
        g = self._meshcat.geometry
        self._set_object(f"{path}/geometry", g.Sphere(_positive(radius, "radius")), _rgba_material(g, rgba))
        self._note_size(path, radius)

    def cylinder(self, path, length, radius, rgba=(0.6, 0.6, 0.6, 1.0)):
        """A cylinder along the node's z axis (meshcat's own cylinder is along y: rotated here)."""
        g = self._meshcat.geometry
        self._set_object(f"{path}/geometry", g.Cylinder(_positive(length, "length"), _positive(radius, "radius")),
                         _rgba_material(g, rgba))
        self.set_transform(f"{path}/geometry", tf.transform(rotation=tf.rot_x(np.pi / 2)), _static=True)
        self._note_size(path, math.hypot(length / 2, radius))

    def capsule(self, path, length, radius, rgba=(0.6, 0.6, 0.6, 1.0)):
        """A capsule along z: a cylinder of ``length`` with two caps of ``radius`` (MuJoCo's capsule)."""
        self.cylinder(path, length, radius, rgba)
        g = self._meshcat.geometry
        for i, z in enumerate((-length / 2, length / 2)):
            self._set_object(f"{path}/cap{i}", g.Sphere(_positive(radius, "radius")), _rgba_material(g, rgba))
            self.set_transform(f"{path}/cap{i}", tf.transform((0.0, 0.0, z)), _static=True)
        self._note_size(path, length / 2 + radius)

    def mesh(self, path, vertices, faces, rgba=(0.6, 0.6, 0.6, 1.0)):
        g = self._meshcat.geometry
        v = np.asarray(vertices, dtype=np.float64).reshape(-1, 3)
        f = np.asarray(faces, dtype=np.uint32).reshape(-1, 3)
        if f.size and f.max() >= len(v):
            raise ValueError(f"mesh face index {int(f.max())} is out of range for {len(v)} vertices")
        self._set_object(f"{path}/geometry", g.TriangularMeshGeometry(v, f), _rgba_material(g, rgba))
        if len(v):
            self._note_size(path, float(np.linalg.norm(v, axis=1).max()))

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
        if _parts(path) and _parts(path)[0] != VIEW_PATH:
            self._extra["/" + "/".join(_parts(path))] = pts

    def delete(self, path: str = ""):
        """Remove ``path`` and everything under it (the whole scene for ""), recorded motion included.

        A robot drawn again at the same path after a delete is a new robot: the old recording's
        clips for that path are dropped (and the remaining animation re-sent), so neither the
        camera framing nor the viewer (which would replay the old clip, clamped at its last frame,
        over the new poses) still sees the old motion."""
        parts = _parts(path)
        self._send(self._meshcat.commands.Delete(self._path(path)))

        def gone(anim):
            return [k for k in anim.clips if tuple(k.entries[:len(parts)]) == tuple(parts)]

        if self._anim is not None:
            for key in gone(self._anim):
                del self._anim.clips[key]
        if self._last_animation is not None and not parts:
            self._last_animation = None              # the whole tree (its animation too) was reset
        elif self._last_animation is not None and gone(self._last_animation):
            for key in gone(self._last_animation):
                del self._last_animation.clips[key]
            play, repetitions = self._animation_options
            self._send(self._meshcat.commands.SetAnimation(self._last_animation, play=play, repetitions=repetitions))

    # -- poses and recording ----------------------------------------------------------------
    def set_transform(self, path, matrix, _static=False):
        m = tf.as_matrix(matrix)
        key = "/" + "/".join(_parts(path))
        if _static:
            if key in self._radius:
                self._fixed.add(key)                 # a world-fixed geom (floor, rail, post): placed once
                self._fixed_where[key] = m[:3, 3].copy()
        elif self._anim is None:
            self._where[key] = m[:3, 3].copy()
        else:
            self._where.setdefault(key, m[:3, 3].copy())
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

    def set_camera(self, position, target=(0.0, 0.0, 0.0), _auto=False):
        """Look at ``target`` from ``position`` (both m, world frame, z up).

        Meshcat's camera lives in the y-up ``rotated`` frame, so world (x, y, z) is (x, z, -y)
        there; the orbit target is set by JavaScript (see :meth:`_camera_js`).
        A camera set here is kept: the automatic framing (:meth:`frame`) stops until called again.
        """
        t = tf._vec(target, 3, "camera target")
        d = tf._vec(position, 3, "camera position") - t
        if not np.linalg.norm(d) > 0:
            raise ValueError(f"camera position {tuple(position)} equals the target: step back, e.g. position=(2, -2, 1.5)")
        if not _auto:
            self.camera_auto = False
        self.camera = (t + d, t)
        self._send(self._meshcat.commands.SetTransform(np.eye(4), self._path("/Cameras/default")))
        p = t + d
        self._send(self._meshcat.commands.SetProperty("position", [float(p[0]), float(p[2]), float(-p[1])],
                                                      self._path("/Cameras/default/rotated/<object>")))
        self._send_camera()

    def _send_camera(self):
        """The live viewer gets the camera as JavaScript through meshcat's ``set_control`` (whose
        callback string the viewer evaluates); the local tree keeps only the JS for html()."""
        if self._vis is None:
            return
        sock = self._vis.window.zmq_socket
        for data in ({"type": "set_control", "name": "robocourse camera", "callback": self._camera_js()},
                     {"type": "delete_control", "name": "robocourse camera"}):
            sock.send_multipart([b"set_property", b"/robocourse_camera", self._msgpack.packb(data)])
            sock.recv()

    def move_camera_target(self, target):
        """Move the point the camera orbits, keeping its offset (a camera that follows a robot live)."""
        t = tf._vec(target, 3, "camera target")
        if self.camera is None:
            raise RuntimeError("move_camera_target() before the camera was placed: call frame() or set_camera() first")
        pos, old = self.camera
        self.camera = (pos - old + t, t)
        self._send_camera()

    # -- framing: camera, grid and scale from the motion -------------------------------------
    def motion_points(self) -> tuple[np.ndarray, np.ndarray]:
        """Every position a moving node took (recording included) plus traces (N x 3, m), and
        the bounding radius of the geometry at each (N,): what :meth:`frame` fits in the view."""
        anim = self._anim or self._last_animation
        pts, pad = [], []
        recorded = {}
        if anim is not None:
            for clip_path, clip in anim.clips.items():
                key = clip_path.lower()
                track = clip.tracks.get("position")
                if track is not None and track.values:
                    recorded[key] = np.asarray(track.values, np.float64).reshape(-1, 3)
        for key, radius in self._radius.items():
            if key in self._fixed:
                continue
            where = [recorded[key]] if key in recorded else []
            if key in self._where:
                where.append(self._where[key][None, :])
            for w in where:
                pts.append(w)
                pad.append(np.full(len(w), radius))
        for w in self._extra.values():
            pts.append(w)
            pad.append(np.zeros(len(w)))
        if pts:
            span = float(np.ptp(np.concatenate(pts), axis=0).max() + 2 * max(float(p.max()) for p in pad))
            for key in self._fixed:
                if key in self._fixed_where and self._radius.get(key, np.inf) <= 0.5 * span:
                    pts.append(self._fixed_where[key][None, :])
                    pad.append(np.array([self._radius[key]]))
        if not pts:
            return np.zeros((0, 3)), np.zeros(0)
        return np.concatenate(pts), np.concatenate(pad)

    def frame(self, direction=None, fill: float = 0.8, grid: bool = True, aspect: float = framing.ASPECT):
        """Place the camera so every recorded/current motion fills the view, and lay a grid
        (1-2-5 spacing, about ten squares across the motion) plus a labelled scale bar on the floor.

        ``direction`` (world vector from the motion towards the camera) overrides the automatic
        choice (side-on for motion in a vertical plane, 55 deg from above for motion on the
        floor). Returns ``(position, target)``. Called by :meth:`html` and :meth:`show` unless
        :meth:`set_camera` placed the camera by hand. ``aspect``: the view's width / height that
        the framing plans for (the notebook's static view passes its own).
        """
        pts, pad = self.motion_points()
        if len(pts) == 0:
            return None
        if direction is not None:
            self.view_direction = direction
        pos, target = framing.frame_motion(pts, pad=pad, fill=fill, direction=self.view_direction, aspect=aspect)
        self.set_camera(pos, target, _auto=True)
        self.camera_auto = True
        if grid:
            self._draw_grid(pts, pad, pos, target, aspect)
        return pos, target

    @staticmethod
    def _scale_bar_place(pts, pad, pos, target, right, length, width, height, z, aspect=framing.ASPECT):
        """A floor point for the scale bar's left end where bar and label are on screen and as far
        as possible (on screen) from where the robot went."""
        fwd = np.array([target[0] - pos[0], target[1] - pos[1], 0.0])
        fwd /= np.linalg.norm(fwd)
        rel = pts - target
        xs = rel @ right
        ds = rel @ fwd
        left, rgt = float((xs - pad).min()), float((xs + pad).max())
        near, far = float((ds - pad).min()), float((ds + pad).max())
        seen, depth = framing.project(pts, pos, target, aspect=aspect)
        reach = pad / (depth * math.tan(math.radians(framing.FOV_DEG) / 2))   # the robot's size on screen
        best, best_score = None, -1.0
        for along in (left, rgt - width, (left + rgt - width) / 2):
            for depth in (near, 0.0, far):
                start = target + right * along + fwd * depth
                start[2] = z
                ends = np.array([start, start + right * width, start + right * width + [0, 0, height * 1.2],
                                 start + [0, 0, height * 1.2]])
                try:
                    ndc, _ = framing.project(ends, pos, target, aspect=aspect)
                except ValueError:
                    continue
                if np.abs(ndc).max() > 0.95:
                    continue
                score = float(np.min(np.linalg.norm(seen[:, None, :] - ndc[None, :, :], axis=2) - reach[:, None]))
                if score > best_score:
                    best, best_score = start, score
        if best is None:  # nothing fits on screen: the left edge at the target's depth
            best = target + right * left
            best[2] = z
        return best

    def _draw_grid(self, pts, pad, pos, target, aspect=framing.ASPECT):
        g, cmds = self._meshcat.geometry, self._meshcat.commands
        lo, hi = (pts - pad[:, None]).min(0), (pts + pad[:, None]).max(0)
        span = float(max(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2], 1e-3))
        s = framing._nice(span / 8)
        x0, x1 = math.floor((lo[0] - s) / s) * s, math.ceil((hi[0] + s) / s) * s
        y0, y1 = math.floor((lo[1] - s) / s) * s, math.ceil((hi[1] + s) / s) * s
        # on the floor the drawer reported (just above a MuJoCo plane, drawn 2 mm thick), else at z = 0
        # or under the lowest point of the motion
        floor = self.floor_z if self.floor_z is not None else min(0.0, float(pts[:, 2].min()))
        z = floor + 0.002
        segs = []
        for x in np.arange(x0, x1 + s / 2, s):
            segs += [(x, y0, z), (x, y1, z)]
        for y in np.arange(y0, y1 + s / 2, s):
            segs += [(x0, y, z), (x1, y, z)]
        lines = g.LineSegments(g.PointsGeometry(np.ascontiguousarray(np.array(segs, np.float32).T)),
                               g.LineBasicMaterial(color=0x505050))
        self._send(cmds.Delete(self._path(VIEW_PATH)))
        self._send(cmds.SetObject(lines, path=self._path(f"{VIEW_PATH}/grid")))
        self._send(cmds.SetProperty("visible", False, self._path("/Grid")))   # meshcat's fixed 0.5 m grid
        # the scale bar: along the camera's horizontal "right", where it is seen beside the motion
        right, up, fwd = framing.camera_axes(pos, target)
        length = framing._nice(span / 3)
        thick = length / 30
        yaw = math.atan2(right[1], right[0])
        rot = tf.rot_z(yaw)
        h = length * 0.3
        view_aspect = aspect
        png, aspect = _label_png(f"bar {_length_text(length)}\ngrid {_length_text(s)}")
        start = self._scale_bar_place(pts, pad, pos, target, right, length, max(length, h * aspect), h, z + thick / 2,
                                      view_aspect)
        centre = start + rot @ np.array([length / 2, 0.0, 0.0])
        self._send(cmds.SetObject(g.Box([length, thick * 2, thick]), _rgba_material(g, (0.05, 0.05, 0.05, 1.0)),
                                  self._path(f"{VIEW_PATH}/scale_bar")))
        self._send(cmds.SetTransform(tf.transform(centre, rotation=rot), self._path(f"{VIEW_PATH}/scale_bar")))
        label = g.Mesh(g.Box([h * aspect, h, 1e-4]), g.MeshBasicMaterial(
            map=g.ImageTexture(image=g.PngImage(png)), transparent=True))
        self._send(cmds.SetObject(label, path=self._path(f"{VIEW_PATH}/scale_label")))
        # the label faces the camera (its plane spanned by the view's right and up), so it reads
        # from a camera high above the floor too, where an upright label is seen edge-on
        lpos = start + rot @ np.array([h * aspect / 2, 0.0, 0.0]) + np.array([0.0, 0.0, thick]) + up * (h * 0.6)
        facing = np.column_stack([right, up, -fwd])
        self._send(cmds.SetTransform(tf.transform(lpos, rotation=facing),
                                     self._path(f"{VIEW_PATH}/scale_label")))
        # meshcat's world axes (0.5 m long by default) drawn as long as the scale bar
        self._send(cmds.SetTransform(np.diag([length / 0.5, length / 0.5, length / 0.5, 1.0]), self._path("/Axes")))
        self.grid_spacing, self.scale_length = s, length

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
        self._animation_options = (play, repetitions)
        self._send(self._meshcat.commands.SetAnimation(anim, play=play, repetitions=repetitions))
        return anim

    def frames_recorded(self) -> int:
        anim = self._anim or self._last_animation
        if anim is None:
            return 0
        keys = {k for clip in anim.clips.values() for track in clip.tracks.values() for k in track.frames}
        return len(keys)

    # -- output -----------------------------------------------------------------------------
    def html(self, aspect: float = framing.ASPECT) -> str:
        """The whole scene (animation included) as one self-contained HTML page, framed (unless
        the camera was set by hand) for a view ``aspect`` wide per unit of height."""
        if self.camera_auto:
            self.frame(aspect=aspect)
        js_path = Path(self._meshcat.__file__).parent / "viewer" / "dist" / "main.min.js"
        commands = []
        for node in self._tree.walk():
            for blob in ([node.object] if node.object else []) + node.properties + (
                    [node.transform] if node.transform else []) + ([node.animation] if node.animation else []):
                commands.append('run("data:application/octet-binary;base64,' + base64.b64encode(blob).decode("ascii") + '");')
        return ("<!DOCTYPE html>\n<html><head><meta charset=utf-8><title>robocourse scene</title>"
                "<style>body{margin:0}#meshcat-pane{width:100vw;height:100vh;overflow:hidden}</style></head>"
                "<body><div id=\"meshcat-pane\"></div><script>" + js_path.read_text(encoding="utf-8")
                + "</script><script>var viewer = new MeshCat.Viewer(document.getElementById(\"meshcat-pane\"));\n"
                "function run(url) { const s = atob(url.slice(url.indexOf(',') + 1)); const b = new Uint8Array(s.length);\n"
                "  for (let i = 0; i < s.length; i++) b[i] = s.charCodeAt(i);\n  viewer.handle_command_bytearray(b); }\n"
                + "\n".join(commands) + "\n" + (self._camera_js() or "") + "\n</script></body></html>\n")

    def _camera_js(self) -> str | None:
        """JavaScript that points meshcat's orbit camera at ``self.camera``.

        meshcat 0.3.2 turns its three.js scene to z up (the Scene is rotated by -90 deg about x)
        and undoes that for the camera (``/Cameras/default/rotated``), so the camera and its
        OrbitControls live in three.js's y-up world: world (x, y, z) is (x, z, -y) there. It has
        no command for the orbit target, which stays at the origin (moving ``/Cameras/default``
        moves the camera but the controls still look at the origin), so the target is set on
        the viewer's controls directly."""
        if self.camera is None:
            return None
        (px, py, pz), (tx, ty, tz) = (map(float, v) for v in self.camera)
        return ("(function () { const v = viewer, c = v.camera;"
                " for (let p = c.parent; p && p.name !== 'rotated'; p = p.parent) {"
                " p.position.set(0, 0, 0); p.quaternion.set(0, 0, 0, 1); p.updateMatrix(); }"
                f" c.position.set({px!r}, {pz!r}, {-py!r}); v.controls.target.set({tx!r}, {tz!r}, {-ty!r});"
                " v.scene.updateMatrixWorld(true); v.controls.update(); v.set_dirty();"
                " return function () {}; })()")

    def save_html(self, path) -> Path:
        path = Path(path)
        path.write_text(self.html(), encoding="utf-8")
        return path

    def static(self, height: int = 400):
        """An IPython display object with the static scene, which a saved notebook keeps."""
        from IPython.display import HTML

        doc = html_lib.escape(self.html(aspect=max(1.0, CELL_WIDTH_PX / int(height))), quote=True)
        return HTML(f'<div style="height:{int(height)}px;width:100%;resize:both;overflow:hidden">'
                    f'<iframe srcdoc="{doc}" style="width:100%;height:100%;border:none"></iframe></div>')

    def show(self, height: int = 400):
        """Live mode: the running server's view. Offline: the static scene.

        The live view is an iframe whose own page is the static scene as it is now; that page
        switches to the live server only if the server answers. A notebook saved with this
        output and reopened after the kernel stopped shows the scene, not a dead link."""
        if self.camera_auto:
            self.frame(aspect=max(1.0, CELL_WIDTH_PX / int(height)))
        if self._vis is not None:
            return _LiveView(self, height)
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


class _LiveView:
    """The live scene in a notebook cell (``_repr_html_``), falling back to its static copy."""

    def __init__(self, scene: Scene, height: int):
        self.url = scene._vis.url()
        probe = (f"<script>fetch({self.url!r}, {{mode: 'no-cors'}}).then(() => window.location.replace({self.url!r}))"
                 ".catch(() => {});</script></body>")
        page = scene.html().replace("</body>", probe)
        self.data = (f'<div style="height:{int(height)}px;width:100%;resize:both;overflow:hidden">'
                     f'<iframe srcdoc="{html_lib.escape(page, quote=True)}" '
                     'style="width:100%;height:100%;border:none"></iframe></div>')

    def _repr_html_(self):
        return self.data


def _length_text(metres: float) -> str:
    if metres >= 1:
        return f"{metres:g} m"
    if metres >= 0.01:
        return f"{metres * 100:g} cm"
    return f"{metres * 1000:g} mm"


def _label_png(text: str) -> tuple[bytes, float]:
    """``text`` rendered black on white as PNG bytes (matplotlib Agg), and its width/height."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    lines = text.splitlines()
    w_in, h_in = 0.14 * max(len(t) for t in lines) + 0.2, 0.3 * len(lines) + 0.1
    fig = Figure(figsize=(w_in, h_in), dpi=100)
    fig.patch.set_facecolor((1, 1, 1, 0.85))
    fig.text(0.5, 0.5, text, ha="center", va="center", fontsize=14, color="black")
    FigureCanvasAgg(fig)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", facecolor=fig.get_facecolor())
    return buf.getvalue(), w_in / h_in


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

