"""The object as the projector sees it, for the looks of the world (issue 50): each projector pixel's ray is cast into
the evaluated scene (geometry_probe's BVH), and where it lands, with the face's normal there, goes to
lapig_core/lgst/world/geometry.from_hits as plain arrays, in the projector's OpenCV coordinates, with the world's up.
Main thread only (bpy)."""
from __future__ import annotations

import dataclasses

import numpy as np
from mathutils import Vector
from mathutils.bvhtree import BVHTree

from .geometry_probe import renderable_objects, scene_triangles


def intrinsics(model, width: int, height: int) -> tuple[float, float, float, float]:
    """fx, fy, cx, cy in pixels of a width x height frame (ProjectorModel: throw ratio and lens shift)."""
    sx, sy = model.uv_scale()
    return (sx * width, sy * height, (0.5 + model.shift_x) * width - 0.5, (0.5 - model.shift_y) * height - 0.5)


def cast(scene, projector_obj, model, width: int, height: int, step: int = 1):
    """(points, normals, up, uv) in the projector's OpenCV coordinates (x right, y down, z ahead), every `step` pixels
    of a width x height frame and spread to the others (1: every pixel; a coarser grid makes steps of depth the
    cavity reads as edges); NaN where a pixel's ray lands on nothing. uv: (H, W, 2) where each lands in its mesh's
    active UV map (interpolated over the triangle hit), NaN where the mesh has none."""
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
    verts, tris, tri_uvs = scene_triangles(renderable_objects(scene), bpy.context.evaluated_depsgraph_get(), uvs=True)
    bvh = BVHTree.FromPolygons(verts.tolist(), tris.tolist())
    points = np.full((len(xy), 3), np.nan)
    normals = np.full((len(xy), 3), np.nan)
    hit_tri = np.full(len(xy), -1, np.int64)
    o = Vector(origin)
    for i, d in enumerate(local @ rot.T):
        loc, normal, index, _ = bvh.ray_cast(o, Vector(d))
        if loc is not None:
            points[i], normals[i], hit_tri[i] = loc, normal, index
    uv = triangle_uvs(points, hit_tri, verts, tris, tri_uvs)
    to_cv = np.diag([1.0, -1.0, -1.0])  # Blender's camera (x right, y up, looking down -z) -> OpenCV's
    points = ((points - origin) @ rot) @ to_cv
    normals = (normals @ rot) @ to_cv
    up = (np.array([0.0, 0.0, 1.0]) @ rot) @ to_cv

    def spread(a, channels=3):
        a = a.reshape(h, w, channels).astype(np.float32)
        return cv2.resize(a, (width, height), interpolation=cv2.INTER_NEAREST).reshape(height, width, channels)

    return spread(points), spread(normals), up, spread(uv, 2)


def triangle_uvs(points, hit_tri, verts, tris, tri_uvs) -> np.ndarray:
    """(N, 2): each hit's UV, the barycentric mix of its triangle's corner UVs (NaN: no hit, or no UV map)."""
    uv = np.full((len(points), 2), np.nan)
    hit = hit_tri >= 0
    if not hit.any():
        return uv
    corners = verts[tris[hit_tri[hit]]]  # (n, 3, 3)
    a, b, c = corners[:, 0], corners[:, 1], corners[:, 2]
    v0, v1, v2 = b - a, c - a, points[hit] - a
    d00, d01, d11 = (v0 * v0).sum(-1), (v0 * v1).sum(-1), (v1 * v1).sum(-1)
    d20, d21 = (v2 * v0).sum(-1), (v2 * v1).sum(-1)
    den = np.where(np.abs(d00 * d11 - d01 * d01) > 1e-18, d00 * d11 - d01 * d01, np.nan)
    wb, wc = (d11 * d20 - d01 * d21) / den, (d00 * d21 - d01 * d20) / den
    t = tri_uvs[hit_tri[hit]]
    uv[hit] = (1 - wb - wc)[:, None] * t[:, 0] + wb[:, None] * t[:, 1] + wc[:, None] * t[:, 2]
    return uv


def projector_look_geometry(scene, projector_obj, model, width: int, height: int):
    """The look geometry of the object as this projector sees it at the working frame (width x height), or None
    where the projector's rays land on nothing."""
    from ...lapig_core.lgst.world.geometry import from_hits

    points, normals, up, uv = cast(scene, projector_obj, model, width, height)
    if not np.isfinite(points).all(-1).any():
        return None
    return from_hits(points, normals, up, *intrinsics(model, width, height),
                     note=f"shaped by the scene's geometry as {projector_obj.name} sees it", uv=uv)


class _Frame:
    """What preview.caster_model reads of an image: its size."""

    def __init__(self, width: int, height: int):
        self.size = (width, height)


def camera_look_geometry(scene, camera_obj, width: int, height: int):
    """The object as the rig's camera sees it at width x height (a rig of several projectors makes its look in the
    camera's space): the camera's rays cast as a projector's, by its lens, sensor fit and shift; None where they
    land on nothing."""
    from .preview import caster_model

    if camera_obj is None or camera_obj.type != "CAMERA" or camera_obj.data.type != "PERSP":
        return None
    return projector_look_geometry(scene, camera_obj, caster_model(camera_obj, _Frame(width, height)), width, height)
