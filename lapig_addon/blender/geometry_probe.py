"""Exact geometry by ray casting: where projector pixels land and where the camera sees them.

Used for the coverage check before a capture and as ground truth for the registration error.
"""
from __future__ import annotations

import bpy
import numpy as np
from mathutils import Vector
from mathutils.bvhtree import BVHTree

from ...lapig_core.optics.projector_model import frame_sample_points

RENDERABLE = {"MESH", "CURVE", "SURFACE", "META", "FONT", "CURVES", "POINTCLOUD", "VOLUME"}


def renderable_objects(scene):
    return [ob for ob in scene.objects if ob.type in RENDERABLE and not ob.hide_render]


def scene_triangles(objects, depsgraph, uvs: bool = False):
    """Every object's evaluated triangles in world space: (vertices (V, 3), triangles (T, 3) of vertex indices,
    and with `uvs` each triangle's corners in its mesh's active UV map (T, 3, 2), NaN for a mesh without one)."""
    verts, tris, tri_uvs, offset = [], [], [], 0
    for ob in objects:
        if ob.type not in RENDERABLE:
            continue
        ev = ob.evaluated_get(depsgraph)
        try:
            mesh = ev.to_mesh()
        except RuntimeError:
            continue
        if mesh is None:
            continue
        try:
            mesh.calc_loop_triangles()
            co = np.empty(len(mesh.vertices) * 3, np.float64)
            mesh.vertices.foreach_get("co", co)
            tri = np.empty(len(mesh.loop_triangles) * 3, np.int64)
            mesh.loop_triangles.foreach_get("vertices", tri)
            if uvs:
                corner_uv = np.full((len(mesh.loop_triangles), 3, 2), np.nan)
                layer = mesh.uv_layers.active
                if layer is not None and len(mesh.loop_triangles):
                    loops = np.empty(len(mesh.loop_triangles) * 3, np.int64)
                    mesh.loop_triangles.foreach_get("loops", loops)
                    uv = np.empty(len(layer.data) * 2, np.float64)
                    layer.data.foreach_get("uv", uv)
                    corner_uv = uv.reshape(-1, 2)[loops].reshape(-1, 3, 2)
                tri_uvs.append(corner_uv)
        finally:
            ev.to_mesh_clear()
        m = np.array(ob.matrix_world)
        co = co.reshape(-1, 3) @ m[:3, :3].T + m[:3, 3]
        verts.append(co)
        tris.append(tri.reshape(-1, 3) + offset)
        offset += len(co)
    if not verts:
        raise ValueError("there is nothing to render: the scene has no visible geometry")
    return np.concatenate(verts), np.concatenate(tris), (np.concatenate(tri_uvs) if uvs else None)


def scene_bvh(objects, depsgraph) -> BVHTree:
    """One BVH of every object's evaluated triangles, in world space."""
    verts, tris, _ = scene_triangles(objects, depsgraph)
    return BVHTree.FromPolygons(verts.tolist(), tris.tolist())


