"""`python -m lapig_addon bench frame --json`: the whole projector frame at its native resolution.

Two walls, each captured once at the working frame: the demo wall (4:3, 800x600) and a wide one
(16:9, 1920x1080 on a 3.6 x 2 m wall). On each, the PSA look is made at native resolution
(the new path) and the projector images of both paths are rendered with Cycles and registered at
native resolution:
  new path  the look and its compensation over the whole frame at native resolution;
  old path  what the code did before the working frame: a 256x256 working square in the middle
            of the frame (side min(W, H)), compensated at 256 and upscaled (Lanczos, clamped),
            black elsewhere. It is emulated with the new path's models and references, on the
            same look (the native target's central square at 256), so the two differ only in
            coverage and resolution.
Figures, per wall and path, against the native target over the frame's on-object pixels:
frame_coverage (share of the on-object pixels that carry the compensated look),
native_rendered_psnr / _ssim, sharpness_ratio (variance of the Laplacian of the rendered capture
over the target's, both after a 1-px Gaussian so the camera's sensor noise does not count as
detail); for the new path native_seconds (finished PSA -> the native 16-bit projector
image on disk), peak_rss_mb (the process's peak resident memory during that step) and
psa_seconds at the working frame.
"""
from __future__ import annotations

import os
import platform
import time

import bpy
import cv2
import numpy as np
import torch

from ...lapig_core.capture.dataset import load_capture_set
from ...lapig_core.capture.native_references import registered_references
from ...lapig_core.common import metrics
from ...lapig_core.common.imageio import write_png
from ...lapig_core.common.resample import resize_image
from ...lapig_core.common.sheets import labelled_grid
from ...lapig_core.common.surfaces import make_surface
from ...lapig_core.pipeline import as_image, output_at, stylize, surface_models
from ...lapig_core.psa.adaptation import PSASettings
from ...lapig_core.photometric.training_data import to_tensor
from .projection_render import register_at, render_working_images
from ..evaluate import SHARPNESS_SIGMA, build_surface_scene, capture_surface

WALLS = (  # name, projector, wall (m), camera
    ("4x3", (800, 600), None, (800, 600)),
    ("16x9", (1920, 1080), (3.6, 2.0), (1920, 1080)),
)
PROMPT = "Render it in the style of a Van Gogh oil painting"
OLD_WORKING_SIZE = 256


def _log(args, msg):
    if not args.json:
        print(msg, flush=True)


class PeakMemory:
    """The process's peak resident memory over a block, in MB (Linux: VmHWM, reset on entry)."""

    def __enter__(self):
        try:
            with open("/proc/self/clear_refs", "w") as f:
                f.write("5")
        except OSError:
            pass
        return self

    def __exit__(self, *exc):
        self.mb = None
        try:
            with open("/proc/self/status") as f:
                self.mb = next(int(line.split()[1]) / 1024 for line in f if line.startswith("VmHWM"))
        except (OSError, StopIteration):
            pass


def old_path_frame(models, target, setup_dir, width, height) -> tuple[np.ndarray, np.ndarray]:
    """The old path's native frame (H, W, 3) for a native target, and where it carries the look."""
    side = min(width, height)
    x0, y0 = (width - side) // 2, (height - side) // 2
    refs = registered_references(setup_dir, width, height)

    def square(img):  # the central square at the old working size
        return cv2.resize(np.ascontiguousarray(img[y0:y0 + side, x0:x0 + side]), (OLD_WORKING_SIZE,) * 2,
                          interpolation=cv2.INTER_AREA)

    with torch.no_grad():
        working = models.compensator(to_tensor(square(target)), to_tensor(square(refs.gray)))
    frame = np.zeros((height, width, 3), np.float32)
    frame[y0:y0 + side, x0:x0 + side] = resize_image(as_image(working), side, side)
    covered = np.zeros((height, width), bool)
    covered[y0:y0 + side, x0:x0 + side] = True
    return frame, covered


def _figures(captured, target, valid, covered) -> dict:
    return {"frame_coverage": round(float((valid & covered).sum() / max(valid.sum(), 1)), 4),
            "native_rendered_psnr": round(metrics.masked_psnr(captured, target, valid), 3),
            "native_rendered_ssim": round(metrics.ssim(captured, target), 4),
            "sharpness_ratio": round(metrics.sharpness(captured, valid, SHARPNESS_SIGMA)
                                     / metrics.sharpness(target, valid, SHARPNESS_SIGMA), 4)}


