"""Implementations of the CLI commands (bpy work happens here, on the main thread)."""
from __future__ import annotations

import os
import shutil
import time

import bpy
import numpy as np

from ...lapig_core.capture import dataset as ds
from ...lapig_core.common.imageio import read_image, write_png
from ...lapig_core.common.sheets import labelled_grid
from ..blender import addon, storage
from . import headless
from ..services.capture_job import CaptureSettings
from .output import print_json


def _ensure_registered():
    if not addon.is_registered():
        addon.register()


def cmd_demo(args) -> int:
    """The README's main job: demo scene -> capture -> models -> prompt -> projector image -> render."""
    from ..services import export_result
    from ..services.pipeline_jobs import GenerateJob, RenderResultJob, TrainModelsJob

    _ensure_registered()
    out = os.path.abspath(args.out)
    os.makedirs(out, exist_ok=True)
    t0 = time.perf_counter()
    timings = {}
    scene, projector, camera, target = headless.build_demo_setup(args.shape, args.surface, folder=out,
                                                                 seed=args.seed)
    blend_path = os.path.join(out, "demo.blend")
    bpy.ops.wm.save_as_mainfile(filepath=blend_path)  # data then lives beside it, in demo_lapig/
    scene = bpy.context.scene
    name = storage.setup_name_for(target)
    settings = CaptureSettings(out_dir=storage.capture_root(name), setup_name=name, train_count=args.train,
                               test_count=args.test, seed=args.seed)
    t = time.perf_counter()
    result = headless.run_capture(scene, settings, progress=headless.print_progress)
    timings["capture_s"] = round(time.perf_counter() - t, 2)
    scene.lapig.last_capture_dir = str(result["setup_dir"])
    scene.lapig.last_capture_fingerprint = result["meta"]["fingerprint"]
    write_png(os.path.join(out, "contact_sheet.png"), contact_sheet(result["setup_dir"]))
    t = time.perf_counter()
    TrainModelsJob(scene).run_to_completion(on_progress=headless.print_progress)
    timings["train_s"] = round(time.perf_counter() - t, 2)
    scene.lapig.prompt = args.prompt
    t = time.perf_counter()
    generated = GenerateJob(scene).run_to_completion(on_progress=headless.print_progress)
    timings["stylize_s"] = round(time.perf_counter() - t, 2)
    t = time.perf_counter()
    rendered = RenderResultJob(scene).run_to_completion()
    timings["render_s"] = round(time.perf_counter() - t, 2)
    exported = export_result.export_current(scene, os.path.join(out, "projector_image.png"))
    scene.lapig.preview_mode = "TARGET"
    bpy.ops.wm.save_mainfile()
    sheet_path = os.path.join(out, "comparison.png")
    shutil.copyfile(os.path.join(generated["folder"], "comparison.png"), sheet_path)
    meta = result["meta"]
    m = rendered["metrics"]
    timings["total_s"] = round(time.perf_counter() - t0, 2)
    summary = {"comparison_sheet": sheet_path, "contact_sheet": os.path.join(out, "contact_sheet.png"),
               "projector_image": str(exported["image"]), "blend": blend_path, "result": generated["folder"],
               "prompt": args.prompt, "styles": generated["summary"]["lgst"].get("styles"),
               "rendered_psnr": round(m.get("rendered_psnr", float("nan")), 3),
               "rendered_psnr_nopsa": round(m.get("rendered_psnr_nopsa", float("nan")), 3),
               "registration_error_px_median": meta["registration"].get("registration_error_px_median"),
               **timings}
    print(f"Look at {sheet_path} and {summary['contact_sheet']}; open {blend_path} in Blender")
    print_json(summary)
    return 0


