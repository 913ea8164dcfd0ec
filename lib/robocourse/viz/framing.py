"""Where to put the camera so the motion fills the view, and what the camera then sees.

Counterpart of what a person does in RViz/Meshcat by hand: look across the plane the robot moves
in (side-on for a cart-pole or pendulum swinging in x-z, from above at an angle for a car driving
on the floor), step back until the whole motion fits, and lay a grid with a known spacing under
it. Meshcat 0.3.2's camera is a three.js ``PerspectiveCamera(fov=75 deg vertical)`` whose "up"
is world z; :func:`project` reproduces its projection so tests can measure what is on screen.
"""

from __future__ import annotations

import math

import numpy as np

#: meshcat 0.3.2's default camera: PerspectiveCamera(75, aspect, 0.01, 100)
FOV_DEG = 75.0
#: the aspect the framing plans for (a 640 x 480 screenshot; notebook cells are wider, so safer)
ASPECT = 4 / 3


def _nice(x: float) -> float:
    """The largest 1, 2 or 5 x 10^k not above ``x`` (grid spacings and scale bars)."""
    if not (math.isfinite(x) and x > 0):
        raise ValueError(f"a length scale must be positive and finite, got {x!r}")
    k = math.floor(math.log10(x))
    for m in (5, 2, 1):
        if m * 10 ** k <= x * (1 + 1e-9):
            return float(m * 10 ** k)
    return float(10 ** k)


def camera_axes(position, target):
    """(right, up, forward) unit vectors of a camera at ``position`` looking at ``target`` (z up)."""
    p, t = np.asarray(position, np.float64), np.asarray(target, np.float64)
    f = t - p
    n = np.linalg.norm(f)
    if not n > 0:
        raise ValueError(f"camera position {tuple(p)} equals its target: step back from the target")
    f /= n
    r = np.cross(f, [0.0, 0.0, 1.0])
    if np.linalg.norm(r) < 1e-9:
        raise ValueError("the camera looks straight down or up: tilt it (meshcat's orbit camera keeps z up)")
    r /= np.linalg.norm(r)
    return r, np.cross(r, f), f


def project(points, position, target, fov_deg: float = FOV_DEG, aspect: float = ASPECT):
    """Normalised device coordinates (N x 2, -1..1 is on screen) and depths of world ``points``.

    The same pinhole model three.js uses for meshcat's PerspectiveCamera (vertical ``fov_deg``)."""
    pts = np.asarray(points, np.float64).reshape(-1, 3)
    r, u, f = camera_axes(position, target)
    rel = pts - np.asarray(position, np.float64)
    depth = rel @ f
    if np.any(depth <= 0):
        raise ValueError("some points are behind the camera: move the camera back")
    t = math.tan(math.radians(fov_deg) / 2)
    return np.c_[(rel @ r) / (depth * t * aspect), (rel @ u) / (depth * t)], depth


