"""MyCar in the 3D view: a recorded drive (RViz showing the robot model while a bag plays).

Counterpart: RViz's RobotModel display following ``/tf`` while ``ros2 action send_goal`` drives
the car, and Drake's ``StartRecording`` / ``PublishRecording`` to keep the motion as an
animation. A timer on the car's own executor samples the simulated car every ``1 / fps``
seconds of simulated time, so the animation's clock is the bus clock; the recorded trail is
drawn on the floor and the scene frames the whole drive (see :mod:`robocourse.viz.framing`).
Chapter 3 records its navigation goal with :func:`record_navigation`; the teleop's static
fallback (:meth:`robocourse.mycar.teleop_live.LiveTeleop.drive_recorded`) records with the same
:class:`CarRecording`.
"""

from __future__ import annotations

import numpy as np

#: scene paths: the car's geoms, its recorded trail, the live view's framing corners
CAR_PATH, TRAIL_PATH, FRAME_PATH = "mycar", "mycar_trail", "robocourse_frame"


def car_simulator(car):
    """The launched car's simulator node, or a clear error for a car without MuJoCo."""
    sim = getattr(car, "simulator", None)
    if sim is None:
        raise ValueError("the 3D view draws the MuJoCo car: launch the car with driver: mujoco "
                         "(the default mycar.yaml does)")
    return sim


def fresh_drawer(scene, car):
    """A new MujocoDrawer for ``car`` at :data:`CAR_PATH`; an earlier car, its trail and its
    recorded motion are removed first (a new drive is framed on its own)."""
    from robocourse.viz import MujocoDrawer

    sim = car_simulator(car)
    for path in (CAR_PATH, TRAIL_PATH, FRAME_PATH):
        scene.delete(path)
    return MujocoDrawer(scene, sim.car.model, prefix=CAR_PATH)


class CarRecording:
    """Record a launched MyCar's MuJoCo car into ``scene`` while something drives it.

    ``sample()`` draws the car at the current simulated time (animation time counts from the
    recording's start); ``finish(height)`` stops the recording, lays the trail on the floor and
    returns the static view (``scene.publish_recording``)."""

    def __init__(self, car, scene=None, fps: int = 20):
        if isinstance(fps, bool) or not isinstance(fps, int) or fps <= 0:
            raise ValueError(f"fps={fps!r}: a recording needs a positive whole number of frames per second (e.g. 20)")
        if scene is None:
            from robocourse.viz import get_scene

            scene = get_scene()
        self.car, self.scene, self.fps = car, scene, fps
        self._sim = car_simulator(car)
        self._clock = car.driver.get_clock()
        self.drawer = fresh_drawer(scene, car)
        self.trail: list[tuple[float, float, float]] = []     # (x, y, z) ground truth per frame, m
        scene.start_recording(fps=fps)
        self.t0_ns = self._clock.now().nanoseconds

    def sample(self) -> None:
        """Draw the car as it is now, at animation time (now - start)."""
        self.scene.set_time((self._clock.now().nanoseconds - self.t0_ns) * 1e-9)
        self.drawer.update(self._sim.car.data)
        self.trail.append((*self._sim.car.pose()[:2], 0.005))

    def finish(self, height: int = 350):
        """Stop recording, draw the trail, return the recording as static HTML."""
        self.scene.stop_recording()
        if len(self.trail) >= 2:
            self.scene.trace(TRAIL_PATH, np.asarray(self.trail, dtype=np.float64), rgba=(0.9, 0.2, 0.2, 1.0))
        if self.scene.camera_auto:      # seen from the heading that draws the car largest, whichever way it started
            from robocourse.viz.framing import closest_direction
            from robocourse.viz.scene import CELL_WIDTH_PX

            pts, pad = self.scene.motion_points()
            if len(pts):
                self.scene.view_direction = closest_direction(pts, pad=pad, aspect=max(1.0, CELL_WIDTH_PX / int(height)))
        return self.scene.publish_recording(height=height)


def record_navigation(car, goal: dict, scene=None, fps: int = 20, height: int = 350, timeout: float = 60.0):
    """Send ``goal`` (``ros2 action send_goal`` values for ``/navigate_to_pose``) to a launched car,
    record the drive in ``scene`` and return ``(view, status, result, recording)``.

    ``status``/``result`` are what :func:`robocourse.bus.introspection.action_send_goal` returns
    (``None`` if the goal was rejected); ``recording.trail`` holds the true path."""
    from robocourse.bus import introspection

    from .msgs import NavigateToPose

    rec = CarRecording(car, scene, fps=fps)
    node = car.context.create_node("view_recorder")
    car.executor.add_node(node)
    timer = node.create_timer(1.0 / fps, rec.sample)
    try:
        rec.sample()                                    # frame 0: where the drive starts
        status, result, _ = introspection.action_send_goal(car.context, "/navigate_to_pose", NavigateToPose, goal,
                                                           car.executor, feedback=False, quiet=True, timeout=timeout)
    finally:
        node.destroy_timer(timer)
        car.executor.remove_node(node)
        node.destroy_node()
    return rec.finish(height), status, result, rec
