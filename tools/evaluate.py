"""`python -m lapig_addon eval`: one surface image, one prompt, with and without PSA, captured for real.

Builds a wall panel textured with the image, captures it, fine-tunes the models, stylizes with and
without PSA, projects both compensated images with Cycles (the "real capture"), and writes
DIR/sheet.png (surface | target without PSA | captured without | target with PSA | captured with)
and DIR/metrics.json.
"""
from __future__ import annotations

import json
import os
import time

import numpy as np

from ..lapig_core.common import metrics
from ..lapig_core.capture.dataset import load_capture_set
from ..lapig_core.common.imageio import atomic_write_bytes, read_image, write_png
from ..lapig_core.pipeline import as_image, stylize, surface_models
from ..lapig_core.psa.adaptation import PSASettings
from ..lapig_core.common.sheets import labelled_grid
from ..lapig_core.lgst import backend_class
from ..lapig_core.lgst.prompt_mapping import validate_prompt
from ..lapig_addon.blender import scene_state
from ..lapig_addon.blender.projection_render import render_working_images
from ..lapig_addon.cli import headless


def build_surface_scene(image: np.ndarray, folder: str, name: str = "surface", shape: str = "panel"):
    """The demo rig around an object textured with `image`."""
    return headless.build_demo_setup(shape, name, folder=folder, texture=image)


def capture_surface(scene, projector, camera, target, data_dir, setup="surface", train=125, test=0, seed=0):
    settings = scene_state.capture_settings(scene, out_dir=data_dir, setup_name=setup, train_count=train,
                                            test_count=test, seed=seed)
    result = headless.run_capture(scene, settings, projector, camera, target)
    return result["setup_dir"]


def evaluate_prompt(cs, models, rig_objects, setup_dir, prompt, backend="styletransfer", seed=0,
                    settings: PSASettings | None = None, progress=None) -> tuple[dict, dict]:
    """Stylize with and without PSA, render both for real; (metrics, images)."""
    t = time.perf_counter()
    res = stylize(cs, models, prompt, backend=backend, seed=seed, settings=settings, on_progress=progress)
    psa_s = time.perf_counter() - t
    targets = [as_image(res.without.target), as_image(res.with_psa.target)]
    projector_images = [as_image(res.without.projector_image), as_image(res.with_psa.projector_image)]
    scene, projector, camera, target = rig_objects
    t = time.perf_counter()
    captured = render_working_images(scene, projector, camera, target, setup_dir, np.stack(projector_images))
    render_s = time.perf_counter() - t
    out = {"prompt": prompt, "backend": backend, "seed": seed, "lgst": res.describe,
           "psa_settings": res.settings.to_dict()}
    for key, i, r in (("without_psa", 0, res.without), ("with_psa", 1, res.with_psa)):
        figures = metrics.evaluate(captured[i], targets[i])
        simulated = metrics.psnr(as_image(r.simulated), targets[i])
        out[key] = {**{k: round(v, 4) for k, v in figures.items()}, "simulated_psnr": round(simulated, 4),
                    "iterations": r.iterations, "seconds": round(r.seconds, 2), "stopped": r.stopped}
    out["style_retention"] = {k: round(v, 4) for k, v in res.style_retention().items()}
    out["psa_s"], out["render_s"] = round(psa_s, 2), round(render_s, 2)
    images = {"targets": targets, "captured": list(captured), "projector_images": projector_images}
    return out, images


def comparison_sheet(surface, images, title):
    tiles = [surface, images["targets"][0], images["captured"][0], images["targets"][1], images["captured"][1]]
    labels = ["surface (I+)", "target without PSA", "captured without PSA", "target with PSA", "captured with PSA"]
    return labelled_grid(tiles, labels, columns=5, cell=256, title=title)


def run(args) -> dict:
    t0 = time.perf_counter()
    # every input checked before the capture and the training, which take minutes
    validate_prompt(args.prompt)
    backend_class(args.backend)
    image = read_image(args.surface)
    out = os.path.abspath(args.out)
    os.makedirs(out, exist_ok=True)
    rig_objects = build_surface_scene(image, out)
    t = time.perf_counter()
    setup_dir = capture_surface(*rig_objects, os.path.join(out, "dataset"), train=args.train, seed=args.seed)
    capture_s = time.perf_counter() - t
    cs = load_capture_set(setup_dir)
    t = time.perf_counter()
    models = surface_models(cs, on_progress=headless.print_progress if args.verbose else None,
                            iterations=args.iterations)
    train_s = time.perf_counter() - t
    settings = PSASettings(seed=args.seed, max_iterations=args.psa_iterations)
    result, images = evaluate_prompt(cs, models, rig_objects, setup_dir, args.prompt, args.backend, args.seed,
                                     settings)
    sheet = comparison_sheet(cs.cam_white, images, f"'{args.prompt}' ({', '.join(n for n, _ in result['lgst'].get('styles', []))})")
    write_png(os.path.join(out, "sheet.png"), sheet)
    for name, im in (("target_without_psa", images["targets"][0]), ("target_with_psa", images["targets"][1]),
                     ("projector_without_psa", images["projector_images"][0]),
                     ("projector_with_psa", images["projector_images"][1]),
                     ("captured_without_psa", images["captured"][0]), ("captured_with_psa", images["captured"][1])):
        write_png(os.path.join(out, name + ".png"), im)
    result["timings"] = {"capture_s": round(capture_s, 2), "train_s": round(train_s, 2), "psa_s": result.pop("psa_s"),
                         "render_s": result.pop("render_s"), "total_s": round(time.perf_counter() - t0, 2)}
    result["surface"] = os.path.abspath(args.surface)
    result["sheet"] = os.path.join(out, "sheet.png")
    atomic_write_bytes(os.path.join(out, "metrics.json"), json.dumps(result, indent=2, default=str).encode())
    return result