def frame_motion(points, pad: float = 0.0, fov_deg: float = FOV_DEG, aspect: float = ASPECT,
                 fill: float = 0.8, direction=None):
    """Camera (position, target) so that ``points`` (N x 3, every place something was) fill the view.

    The view direction looks across the plane the motion spans: if the motion stays near the
    floor (car), from above at 55 deg elevation; if it spans height too (pendulum, cart-pole),
    side-on at 15 deg elevation, perpendicular to the main horizontal direction of motion (so a
    rail runs across the screen). ``direction`` (world vector from target to camera) overrides.
    ``pad`` (m, one number or one per point) is added around the points (the robot's own size); ``fill`` is the fraction of
    the screen the motion should span along its tighter screen axis.
    """
    pts = np.asarray(points, np.float64).reshape(-1, 3)
    pts = pts[np.all(np.isfinite(pts), axis=1)]
    if len(pts) == 0:
        raise ValueError("nothing to frame: the scene has no finite positions yet (draw something first)")
    if not 0 < fill <= 1:
        raise ValueError(f"fill is the fraction of the view to use, in (0, 1], got {fill!r}")
    pads = np.broadcast_to(np.asarray(pad, np.float64), (len(np.asarray(points).reshape(-1, 3)),))
    pads = pads[np.all(np.isfinite(np.asarray(points, np.float64).reshape(-1, 3)), axis=1)]
    lo, hi = (pts - pads[:, None]).min(0), (pts + pads[:, None]).max(0)
    target = (lo + hi) / 2
    span = hi - lo
    if direction is None:
        xy = pts[:, :2] - pts[:, :2].mean(0)
        if len(xy) > 1 and np.ptp(xy, axis=0).max() > 1e-6:
            w, v = np.linalg.eigh(xy.T @ xy)
            main = v[:, np.argmax(w)]
        else:
            main = np.array([1.0, 0.0])
        side = np.array([main[1], -main[0]])            # perpendicular to the motion, horizontal
        if side[1] > 0 or (abs(side[1]) < 1e-9 and side[0] < 0):
            side = -side                                 # look from -y (x runs left to right)
        bare = np.ptp(pts, axis=0)                       # the motion itself, without the robot's size
        flat = bare[2] < 0.25 * max(bare[0], bare[1])
        elev = math.radians(55.0 if flat else 15.0)
        direction = np.array([side[0] * math.cos(elev), side[1] * math.cos(elev), math.sin(elev)])
    d = np.asarray(direction, np.float64)
    if not (d.shape == (3,) and np.all(np.isfinite(d)) and np.linalg.norm(d) > 0):
        raise ValueError(f"direction must be a non-zero 3-vector (from the target towards the camera), got {direction!r}")
    d /= np.linalg.norm(d)
    # every point as a sphere of its pad radius must land inside `fill` of the screen
    t = math.tan(math.radians(fov_deg) / 2)
    r_ax, u_ax, f_ax = camera_axes(target + d, target)
    rel = pts - target

    def fits(dist):
        depth = (rel - d * dist) @ (-d)
        if np.any(depth <= pads + 1e-6):                 # a point at or behind the camera
            return False
        x = (rel @ r_ax + np.sign(rel @ r_ax) * pads) / (depth * t * aspect)
        y = (rel @ u_ax + np.sign(rel @ u_ax) * pads) / (depth * t)
        return float(max(np.abs(x).max(), np.abs(y).max())) <= fill

    far = max(float(np.linalg.norm(span)), 1e-3)
    while not fits(far):
        far *= 2
    near = 0.0
    for _ in range(50):                                  # bisect for the closest distance that fits
        mid = (near + far) / 2
        near, far = (near, mid) if fits(mid) else (mid, far)
    dist = far
    return target + d * dist, target


def closest_direction(points, pad: float = 0.0, aspect: float = ASPECT, elevation_deg: float = 55.0,
                      steps: int = 72, fill: float = 0.8, fov_deg: float = FOV_DEG):
    """The view direction (target -> camera, ``elevation_deg`` above the floor) from which the motion
    fits the view with the camera closest, so the robot is drawn largest.

    :func:`frame_motion`'s automatic choice looks across the motion's main horizontal axis; for a
    drive that turns (no main axis) that choice follows the drive's heading in the world, and a
    wide notebook view may then see the drive end-on, from twice as far. Trying ``steps`` headings
    makes the picture the same whichever way the car was facing when it started."""
    if not (isinstance(steps, int) and steps >= 1):
        raise ValueError(f"steps={steps!r}: the number of headings to try must be a positive int (e.g. 72)")
    if not 0.0 < float(elevation_deg) < 90.0:
        raise ValueError(f"elevation_deg={elevation_deg!r}: the camera must look down from above the floor, "
                         "strictly between 0 and 90 degrees (55 is the floor default)")
    elev = math.radians(float(elevation_deg))
    best, best_dist = None, math.inf
    for k in range(steps):
        yaw = 2.0 * math.pi * k / steps
        d = np.array([math.cos(yaw) * math.cos(elev), math.sin(yaw) * math.cos(elev), math.sin(elev)])
        pos, target = frame_motion(points, pad=pad, fov_deg=fov_deg, aspect=aspect, fill=fill, direction=d)
        dist = float(np.linalg.norm(pos - target))
        if dist < best_dist * (1.0 - 1e-6):          # ties keep the first heading: deterministic
            best, best_dist = d, dist
    return best
