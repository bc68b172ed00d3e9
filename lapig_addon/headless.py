"""Headless building blocks shared by the CLI, the benchmarks and the tests (bpy module or blender -b)."""
from __future__ import annotations

import os

import bpy

from . import demo_scene, rig
from .capture_job import CaptureJob, CaptureSettings  # noqa


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
    lp = scene.lapig
    job = CaptureJob(scene, projector or lp.projector, camera or lp.camera, target or lp.target, settings)
    return job.run_to_completion(on_progress=progress)


def render_synthetic_setups(specs, out, train, test, seed=0, skip_existing=True, sheet=None) -> dict:
    """Capture each synthetic setup into `out/<name>`, a data set root of its own; returns figures.

    Own roots because the public layout shares the projector images of a root between its setups,
    and every setup here projects its own seeded patterns.
    """
    import time

    from ..lapig_core import dataset as ds
    from ..lapig_core.imageio import write_png
    from . import synthetic_setups as syn

    out = os.path.abspath(out)
    textures = ensure_dir(os.path.join(out, "textures"))
    summary = {}
    for spec in specs:
        layout = syn.layout(out, spec.name)
        if skip_existing and layout.setup_json.exists():
            print(f"{spec.name}: already captured", flush=True)
            continue
        t = time.perf_counter()
        scene, projector, camera, target = syn.build_setup(spec, textures)
        settings = CaptureSettings(out_dir=str(layout.root), setup_name=spec.name, train_count=train, test_count=test,
                                   ambient=spec.ambient, seed=seed + spec.seed)
        result = run_capture(scene, settings)
        meta = result["meta"]
        meta["synthetic_setup"] = spec.to_dict()
        ds.write_setup_json(layout, meta)
        if sheet is not None:
            write_png(os.path.join(out, f"{spec.name}_sheet.png"), sheet(result["setup_dir"]))
        summary[spec.name] = {"working_valid_fraction": round(meta["working_valid_fraction"], 3),
                              "seconds": round(time.perf_counter() - t, 1)}
        print(f"{spec.name}: {summary[spec.name]}", flush=True)
    return summary


_last_progress = {"message": None}


def print_progress(progress, message):
    """One line per new message (a worker job reports the same state on every poll)."""
    if message == _last_progress["message"]:
        return
    _last_progress["message"] = message
    print(f"[{progress:6.1%}] {message}", flush=True)


def ensure_dir(path):
    os.makedirs(path, exist_ok=True)
    return path
