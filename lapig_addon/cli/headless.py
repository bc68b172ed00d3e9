"""Headless building blocks shared by the CLI, the benchmarks and the tests (bpy module or blender -b)."""
from __future__ import annotations

import os

import bpy

from ..blender import demo_scene, rig, scene_state
from ..services.capture_job import CaptureJob, CaptureSettings
from .output import print_progress  # noqa: F401 (re-exported)


def build_demo_setup(shape="panel", surface="sakura", folder=None, seed=0, camera_resolution=(480, 360),
                     tint=(1.0, 1.0, 1.0), texture=None):
    """A fresh scene with a textured object, a projector and a camera placed around it.

    tint and texture as in demo_scene.add_surface_object (texture: the user's own image).
    """
    demo_scene.new_empty_scene()
    target = demo_scene.add_surface_object(shape, surface, folder=folder, seed=seed, tint=tint, texture=texture)
    bpy.context.view_layer.objects.active = target
    camera = rig.create_camera(bpy.context.scene)
    camera.lapig_camera.resolution_x, camera.lapig_camera.resolution_y = camera_resolution
    projector, camera, _ = rig.add_rig(bpy.context, target, camera=camera)  # lens fits this aspect
    return bpy.context.scene, projector, camera, target


def run_capture(scene, settings: CaptureSettings, projector=None, camera=None, target=None, progress=None):
    """Capture the given rig objects (None: the scene's own) to completion."""
    own = scene_state.rig_objects(scene)
    job = CaptureJob(scene, projector or own[0], camera or own[1], target or own[2], settings)
    return job.run_to_completion(on_progress=progress)


def ensure_dir(path):
    os.makedirs(path, exist_ok=True)
    return path