def run_wall(name, projector, wall, camera, args, out):
    t0 = time.perf_counter()
    folder = os.path.join(out, name)
    os.makedirs(folder, exist_ok=True)
    rig_objects = build_surface_scene(make_surface("sakura", size=1024, seed=7), folder, name="sakura",
                                      projector=projector, wall=wall, camera=camera)
    setup_dir = capture_surface(*rig_objects, os.path.join(folder, "data"), setup=name, train=args.train,
                                seed=args.seed, working_size=OLD_WORKING_SIZE)
    cs = load_capture_set(setup_dir)
    capture_s = time.perf_counter() - t0
    models = surface_models(cs, iterations=args.iterations)
    settings = PSASettings(seed=args.seed)
    settings.max_iterations = args.psa_iterations or settings.max_iterations
    res = stylize(cs, models, PROMPT, seed=args.seed, settings=settings)
    _log(args, f"{name}: working frame {cs.frame_size}, PSA {res.with_psa.seconds:.1f} s")
    width, height = projector
    with PeakMemory() as peak:
        t = time.perf_counter()
        native = output_at(cs, models, res, width, height)
        write_png(os.path.join(folder, "projector_native.png"), as_image(native.projector_image), bit_depth=16)
        native_s = time.perf_counter() - t
    target, new_frame = as_image(native.target), as_image(native.projector_image)
    old_frame, old_covered = old_path_frame(models, target, setup_dir, width, height)
    _, raw = render_working_images(*rig_objects, setup_dir, [new_frame, old_frame], return_raw=True)
    rendered = [register_at(setup_dir, r, width, height) for r in raw]
    valid = rendered[0][1]
    new = {**_figures(rendered[0][0], target, valid, np.ones_like(valid)), "native_seconds": round(native_s, 2),
           "peak_rss_mb": round(peak.mb, 1) if peak.mb else None, "psa_seconds": round(res.with_psa.seconds, 2),
           "psa_iterations": res.with_psa.iterations, "working_frame": list(cs.frame_size), "tile": native.tile}
    old = _figures(rendered[1][0], target, valid, old_covered)
    for image_name, image in (("target_native", target), ("rendered_new", rendered[0][0]),
                              ("projector_old", old_frame), ("rendered_old", rendered[1][0])):
        write_png(os.path.join(folder, image_name + ".png"), image, bit_depth=16)
    sheet = os.path.join(out, f"sheet_{name}.png")
    write_png(sheet, labelled_grid([target, new_frame, rendered[0][0], old_frame, rendered[1][0]],
                                   ["target (native)", "new: projector image", "new: rendered",
                                    "old: projector image", "old: rendered"], columns=5, cell=384,
                                   title=f"{name} wall, {width}x{height}: '{PROMPT}'"))
    return {"new": new, "old": old, "sheet": sheet, "capture_s": round(capture_s, 1),
            "total_s": round(time.perf_counter() - t0, 1)}


def run(args) -> dict:
    t0 = time.perf_counter()
    out = os.path.abspath(args.out)
    os.makedirs(out, exist_ok=True)
    walls = {name: run_wall(name, projector, wall, camera, args, out) for name, projector, wall, camera in WALLS}
    wide = walls["16x9"]
    return {
        "frame_coverage_4x3": walls["4x3"]["new"]["frame_coverage"],
        "frame_coverage_16x9": wide["new"]["frame_coverage"],
        "frame_coverage_old_4x3": walls["4x3"]["old"]["frame_coverage"],
        "frame_coverage_old_16x9": wide["old"]["frame_coverage"],
        "native_rendered_psnr_16x9": wide["new"]["native_rendered_psnr"],
        "native_rendered_psnr_old_16x9": wide["old"]["native_rendered_psnr"],
        "native_psnr_gain_16x9": round(wide["new"]["native_rendered_psnr"] - wide["old"]["native_rendered_psnr"], 3),
        "sharpness_ratio_16x9": wide["new"]["sharpness_ratio"], "sharpness_ratio_old_16x9": wide["old"]["sharpness_ratio"],
        "native_seconds_1080p": wide["new"]["native_seconds"], "peak_rss_mb_1080p": wide["new"]["peak_rss_mb"],
        "psa_seconds_16x9": wide["new"]["psa_seconds"], "psa_seconds_4x3": walls["4x3"]["new"]["psa_seconds"],
        "walls": walls, "prompt": PROMPT, "train": args.train, "iterations": args.iterations,
        "bench_total_s": round(time.perf_counter() - t0, 1), "cpu_threads": torch.get_num_threads(),
        "machine": platform.processor() or platform.machine(), "blender": bpy.app.version_string,
    }