def contact_sheet(setup_dir) -> np.ndarray:
    """Raw and registered references, a few Gray-code captures, and training pairs."""
    layout = ds.DatasetLayout(os.path.dirname(os.path.dirname(setup_dir)), os.path.basename(setup_dir))
    images, labels = [], []
    for i, name in enumerate(["I- (black)", "I+ (white)", "s (gray)"], start=1):
        images.append(read_image(layout.image_path(layout.cam_raw_dir("ref"), i)))
        labels.append(f"raw {name}")
    for i, name in enumerate(["I- (black)", "I+ (white)", "s (gray)"], start=1):
        images.append(read_image(layout.image_path(layout.cam_warp_dir("ref"), i)))
        labels.append(f"registered {name}")
    for i in (1, 7, 15):
        images.append(read_image(layout.image_path(layout.cam_raw_dir("sl"), i)))
        labels.append(f"Gray code {i}")
    for i in (1, 2, 3):
        images.append(read_image(layout.image_path(layout.prj_dir("train"), i)))
        labels.append(f"projected train {i}")
        images.append(read_image(layout.image_path(layout.cam_raw_dir("train"), i)))
        labels.append(f"raw capture {i}")
        images.append(read_image(layout.image_path(layout.cam_warp_dir("train"), i)))
        labels.append(f"registered capture {i}")
    return labelled_grid(images, labels, columns=6, cell=220, title=f"LAPIG capture set: {layout.setup}")


def cmd_capture(args) -> int:
    _ensure_registered()
    if args.blend:
        if not os.path.isfile(args.blend):
            raise ValueError(f"no such .blend file: {args.blend}")
        bpy.ops.wm.open_mainfile(filepath=args.blend)
    scene = bpy.context.scene
    s = scene.lapig
    if s.target is None:
        raise ValueError("the scene has no LAPIG rig: add the projector and camera first (or run 'demo')")
    settings = CaptureSettings(out_dir=os.path.abspath(args.out),
                               setup_name=args.setup or storage.setup_name_for(s.target),
                               train_count=args.train, test_count=args.test, working_size=args.size,
                               samples=args.samples, pattern_folder=args.patterns, seed=args.seed)
    result = headless.run_capture(scene, settings, progress=headless.print_progress)
    print_json({"setup_dir": str(result["setup_dir"]), **result["meta"]["registration"],
                "valid_fraction": result["meta"]["valid_fraction"]})
    return 0








def _open_scene(args):
    _ensure_registered()
    if getattr(args, "blend", None):
        if not os.path.isfile(args.blend):
            raise ValueError(f"no such .blend file: {args.blend}")
        bpy.ops.wm.open_mainfile(filepath=os.path.abspath(args.blend))
    scene = bpy.context.scene
    if scene.lapig.target is None:
        raise ValueError("the scene has no LAPIG rig: add the projector and camera first (or run 'demo')")
    return scene


def _save_if_asked(args):
    if getattr(args, "save", False):
        if not bpy.data.filepath:
            raise ValueError("--save needs a .blend opened with --blend")
        bpy.ops.wm.save_mainfile()


def cmd_train(args) -> int:
    from ..services.pipeline_jobs import TrainModelsJob

    scene = _open_scene(args)
    out = TrainModelsJob(scene).run_to_completion(on_progress=headless.print_progress)
    _save_if_asked(args)
    print_json({"capture": out["folder"], "train_s": round(out["seconds"], 2)})
    return 0


def cmd_stylize(args) -> int:
    from ..services.pipeline_jobs import GenerateJob, RenderResultJob

    scene = _open_scene(args)
    s = scene.lapig
    s.prompt, s.backend, s.style_override, s.style_seed = args.prompt, args.backend, args.mix, args.seed
    if not 0.0 < args.strength < 1.0:
        raise ValueError("--strength must be between 0 and 1")
    s.use_psa, s.psa_strength = args.psa, args.strength
    out = GenerateJob(scene).run_to_completion(on_progress=headless.print_progress)
    summary = dict(out["summary"]["metrics"])
    if args.render:
        summary.update(RenderResultJob(scene).run_to_completion()["metrics"])
    _save_if_asked(args)
    print(f"Look at {os.path.join(out['folder'], 'comparison.png')}")
    print_json({"result": out["folder"], "styles": out["summary"]["lgst"].get("styles"), **summary})
    return 0


def cmd_export(args) -> int:
    from ..services import export_result

    scene = _open_scene(args)
    scene.lapig.export_bit_depth = str(args.bit_depth)
    written = export_result.export_current(scene, os.path.abspath(args.out))
    summary = {k: str(v) for k, v in written.items()}
    if args.crossfade:
        scene.lapig.crossfade_frames = args.frames
        frames = export_result.export_crossfade(scene, os.path.abspath(args.crossfade))
        summary["crossfade_frames"] = len(frames)
    print_json(summary)
    return 0



