"""Headless building blocks shared by the CLI, the benchmarks and the tests (bpy module or blender -b)."""
from __future__ import annotations

import os

import bpy

from ..blender import demo_scene, rig
from ..blender.scene_store import scene_seams
from ..services.capture.capture_job import CaptureJob, CaptureSettings
from .output import print_progress  # noqa: F401 (re-exported)


def build_demo_setup(shape="panel", surface="sakura", folder=None, seed=0, camera_resolution=(480, 360),
                     tint=(1.0, 1.0, 1.0), texture=None, projector_resolution=(800, 600), throw_ratio=1.5,
                     wall_size=None, finish="matte"):
    """A fresh scene with a textured object, a projector and a camera placed around it.

    tint and texture as in demo_scene.add_surface_object (texture: the user's own image);
    wall_size (width, height) in metres: the panel's size (default 2 x 2; a wide facade: (3.6, 2.0)).
    """
    if wall_size and shape != "panel":
        raise ValueError(f"a wall size is for the panel, not the {shape}")
    demo_scene.new_empty_scene()
    target = demo_scene.add_surface_object(shape, surface, folder=folder, seed=seed, tint=tint, texture=texture,
                                          finish=finish)
    if wall_size:  # the panel is a 2 m plane stood up: its local x and y are the wall's width and height
        target.scale = (wall_size[0] / 2.0, wall_size[1] / 2.0, 1.0)
        bpy.context.view_layer.update()
    bpy.context.view_layer.objects.active = target
    scene = bpy.context.scene
    camera = rig.create_camera(scene)
    camera.lapig_camera.resolution_x, camera.lapig_camera.resolution_y = camera_resolution
    projector = rig.create_projector(scene)
    settings = projector.lapig_projector
    (settings.resolution_x, settings.resolution_y), settings.throw_ratio = projector_resolution, throw_ratio
    projector, camera, _ = rig.add_rig(bpy.context, target, projector=projector, camera=camera)  # lens fits
    return bpy.context.scene, projector, camera, target


def run_capture(scene, settings: CaptureSettings, projector=None, camera=None, target=None, progress=None,
                devices=None):
    """Capture the given rig objects (None: the scene's own; devices: another device factory, e.g. a
    simulated real rig) to completion; a capture of the scene's own rig is recorded in the scene, as the
    panel's."""
    record = projector is None and camera is None and target is None
    seams = scene_seams(scene, projector, camera, target, devices=devices)
    return CaptureJob(seams, settings, record=record).run_to_completion(on_progress=progress)


def ensure_dir(path):
    os.makedirs(path, exist_ok=True)
    return path
