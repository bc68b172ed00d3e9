"""`python -m lapig_addon eval`: one surface image, one prompt, with and without PSA, captured for real.

Builds a wall panel textured with the image (any projector resolution and throw ratio, any wall
size: a wide facade is `--projector 1920x1080 --wall 3.6x2`), captures it, fine-tunes the models,
stylizes with and without PSA at the working frame, makes the PSA look and its projector image at
the output size (native by default), projects the compensated images with Cycles (the "real
capture"), and writes DIR/sheet.png (surface | target without PSA | captured without | target with
PSA | captured with, all over the whole frame), DIR/native_sheet.png and DIR/metrics.json.
"""
from __future__ import annotations

import json
import os
import time

import cv2
import numpy as np

from ..lapig_core.common import metrics
from ..lapig_core.capture.dataset import load_capture_set
from ..lapig_core.common.atomic import atomic_write_bytes
from ..lapig_core.common.imageio import read_image, write_png
from ..lapig_core.native_output import output_frame, tile_for
from ..lapig_core.pipeline import as_image, output_at, stylize, surface_models
from ..lapig_core.psa.adaptation import PSASettings
from ..lapig_core.common.sheets import labelled_grid
from ..lapig_core.lgst import backend_class
from ..lapig_core.lgst.prompt_mapping import validate_prompt
from ..lapig_addon.blender import scene_state
from .bench.projection_render import register_at, render_working_images
from ..lapig_addon.cli import headless

SHARPNESS_SIGMA = 1.0  # px blurred before the Laplacian: finer, a rendered capture's detail is camera noise


def build_surface_scene(image: np.ndarray, folder: str, name: str = "surface", shape: str = "panel",
                        projector=(800, 600), throw_ratio=1.5, wall=None, camera=(480, 360)):
    """The demo rig around an object textured with `image`: projector (width, height) pixels, wall
    (width, height) metres for the panel, camera (width, height) pixels."""
    return headless.build_demo_setup(shape, name, folder=folder, texture=image, projector_resolution=projector,
                                     throw_ratio=throw_ratio, wall_size=wall, camera_resolution=camera)


def capture_surface(scene, projector, camera, target, data_dir, setup="surface", train=125, test=0, seed=0,
                    working_size=None):
    settings = scene_state.capture_settings(scene, out_dir=data_dir, setup_name=setup, train_count=train,
                                            test_count=test, seed=seed, working_size=working_size)
    result = headless.run_capture(scene, settings, projector, camera, target)
    return result["setup_dir"]


def evaluate_prompt(cs, models, rig_objects, setup_dir, prompt, backend="styletransfer", seed=0,
                    settings: PSASettings | None = None, progress=None, output=None) -> tuple[dict, dict]:
    """Stylize with and without PSA, render both for real; (metrics, images). output: (width,
    height) of the PSA look's native output (evaluate_native), None for none."""
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
    # structure: the style at any brightness (issue 13), beside the old SSIM that pays for darkening
    out["style_retention"] = {k: round(v, 4) for k, v in res.style_retention().items()}
    out["surface_reach"] = res.truth  # share of the look inside [I-, I+], clamp bound, message
    out["psa_s"], out["render_s"] = round(psa_s, 2), round(render_s, 2)
    images = {"targets": targets, "captured": list(captured), "projector_images": projector_images}
    if output is not None:
        out["native"], images["native"] = evaluate_native(cs, models, res, rig_objects, setup_dir, *output)
    return out, images


def evaluate_native(cs, models, res, rig_objects, setup_dir, width, height) -> tuple[dict, dict]:
    """The PSA look and its projector image at width x height, rendered for real and registered at
    that size; (figures, images). PSNR over the frame's on-object pixels, sharpness against the
    target's (variance of the Laplacian, after a SHARPNESS_SIGMA blur)."""
    native = output_at(cs, models, res, width, height)
    if native is None:  # the output is the working frame itself
        target, projector_image = as_image(res.with_psa.target), as_image(res.with_psa.projector_image)
        seconds, tile = 0.0, max(width, height)
    else:
        target, projector_image = as_image(native.target), as_image(native.projector_image)
        seconds, tile = native.seconds, native.tile
    _, raw = render_working_images(*rig_objects, setup_dir, projector_image[None], return_raw=True)
    captured, valid = register_at(setup_dir, raw[0], width, height)
    figures = {"frame": [width, height], "tile": tile, "seconds": round(seconds, 2),
               "psnr": round(metrics.masked_psnr(captured, target, valid), 4),
               "ssim": round(metrics.ssim(captured, target), 4),
               "sharpness_ratio": round(metrics.sharpness(captured, valid, SHARPNESS_SIGMA)
                                        / metrics.sharpness(target, valid, SHARPNESS_SIGMA), 4),
               "on_object_fraction": round(float(valid.mean()), 4)}
    return figures, {"target": target, "projector_image": projector_image, "captured": captured}


