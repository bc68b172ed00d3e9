"""Where to put a projector and a camera so the object fills the frame: pure geometry, no bpy.

Planar objects (walls, panels) are *filled*: the projector frame lies inside the surface, as in a
real projection-mapping install. Solid objects (boxes, statues) are *fitted*: their silhouette
fills the frame. The camera sits beside the projector, as on a real rig, and sees all of it.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

FRONT = np.array([0.0, -1.0, 0.0])  # Blender's front view looks from -Y towards +Y
WORLD_UP = np.array([0.0, 0.0, 1.0])


@dataclass
class Pose:
    location: np.ndarray  # (3,)
    rotation: np.ndarray  # (3, 3) columns: right, up, back (the view looks down -back)


@dataclass
class RigPlacement:
    projector: Pose
    camera: Pose
    camera_lens_mm: float
    sensor_width_mm: float
    planar: bool
    distance: float


def look_at(location, target, up=WORLD_UP) -> Pose:
    location = np.asarray(location, float)
    forward = np.asarray(target, float) - location
    forward /= np.linalg.norm(forward)
    if abs(forward @ up) > 0.99:  # looking straight up or down: any horizontal up will do
        up = np.array([0.0, 1.0, 0.0])
    right = np.cross(forward, up)
    right /= np.linalg.norm(right)
    true_up = np.cross(right, forward)
    return Pose(location, np.stack([right, true_up, -forward], axis=1))


def _principal_axes(points):
    centred = points - points.mean(axis=0)
    _, s, vt = np.linalg.svd(centred, full_matrices=False)
    return vt, s


def choose_view_direction(points, normals=None) -> tuple[np.ndarray, bool]:
    """Unit vector from the object towards the rig, and whether the object is planar."""
    axes, _ = _principal_axes(points)
    extents = np.ptp(points @ axes.T, axis=0)
    planar = extents[2] < 0.08 * extents[0]
    if planar:
        n = axes[2]
        if normals is not None and len(normals):
            mean_normal = np.asarray(normals, float).mean(axis=0)
            if np.linalg.norm(mean_normal) > 0.5:  # one-sided panel: look at its front face
                return np.sign(mean_normal @ n or 1.0) * n, True
        # two-sided or unknown: the side facing the default front view, else the top
        score = n @ (FRONT + 0.5 * WORLD_UP)
        return (n if score >= 0 else -n), True
    direction = FRONT + 0.15 * WORLD_UP  # a little above, like a projector on a stand
    return direction / np.linalg.norm(direction), False


def place_rig(points, normals=None, throw_ratio=1.5, aspect=4 / 3, camera_aspect=4 / 3,
              camera_offset=0.25, sensor_width_mm=36.0, max_points=20000) -> RigPlacement:
    """Projector and camera poses for an object given its world-space vertices (N, 3)."""
    points = np.asarray(points, float)
    if points.ndim != 2 or points.shape[1] != 3 or len(points) < 3:
        raise ValueError("the object needs at least three vertices to place a projector around it")
    if len(points) > max_points:
        points = points[np.linspace(0, len(points) - 1, max_points).astype(int)]
    lo, hi = points.min(axis=0), points.max(axis=0)
    centre = (lo + hi) / 2
    if np.linalg.norm(hi - lo) < 1e-6:
        raise ValueError("the object has no size: cannot fit a projector frame to it")
    direction, planar = choose_view_direction(points, normals)
    view = look_at(centre + direction, centre)
    right, up, back = view.rotation.T
    rel = points - centre
    half_w = np.abs(rel @ right).max()
    half_h = np.abs(rel @ up).max()
    front_depth = max((rel @ back).max(), 0.0)
    if planar:
        # the frame (width w, height w/aspect) must lie inside the panel
        frame_w = 0.94 * min(2 * half_w, 2 * half_h * aspect)
    else:
        frame_w = 1.04 * max(2 * half_w, 2 * half_h * aspect)
    distance = throw_ratio * frame_w + (0.0 if planar else front_depth * 0.5)
    projector = look_at(centre + direction * distance, centre)
    cam_loc = projector.location + right * camera_offset * distance + up * 0.05 * distance
    camera = look_at(cam_loc, centre)
    if planar:
        # frame the lit part of the panel (the projector frame), so camera pixels are not wasted
        hw, hh = frame_w / 2, frame_w / aspect / 2
        framed = np.array([centre + sx * hw * right + sy * hh * up for sx in (-1, 1) for sy in (-1, 1)])
    else:
        framed = points
    lens = _lens_to_frame(framed, camera, camera_aspect, sensor_width_mm)
    return RigPlacement(projector, camera, lens, sensor_width_mm, planar, float(distance))


def _lens_to_frame(points, camera: Pose, aspect, sensor_width_mm, margin=1.12) -> float:
    local = (points - camera.location) @ camera.rotation
    depth = np.maximum(-local[:, 2], 1e-6)
    tan_x = np.abs(local[:, 0] / depth).max() * margin
    tan_y = np.abs(local[:, 1] / depth).max() * margin
    tan_half = max(tan_x, tan_y * aspect)  # horizontal sensor fit
    return float(sensor_width_mm / 2 / tan_half)
