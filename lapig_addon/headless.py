"""Headless building blocks shared by the CLI, the benchmarks and the tests (bpy module or blender -b)."""
from __future__ import annotations

import os

import bpy

from . import demo_scene, rig
from .capture_job import CaptureJob, CaptureSettings  # noqa


def build_demo_setup(shape="panel", surface="sakura", folder=None, seed=0, camera_resolution=(480, 360)):
    """A fresh scene with a textured object, a projector and a camera placed around it."""
    demo_scene.new_empty_scene()
    target = demo_scene.add_surface_object(shape, surface, folder=folder, seed=seed)
    bpy.context.view_layer.objects.active = target
    camera = rig.create_camera(bpy.context.scene)
    camera.lapig_camera.resolution_x, camera.lapig_camera.resolution_y = camera_resolution
    projector, camera, _ = rig.add_rig(bpy.context, target, camera=camera)  # lens fits this aspect
    return bpy.context.scene, projector, camera, target


def run_capture(scene, settings: CaptureSettings, projector=None, camera=None, target=None, progress=None):
    lp = scene.lapig
    job = CaptureJob(scene, projector or lp.projector, camera or lp.camera, target or lp.target, settings)
    return job.run_to_completion(on_progress=progress)


def print_progress(progress, message):
    print(f"[{progress:6.1%}] {message}", flush=True)


def ensure_dir(path):
    os.makedirs(path, exist_ok=True)
    return path