def evaluate_refine(cs, models, rig_objects, setup_dir, images, iterations) -> tuple[dict, dict]:
    """The PSA look's projector image refined on the rig (Refine on the rig's loop, through the Cycles device
    factory of the rig's objects), then captured once more with a fresh noise draw: (figures, images). The
    figures are metrics.evaluate's, as with_psa's, beside the loop's record; the native image refined too."""
    from ..lapig_addon.blender.cycles_factory import CyclesDeviceFactory
    from ..lapig_addon.services.refine.refine_job import refine_rounds
    from ..lapig_core.common.steps import run_to_end
    from ..lapig_core.photometric.choice import load_choice
    from ..lapig_core.photometric.classical import ClassicalModel
    from ..lapig_core.photometric.targets import reachable_mask
    from ..lapig_core.refine.loop import Refinement, RefineSettings

    saved = load_choice(os.path.join(setup_dir, "models"))
    model = saved[1] if saved is not None else ClassicalModel.fit(cs.prj_train, cs.cam_train)
    valid = reachable_mask(cs.cam_black, cs.cam_white)
    if cs.projector_valid is not None:
        valid &= cs.projector_valid
    target = images["targets"][1]
    refinement = Refinement(model, target, cs.cam_black, cs.cam_white, valid, images["projector_images"][1],
                            RefineSettings(iterations=iterations))
    devices = CyclesDeviceFactory(*rig_objects)
    t = time.perf_counter()
    run_to_end(refine_rounds(devices, setup_dir, refinement))
    seconds = time.perf_counter() - t
    projector_image = refinement.images[0]
    captured = render_working_images(*rig_objects, setup_dir, projector_image[None], seed=97)[0]
    out = {**{k: round(v, 4) for k, v in metrics.evaluate(captured, target).items()},
           "refine": refinement.record.to_dict(), "seconds": round(seconds, 2)}
    extra = {"projector_image": projector_image, "captured": captured}
    native = images.get("native")
    if native is not None:  # the native output refined itself, captured at native size as evaluate_native does
        h, w = native["target"].shape[:2]
        small = cv2.resize(native["target"], (target.shape[1], target.shape[0]), interpolation=cv2.INTER_AREA)
        on_native = Refinement(model, small, cs.cam_black, cs.cam_white, valid, None,
                               RefineSettings(iterations=iterations), native_start=native["projector_image"])
        run_to_end(refine_rounds(devices, setup_dir, on_native))
        _, raw = render_working_images(*rig_objects, setup_dir, on_native.images, return_raw=True, seed=98)
        cap_native, on = register_at(setup_dir, raw[0], w, h)
        out["native_psnr"] = round(metrics.masked_psnr(cap_native, native["target"], on), 4)
        out["native_refine"] = on_native.record.to_dict()
        extra.update(native_projector_image=on_native.images[0], native_captured=cap_native)
    return out, extra


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
    output = output_frame(args.output_size, *args.projector)  # refused before any work when too large
    tile_for(*output)
    out = os.path.abspath(args.out)
    os.makedirs(out, exist_ok=True)
    rig_objects = build_surface_scene(image, out, projector=args.projector, throw_ratio=args.throw_ratio,
                                      wall=args.wall, camera=args.camera)
    t = time.perf_counter()
    setup_dir = capture_surface(*rig_objects, os.path.join(out, "dataset"), train=args.train, seed=args.seed,
                                working_size=args.working_size)
    capture_s = time.perf_counter() - t
    cs = load_capture_set(setup_dir)
    t = time.perf_counter()
    models = surface_models(cs, on_progress=headless.print_progress if args.verbose else None,
                            iterations=args.iterations)
    train_s = time.perf_counter() - t
    settings = PSASettings(seed=args.seed, max_iterations=args.psa_iterations, adaptation=args.adaptation)
    result, images = evaluate_prompt(cs, models, rig_objects, setup_dir, args.prompt, args.backend, args.seed,
                                     settings, output=output)
    if getattr(args, "refine", 0):
        result["with_refine"], images["refined"] = evaluate_refine(cs, models, rig_objects, setup_dir, images,
                                                                   args.refine)
    sheet = comparison_sheet(cs.cam_white, images, f"'{args.prompt}' ({', '.join(n for n, _ in result['lgst'].get('styles', []))})")
    write_png(os.path.join(out, "sheet.png"), sheet)
    for name, im in (("target_without_psa", images["targets"][0]), ("target_with_psa", images["targets"][1]),
                     ("projector_without_psa", images["projector_images"][0]),
                     ("projector_with_psa", images["projector_images"][1]),
                     ("captured_without_psa", images["captured"][0]), ("captured_with_psa", images["captured"][1])):
        write_png(os.path.join(out, name + ".png"), im)
    if "refined" in images:
        for name in ("projector_image", "captured", "native_projector_image", "native_captured"):
            if name in images["refined"]:
                write_png(os.path.join(out, f"refined_{name}.png"), images["refined"][name], bit_depth=16)
    native = images["native"]
    for name in ("target", "projector_image", "captured"):
        write_png(os.path.join(out, f"native_{name}.png"), native[name], bit_depth=16)
    write_png(os.path.join(out, "native_sheet.png"),
              labelled_grid([native["target"], native["projector_image"], native["captured"]],
                            ["target (native)", "projector image (native)", "captured (native)"], columns=3,
                            cell=512, title=f"{args.prompt} at %dx%d" % tuple(result["native"]["frame"])))
    result["timings"] = {"capture_s": round(capture_s, 2), "train_s": round(train_s, 2), "psa_s": result.pop("psa_s"),
                         "render_s": result.pop("render_s"), "total_s": round(time.perf_counter() - t0, 2)}
    result["surface"] = os.path.abspath(args.surface)
    result["sheet"] = os.path.join(out, "sheet.png")
    atomic_write_bytes(os.path.join(out, "metrics.json"), json.dumps(result, indent=2, default=str).encode())
    return result
