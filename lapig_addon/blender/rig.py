"""Adding the projector and the camera to the scene, placed around the selected object."""
from __future__ import annotations

import bpy
import numpy as np
from mathutils import Matrix, Vector

from ...lapig_core.optics.placement import place_rig
from ...lapig_core.optics.projector_cone import reach
from . import projector_nodes
from . import scene_state
from .scene_state import camera_settings, projector_model

RIG_COLLECTION = "LAPIG Rig"


class RigError(ValueError):
    """A problem the user can fix (nothing selected, wrong object type)."""


def object_world_vertices(obj, depsgraph) -> tuple[np.ndarray, np.ndarray]:
    """Evaluated world-space vertices and polygon normals of a mesh object."""
    evaluated = obj.evaluated_get(depsgraph)
    mesh = evaluated.to_mesh()
    try:
        verts = np.empty(len(mesh.vertices) * 3, np.float64)
        mesh.vertices.foreach_get("co", verts)
        normals = np.empty(len(mesh.polygons) * 3, np.float64)
        mesh.polygons.foreach_get("normal", normals)
        areas = np.empty(len(mesh.polygons), np.float64)
        mesh.polygons.foreach_get("area", areas)
    finally:
        evaluated.to_mesh_clear()
    m = np.array(obj.matrix_world)
    verts = verts.reshape(-1, 3) @ m[:3, :3].T + m[:3, 3]
    normal_matrix = np.linalg.inv(m[:3, :3]).T
    normals = normals.reshape(-1, 3) @ normal_matrix.T
    normals /= np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-12)
    weighted = normals * (areas[:, None] / max(areas.sum(), 1e-12)) * len(areas)
    return verts, weighted


def _pose_matrix(pose) -> Matrix:
    m = np.eye(4)
    m[:3, :3] = pose.rotation
    m[:3, 3] = pose.location
    return Matrix(m.tolist())


def _rig_collection(scene) -> bpy.types.Collection:
    coll = bpy.data.collections.get(RIG_COLLECTION)
    if coll is None:
        coll = bpy.data.collections.new(RIG_COLLECTION)
    if coll.name not in scene.collection.children:
        scene.collection.children.link(coll)
    return coll


def test_card() -> bpy.types.Image:
    """A colour grid the projector shows until there is a result, so aim and focus are visible."""
    image = bpy.data.images.get("LAPIG test card")
    if image is None:
        image = bpy.data.images.new("LAPIG test card", 800, 600)
        image.generated_type = "COLOR_GRID"
    return image


def create_projector(scene, name="LAPIG Projector") -> bpy.types.Object:
    light = bpy.data.lights.new(name, "SPOT")
    obj = bpy.data.objects.new(name, light)
    _rig_collection(scene).objects.link(obj)
    settings = obj.lapig_projector
    settings.is_projector = True  # triggers no rebuild by itself: build explicitly below
    light.energy = settings.brightness
    projector_nodes.build_light_tree(light, projector_model(obj), image=test_card())
    obj.show_in_front = True
    return obj


def create_camera(scene, name="LAPIG Camera") -> bpy.types.Object:
    cam = bpy.data.cameras.new(name)
    obj = bpy.data.objects.new(name, cam)
    _rig_collection(scene).objects.link(obj)
    cam.sensor_fit = "HORIZONTAL"
    cam.clip_start = 0.01
    return obj


def add_rig(context, target=None, projector=None, camera=None):
    """Place a projector and a camera (new ones unless given) around the target mesh."""
    scene = context.scene
    target = target or context.active_object
    if target is None:
        raise RigError("Select the object to project on first")
    if target.type != "MESH":
        raise RigError(f"'{target.name}' is a {target.type.lower()}, not a mesh: select the surface object")
    depsgraph = context.evaluated_depsgraph_get()
    verts, normals = object_world_vertices(target, depsgraph)
    if len(verts) < 3:
        raise RigError(f"'{target.name}' has no geometry to project on")
    projector = projector or create_projector(scene)
    camera = camera or create_camera(scene)
    model, cam = projector_model(projector), camera_settings(camera)
    placement = place_rig(verts, normals, throw_ratio=model.throw_ratio, aspect=model.aspect,
                          camera_aspect=cam.width / cam.height)
    projector.matrix_world = _pose_matrix(placement.projector)
    camera.matrix_world = _pose_matrix(placement.camera)
    camera.data.sensor_fit = "HORIZONTAL"
    camera.data.sensor_width = placement.sensor_width_mm
    camera.data.lens = placement.camera_lens_mm
    camera.data.clip_end = max(camera.data.clip_end, placement.distance * 4)
    bpy.context.view_layer.update()
    focus_on_object(projector, camera, target)
    draw_cone_to(projector, target)
    scene_state.record_rig(scene, projector, camera, target)
    return projector, camera, placement


def axial_distance(obj, point) -> float:
    """Distance of a world point along the view axis (local -Z) of a light or a camera."""
    m = np.array(obj.matrix_world)
    axis = -m[:3, 2] / np.linalg.norm(m[:3, 2])
    return float((np.asarray(point, float) - m[:3, 3]) @ axis)


def draw_cone_to(projector, target) -> None:
    """The viewport draws the spot's cone as far as the light's custom distance (40 m by default): end it just
    past the target. use_custom_distance stays off, so neither Cycles nor EEVEE cuts the light there."""
    corners = [tuple(target.matrix_world @ Vector(c)) for c in target.bound_box]
    projector.data.cutoff_distance = max(reach(tuple(projector.matrix_world.translation), corners), 0.01)


def object_centre(obj) -> np.ndarray:
    """The world centre of an object's bounding box."""
    corners = np.array([tuple(obj.matrix_world @ Vector(c)) for c in obj.bound_box])
    return (corners.min(0) + corners.max(0)) / 2


def focus_on_object(projector, camera, target) -> tuple[float, float]:
    """Focus the projector's and the camera's lenses on the target's centre; returns both distances."""
    centre = object_centre(target)
    distances = []
    for obj, settings in ((projector, projector.lapig_projector), (camera, camera.lapig_camera)):
        if obj is None:
            distances.append(0.0)
            continue
        distance = axial_distance(obj, centre)
        if distance <= 0:
            raise RigError(f"'{target.name}' is behind '{obj.name}': aim the rig at it first")
        settings.focus_distance = distance
        distances.append(distance)
    return distances[0], distances[1]
