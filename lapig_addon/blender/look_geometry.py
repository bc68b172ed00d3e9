"""The object as the projector sees it, for the looks of the world (issue 50): each projector pixel's ray is cast into
the evaluated scene (geometry_probe's BVH), and where it lands, with the face's normal there, goes to
lapig_core/lgst/world/geometry.from_hits as plain arrays, in the projector's OpenCV coordinates, with the world's up.
Main thread only (bpy)."""
from __future__ import annotations

import dataclasses

import numpy as np
from mathutils import Vector

from .geometry_probe import renderable_objects, scene_bvh


def intrinsics(model, width: int, height: int) -> tuple[float, float, float, float]:
    """fx, fy, cx, cy in pixels of a width x height frame (ProjectorModel: throw ratio and lens shift)."""
    sx, sy = model.uv_scale()
    return (sx * width, sy * height, (0.5 + model.shift_x) * width - 0.5, (0.5 - model.shift_y) * height - 0.5)


def cast(scene, projector_obj, model, width: int, height: int, step: int = 1):
    """(points, normals, up) in the projector's OpenCV coordinates (x right, y down, z ahead), every `step` pixels of
    a width x height frame and spread to the others (1: every pixel; a coarser grid makes steps of depth the
    cavity reads as edges); NaN where a pixel's ray lands on nothing."""
    import bpy
    import cv2

    frame = dataclasses.replace(model, width=width, height=height)
    w, h = max(1, width // step), max(1, height // step)
    xs = (np.arange(w) + 0.5) * width / w - 0.5
    ys = (np.arange(h) + 0.5) * height / h - 0.5
    xy = np.stack(np.meshgrid(xs, ys), -1).reshape(-1, 2)
    local = frame.pixel_to_direction(xy)
    m = np.array(projector_obj.matrix_world)
    rot = m[:3, :3] / np.linalg.norm(m[:3, :3], axis=0)  # no object scale
    origin = m[:3, 3]
    bvh = scene_bvh(renderable_objects(scene), bpy.context.evaluated_depsgraph_get())
    points = np.full((len(xy), 3), np.nan)
    normals = np.full((len(xy), 3), np.nan)
    o = Vector(origin)
    for i, d in enumerate(local @ rot.T):
        loc, normal, _, _ = bvh.ray_cast(o, Vector(d))
        if loc is not None:
            points[i], normals[i] = loc, normal
    to_cv = np.diag([1.0, -1.0, -1.0])  # Blender's camera (x right, y up, looking down -z) -> OpenCV's
    points = ((points - origin) @ rot) @ to_cv
    normals = (normals @ rot) @ to_cv
    up = (np.array([0.0, 0.0, 1.0]) @ rot) @ to_cv

    def spread(a):
        a = a.reshape(h, w, 3).astype(np.float32)
        return cv2.resize(a, (width, height), interpolation=cv2.INTER_NEAREST)

    return spread(points), spread(normals), up


def projector_look_geometry(scene, projector_obj, model, width: int, height: int):
    """The look geometry of the object as this projector sees it at the working frame (width x height), or None
    where the projector's rays land on nothing."""
    from ...lapig_core.lgst.world.geometry import from_hits

    points, normals, up = cast(scene, projector_obj, model, width, height)
    if not np.isfinite(points).all(-1).any():
        return None
    return from_hits(points, normals, up, *intrinsics(model, width, height),
                     note=f"shaped by the scene's geometry as {projector_obj.name} sees it")