class CameraProjection:
    """World points -> camera pixel coordinates (OpenCV convention) for a given render size."""

    def __init__(self, camera_obj, scene, width, height):
        frame = camera_obj.data.view_frame(scene=scene)  # top-right, bottom-right, bottom-left, top-left
        tr, _, bl, _ = frame
        self.left, self.right = bl.x, tr.x
        self.bottom, self.top = bl.y, tr.y
        self.plane = -tr.z
        self.world_to_local = np.array(camera_obj.matrix_world.inverted())
        self.origin = np.array(camera_obj.matrix_world.translation)
        self.width, self.height = width, height

    def project(self, points) -> np.ndarray:
        p = np.asarray(points, float) @ self.world_to_local[:3, :3].T + self.world_to_local[:3, 3]
        depth = -p[:, 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            x = p[:, 0] / depth * self.plane
            y = p[:, 1] / depth * self.plane
        nx = (x - self.left) / (self.right - self.left)
        ny = (y - self.bottom) / (self.top - self.bottom)
        out = np.stack([nx * self.width - 0.5, (1 - ny) * self.height - 0.5], axis=1)
        out[depth <= 0] = np.nan
        return out

    def in_frame(self, xy) -> np.ndarray:
        """Whether pixel coordinates (OpenCV convention) fall inside the rendered image."""
        return (xy[:, 0] >= -0.5) & (xy[:, 0] <= self.width - 0.5) & \
            (xy[:, 1] >= -0.5) & (xy[:, 1] <= self.height - 0.5)


def projector_hits(bvh, projector_obj, model, pixel_xy) -> np.ndarray:
    """First surface point hit by each projector pixel ray (NaN where it hits nothing)."""
    directions = model.pixel_to_direction(pixel_xy).reshape(-1, 3)
    m = np.array(projector_obj.matrix_world)
    rot = m[:3, :3] / np.linalg.norm(m[:3, :3], axis=0)  # ignore any object scale
    world_dirs = directions @ rot.T
    origin = Vector(m[:3, 3])
    hits = np.full((len(world_dirs), 3), np.nan)
    for i, d in enumerate(world_dirs):
        loc, _, _, _ = bvh.ray_cast(origin, Vector(d))
        if loc is not None:
            hits[i] = loc
    return hits


def projector_axial_depth(bvh, projector_obj, model, step: int = 4) -> np.ndarray:
    """(H, W) native map of each projector pixel's surface depth along the projector's axis (what a
    thin lens focuses by), ray cast every `step` pixels and spread to the others; NaN where the
    pixel lights nothing."""
    import cv2

    w, h = max(1, model.width // step), max(1, model.height // step)
    xs = (np.arange(w) + 0.5) * model.width / w - 0.5
    ys = (np.arange(h) + 0.5) * model.height / h - 0.5
    xy = np.stack(np.meshgrid(xs, ys), -1).reshape(-1, 2)
    hits = projector_hits(bvh, projector_obj, model, xy)
    m = np.array(projector_obj.matrix_world)
    rot = m[:3, :3] / np.linalg.norm(m[:3, :3], axis=0)
    axis = -rot[:, 2]  # a light shines along its local -Z
    depth = ((hits - m[:3, 3]) @ axis).reshape(h, w).astype(np.float32)
    return cv2.resize(depth, (model.width, model.height), interpolation=cv2.INTER_NEAREST)


def visible_from(bvh, origin, points, tolerance=1e-3) -> np.ndarray:
    """Whether each point is the first surface hit seen from origin (not occluded)."""
    origin = np.asarray(origin, float)
    visible = np.zeros(len(points), bool)
    o = Vector(origin)
    for i, p in enumerate(points):
        if not np.isfinite(p).all():
            continue
        d = p - origin
        dist = np.linalg.norm(d)
        loc, _, _, hit_dist = bvh.ray_cast(o, Vector(d / dist), dist * 1.01)
        visible[i] = loc is not None and abs(hit_dist - dist) <= tolerance * max(dist, 1.0)
    return visible


def exact_projector_to_camera(bvh, projector_obj, model, camera_proj: CameraProjection, pixel_xy):
    """Ground truth camera coordinates of projector pixels; NaN where unlit, hidden or off-frame."""
    pixel_xy = np.asarray(pixel_xy, float)
    shape = pixel_xy.shape[:-1]
    hits = projector_hits(bvh, projector_obj, model, pixel_xy)
    seen = visible_from(bvh, camera_proj.origin, hits)
    cam = camera_proj.project(np.where(np.isfinite(hits), hits, 0.0))
    cam[~(seen & camera_proj.in_frame(cam))] = np.nan
    return cam.reshape(*shape, 2)


def coverage(bvh, projector_obj, model, camera_proj, target_bvh=None, grid=24) -> dict:
    """Share of the projector's frame that lands on geometry the camera sees."""
    xy = frame_sample_points(model.width, model.height, grid).reshape(-1, 2)
    hits = projector_hits(bvh, projector_obj, model, xy)
    lit = np.isfinite(hits).all(axis=1)
    if target_bvh is not None:  # count only hits on the chosen surface object
        on_target = np.zeros(len(hits), bool)
        for i in np.flatnonzero(lit):
            loc, _, _, dist = target_bvh.find_nearest(Vector(hits[i]), 1e-4) or (None,) * 4
            on_target[i] = loc is not None
        lit &= on_target
    seen = visible_from(bvh, camera_proj.origin, hits) & lit
    cam = camera_proj.project(np.where(np.isfinite(hits), hits, 0.0))
    inside = camera_proj.in_frame(cam)
    return {"projector_on_object": float(lit.mean()), "seen_by_camera": float((seen & inside).mean())}


class RigGeometry:
    """The exact geometry of a rig for the capture sequence's checks (its GeometryChecks hooks).

    ``render_scene`` is the scene the camera renders in (its resolution decides the camera's
    frame); the BVHs are built on first use, from the evaluated scene.
    """

    def __init__(self, scene, projector_obj, camera_obj, target_obj, model, render_scene, width, height):
        self.scene, self.projector, self.target, self.model = scene, projector_obj, target_obj, model
        self.camera_proj = CameraProjection(camera_obj, render_scene, width, height)
        self._bvh = self._target_bvh = None

    def _bvhs(self):
        if self._bvh is None:
            depsgraph = bpy.context.evaluated_depsgraph_get()
            self._bvh = scene_bvh(renderable_objects(self.scene), depsgraph)
            self._target_bvh = scene_bvh([self.target], depsgraph)
        return self._bvh, self._target_bvh

    def coverage(self) -> dict:
        bvh, target_bvh = self._bvhs()
        return coverage(bvh, self.projector, self.model, self.camera_proj, target_bvh)

    def exact_projector_to_camera(self, pixel_xy) -> np.ndarray:
        return exact_projector_to_camera(self._bvhs()[0], self.projector, self.model, self.camera_proj, pixel_xy)


def camera_object_mask(scene, camera_obj, target_obj, render_scene, width, height, max_rays=60000) -> np.ndarray:
    """(height, width) bool: the camera pixels whose view ray meets the target object first (not hidden by
    another object). Cast at every pixel centre up to `max_rays`, on a coarser grid above, spread by nearest."""
    import cv2

    step = max(1, int(np.ceil(np.sqrt(width * height / max_rays))))
    w, h = -(-width // step), -(-height // step)
    depsgraph = bpy.context.evaluated_depsgraph_get()
    bvh = scene_bvh(renderable_objects(scene), depsgraph)
    target_bvh = scene_bvh([target_obj], depsgraph)
    frame = camera_obj.data.view_frame(scene=render_scene)  # top-right, bottom-right, bottom-left, top-left
    tr, _, bl, _ = frame
    m = np.array(camera_obj.matrix_world)
    rot = m[:3, :3] / np.linalg.norm(m[:3, :3], axis=0)
    origin = Vector(m[:3, 3])
    xs = ((np.arange(w) * step + 0.5 * step) / width).clip(0, 1)
    ys = ((np.arange(h) * step + 0.5 * step) / height).clip(0, 1)
    mask = np.zeros((h, w), bool)
    for j, ny in enumerate(ys):
        for i, nx in enumerate(xs):
            local = np.array([bl.x + nx * (tr.x - bl.x), tr.y - ny * (tr.y - bl.y), tr.z])
            d = Vector(rot @ (local / np.linalg.norm(local)))
            hit, _, _, dist = bvh.ray_cast(origin, d)
            if hit is None:
                continue
            own, _, _, own_dist = target_bvh.ray_cast(origin, d)
            mask[j, i] = own is not None and abs(own_dist - dist) <= 1e-4 * max(dist, 1.0)
    if step > 1:
        mask = cv2.resize(mask.astype(np.uint8), (width, height), interpolation=cv2.INTER_NEAREST).astype(bool)
    return mask


def sl_surface_points(bvh, projector_obj, model, step: int = 8) -> np.ndarray:
    """(h', w', 3) world points (metres, Blender Z up) where the rays of the 'sl' warp's texel pixels
    (lapig_core/multi/mpcdi_export.sl_texel_pixels) first hit the scene; NaN where they miss. Main thread."""
    from ...lapig_core.multi.mpcdi_export import sl_texel_pixels

    pixels = sl_texel_pixels(model, step)
    return projector_hits(bvh, projector_obj, model, pixels).reshape(pixels.shape[:2] + (3,))


def sl_rig_geometry(scene, projector_objs, models, step: int = 8) -> dict:
    """What the 'sl' package needs of the scene, gathered on the main thread (bpy): each projector's world
    matrix and its texels' surface points (plain numpy, for a worker to write)."""
    objects = [ob for ob in renderable_objects(scene) if ob not in projector_objs]
    bvh = scene_bvh(objects, bpy.context.evaluated_depsgraph_get())
    return {"matrices": [np.array(ob.matrix_world, dtype=np.float64) for ob in projector_objs],
            "points": [sl_surface_points(bvh, ob, m, step) for ob, m in zip(projector_objs, models)]}
