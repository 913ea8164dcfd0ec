"""robocourse.viz: a Meshcat scene that is live in JupyterLab and static HTML headless.

``get_scene()`` returns the notebook's one scene; ``MujocoDrawer`` draws a MuJoCo model in it;
``transform``/``rot_x``... build float64 poses without meshcat.transformations (NumPy 2 safe).
"""

from .mujoco_geometry import MujocoDrawer
from .scene import Scene, get_scene, reset_scene
from .transforms import (
           quaternion_from_rotation,
           rot_x,
           rot_y,
           rot_z,
           rotation_from_quaternion,
           transform,
)

__all__ = ["MujocoDrawer", "Scene", "get_scene", "reset_scene", "transform", "rot_x", "rot_y", "rot_z",
           "quaternion_from_rotation", "rotation_from_quaternion"]
