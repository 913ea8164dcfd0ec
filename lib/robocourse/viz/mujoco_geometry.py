"""Draw a MuJoCo model's geometry in a :class:`Scene` and update it from ``MjData``.

The counterpart of Drake's MeshcatVisualizer for a MuJoCo ``MjModel``: every visible geom
(box, sphere, capsule, cylinder, ellipsoid, plane, mesh) becomes a node ``prefix/<geom>``;
``update(data)`` sets each moving geom's world pose (geoms on bodies welded to the world are
placed once) from ``data.geom_xpos``/``geom_xmat``
(inside a recording, into the current animation frame).
"""

from __future__ import annotations

import numpy as np

from . import transforms as tf
from .scene import Scene


class MujocoDrawer:
    def __init__(self, scene: Scene, model, prefix: str = "mujoco", max_group: int = 2, plane_size: float = 4.0):
        import mujoco

        self.scene, self.model, self.prefix = scene, model, prefix.strip("/")
        self.paths: list[tuple[int, str]] = []
        self._planes: list[int] = []
        self._static: list[tuple[int, str]] = []
        gt = mujoco.mjtGeom
        for i in range(model.ngeom):
            if model.geom_group[i] > max_group or model.geom_rgba[i][3] == 0:
                continue
            name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, i) or f"geom{i}"
            path = f"{self.prefix}/{name}"
            size, rgba, kind = model.geom_size[i], np.clip(model.geom_rgba[i], 0, 1), model.geom_type[i]
            if kind == gt.mjGEOM_BOX:
                scene.box(path, 2 * size, rgba)
            elif kind == gt.mjGEOM_SPHERE:
                scene.sphere(path, size[0], rgba)
            elif kind == gt.mjGEOM_CAPSULE:
                scene.capsule(path, 2 * size[1], size[0], rgba)
            elif kind == gt.mjGEOM_CYLINDER:
                scene.cylinder(path, 2 * size[1], size[0], rgba)
            elif kind == gt.mjGEOM_ELLIPSOID:
                scene.sphere(path, 1.0, rgba)
                scene.set_transform(f"{path}/geometry", np.diag([*size, 1.0]), _static=True)  # a scale, not a pose
                scene._note_size(path, float(max(size)))
            elif kind == gt.mjGEOM_PLANE:
                half = [s if s > 0 else plane_size for s in size[:2]]
                scene.box(path, (2 * half[0], 2 * half[1], 0.002), rgba)
            elif kind == gt.mjGEOM_MESH:
                mid = model.geom_dataid[i]
                v0, nv = model.mesh_vertadr[mid], model.mesh_vertnum[mid]
                f0, nf = model.mesh_faceadr[mid], model.mesh_facenum[mid]
                scene.mesh(path, model.mesh_vert[v0:v0 + nv], model.mesh_face[f0:f0 + nf], rgba)
            else:
                continue  # heightfields, SDFs: not drawn
            moving = model.body_weldid[model.geom_bodyid[i]] != 0   # welded to the world (fixed bodies too): static
            (self.paths if moving else self._static).append((i, path))
            if kind == gt.mjGEOM_PLANE and not moving:
                self._planes.append(i)
        self._floor_set = False

    def floor_height(self, data) -> float:
        """The highest world-fixed plane's height (m), else just under the lowest drawn geom
        (box corners exact, other geoms by MuJoCo's bounding sphere): where the grid belongs."""
        import mujoco

        if self._planes:
            return float(max(data.geom_xpos[i][2] for i in self._planes))
        low = []
        for i, _ in self.paths + self._static:
            if self.model.geom_type[i] == mujoco.mjtGeom.mjGEOM_BOX:
                rot = data.geom_xmat[i].reshape(3, 3)
                low.append(data.geom_xpos[i][2] - float(np.abs(rot[2]) @ self.model.geom_size[i]))
            else:
                low.append(data.geom_xpos[i][2] - self.model.geom_rbound[i])
        return float(min(low)) if low else 0.0

    def update(self, data) -> None:
        """Set every drawn geom's pose from ``data`` (call after mj_step / mj_forward)."""
        if self.model.ngeom and not data.geom_xmat.any():
            raise ValueError("data.geom_xmat is all zeros: MuJoCo has not computed poses yet; "
                             "call mujoco.mj_forward(model, data) (or mj_step) before drawing")
        if not self._floor_set:
            self._floor_set = True
            self.scene.floor_z = self.floor_height(data)
        for i, path in self.paths:
            self.scene.set_transform(path, tf.transform(data.geom_xpos[i], rotation=data.geom_xmat[i].reshape(3, 3)))
        if self._static:
            for i, path in self._static:
                self.scene.set_transform(path, tf.transform(data.geom_xpos[i], rotation=data.geom_xmat[i].reshape(3, 3)),
                                         _static=True)
            self._static = []  # world geoms never move: one pose is enough
