"""`python -m lapig_addon bench capture --json`: capture speed and registration accuracy.

captures_per_second counts registered working-size captures of training/test patterns per
wall-clock second: Cycles render, camera response, registration and PNG writes included.
"""
from __future__ import annotations

import os
import platform
import shutil
import time

import bpy

from ...lapig_addon.blender import scene_state
from ...lapig_addon.cli import headless


def run(args) -> dict:
    out = os.path.abspath(args.out)
    shutil.rmtree(out, ignore_errors=True)
    os.makedirs(out)
    t0 = time.perf_counter()
    try:
        cam_w, cam_h = (int(v) for v in args.camera.lower().split("x"))
    except ValueError:
        raise ValueError(f"--camera must look like 480x360, got '{args.camera}'") from None
    scene, projector, camera, target = headless.build_demo_setup(args.shape, "sakura", folder=out,
                                                                 camera_resolution=(cam_w, cam_h))
    count = max(2, args.patterns)
    settings = scene_state.capture_settings(scene, out_dir=os.path.join(out, "dataset"), setup_name="bench",
                                            train_count=count - count // 5, test_count=count // 5)
    progress = None if args.json else headless.print_progress
    result = headless.run_capture(scene, settings, progress=progress)
    meta = result["meta"]
    timings = meta["timings"]
    model, cam = scene_state.projector_model(projector), scene_state.camera_settings(camera)
    return {
        "captures_per_second": round(timings["pattern_count"] / timings["patterns_s"], 3),
        "pattern_captures": timings["pattern_count"],
        "registration_error_px_median": round(meta["registration"]["registration_error_px_median"], 4),
        "registration_error_px_p95": round(meta["registration"]["registration_error_px_p95"], 4),
        "registration_points": meta["registration"]["registration_points"],
        "valid_fraction": round(meta["valid_fraction"], 4),
        "working_valid_fraction": round(meta["working_valid_fraction"], 4),
        "structured_light_s": round(timings["structured_light_render_s"], 3),
        "registration_build_s": round(timings["registration_build_s"], 3),
        "capture_total_s": timings["total_s"],
        "bench_total_s": round(time.perf_counter() - t0, 2),
        "projector_resolution": f"{model.width}x{model.height}",
        "camera_resolution": f"{cam.width}x{cam.height}",
        "samples": settings.samples,
        "shape": args.shape,
        "cpu_threads": os.cpu_count(),
        "machine": platform.processor() or platform.machine(),
        "blender": bpy.app.version_string,
    }
