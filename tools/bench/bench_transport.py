"""`python -m lapig_addon bench transport --json`: light transport as a real room has it.

  * defocus: horizontal bars projected onto a panel turned 55 degrees through the projector's focal
    distance; the blur radius of their edges, measured in the linear capture along each projector
    column band (through Blender's exact projector-to-camera geometry), against the thin lens's
    circle of confusion at that band's depth. The blur is applied in the projector's frame by the
    thin-lens formula, so this checks that chain end to end (frame blur, Cycles, camera sampling),
    not an independent optical simulation;
  * inter-reflection: on the concave corner, the bounce light of the capture's indirect pass against
    a converged reference (full resolution, 1024 samples, 12 bounces, no smoothing);
  * speed: registered captures per second, Realistic and Fast, on the demo wall and the corner;
  * pcnet (only when asked for): the paper's PCNet table on the realistic setups;
  * noise floor and compensation on the realistic setups (synthetic_setups.REALISTIC_SETUPS):
    uncompensated, classical, CompenNeSt on 8 and on 125 pairs (the app's camera-space loss), CompenNeSt on
    125 pairs with the paper's loss beside it, and the compensator the setup chose by measurement
    (lapig_core.photometric.choice), each beside the setup's noise floor;
  * a sheet of raw captures (corner, vase, bust) under a projected pattern, Fast against Realistic;
  * headroom (only when asked for): how much of the captures the per-pixel (classical) model misses
    because of the realistic transport: each realistic setup is also rendered Fast (same object, rig,
    patterns and seeds: its direct-light twin), the classical model is fitted on both, and its
    simulation of the held-out test captures is compared. What a model with spatial context (PCNet,
    CompenNeSt) could gain over the per-pixel one from the transport is about that difference.
"""
from __future__ import annotations

import math
import os
import platform
import time

import bpy
import numpy as np

from ...lapig_addon.blender import rig, scene_state
from ...lapig_addon.blender.cycles_device import CyclesCaptureDevice
from ...lapig_addon.cli import headless
from ...lapig_core.common.atomic import atomic_write_bytes
from ...lapig_core.common.imageio import write_png
from ...lapig_core.common.sheets import labelled_grid
from ...lapig_core.optics.transport import FAST, LightTransport
from .. import synthetic_setups as syn

BAR = 20  # projector pixels per bar of the defocus pattern (edges 20 px apart)


def _log(args, msg):
    if not args.json:
        print(msg, flush=True)


def realistic_specs(args) -> list:
    """The realistic setups --realistic-setups names (all of them when it names none)."""
    return [s for s in syn.REALISTIC_SETUPS if not args.realistic_setups or s.name in args.realistic_setups]


def psnr_over(pred, target, selection):
    """metrics.masked_psnr over (N, H, W) or (H, W) selected pixels, rounded for the JSON; None where none is."""
    from ...lapig_core.common import metrics

    return round(metrics.masked_psnr(pred, target, selection), 4) if np.any(selection) else None


def _linear(device, frames):
    return device._linear(frames)


# -- defocus ---------------------------------------------------------------------------------
def _edge_variance(profile, edges, half):
    """Mean variance of the line spread at each edge of a 1D profile (NaN-free windows only)."""
    out = []
    for e in edges:
        window = profile[e - half:e + half + 1]
        if len(window) < 2 * half + 1 or not np.isfinite(window).all():
            continue
        lsf = np.abs(np.diff(window))
        if lsf.sum() <= 0:
            continue
        x = np.arange(len(lsf))
        mean = (lsf * x).sum() / lsf.sum()
        out.append((lsf * (x - mean) ** 2).sum() / lsf.sum())
    return float(np.mean(out)) if out else math.nan


def defocus_run(args, out) -> dict:
    import cv2

    pw, ph = 320, 240
    scene, projector, camera, target = headless.build_demo_setup("panel", "sakura", folder=out,
                                                                 camera_resolution=(640, 480),
                                                                 projector_resolution=(pw, ph))
    camera.lapig_camera.noise = 0.0
    camera.lapig_camera.auto_exposure = False
    target.rotation_euler.z = math.radians(55)  # one side in front of the focus, one behind
    bpy.context.view_layer.update()
    focus, _ = rig.focus_on_object(projector, camera, target)
    lens_mm = args.lens_radius_mm
    blurred_t = LightTransport(bounces=0, vignetting=0.0, projector_focus_m=focus, projector_lens_radius_mm=lens_mm)
    rows = (np.arange(ph) // BAR) % 2
    bars = np.repeat((rows * 255).astype(np.uint8)[:, None], pw, 1)[..., None].repeat(3, -1)
    renders, radius = {}, None
    for name, t in (("sharp", FAST), ("blurred", blurred_t)):
        with CyclesCaptureDevice(scene, projector, camera, target, transport=t, ambient=0.0) as device:
            renders[name] = _linear(device, [bars])[0].mean(-1)
            if name == "blurred":
                radius = device._blur_radius
                xs, ys = np.meshgrid(np.arange(pw, dtype=float), np.arange(ph, dtype=float))
                cam_xy = device.geometry_checks().exact_projector_to_camera(np.stack([xs, ys], -1))
    map_x, map_y = cam_xy[..., 0].astype(np.float32), cam_xy[..., 1].astype(np.float32)
    seen = np.isfinite(map_x) & np.isfinite(map_y)
    profiles = {k: np.where(seen, cv2.remap(v.astype(np.float32), np.nan_to_num(map_x, nan=-10),
                                            np.nan_to_num(map_y, nan=-10), cv2.INTER_LINEAR), np.nan)
                for k, v in renders.items()}
    edges = np.arange(BAR, ph - BAR + 1, BAR)
    bands = []
    band = 8
    for x0 in range(0, pw - band + 1, band):
        cols = slice(x0, x0 + band)
        if not seen[:, cols].all(axis=0).any():
            continue
        ok = seen[:, cols].all(axis=0)
        pred = float(np.mean(radius[:, cols][:, ok]))
        var = {k: _edge_variance(np.nanmean(p[:, cols][:, ok], axis=1), edges, BAR // 2 - 1)
               for k, p in profiles.items()}
        if not all(np.isfinite(v) for v in var.values()):
            continue
        measured = 2 * math.sqrt(max(var["blurred"] - var["sharp"], 0.0))
        bands.append({"x": x0 + band // 2, "predicted_px": round(pred, 3), "measured_px": round(measured, 3)})
    counted = [b for b in bands if b["predicted_px"] >= args.min_blur_px]
    errors = [abs(b["measured_px"] - b["predicted_px"]) / b["predicted_px"] * 100 for b in counted]
    in_focus = [b for b in bands if b["predicted_px"] < 0.5]
    sheet = labelled_grid([renders["sharp"][..., None].repeat(3, -1) / max(renders["sharp"].max(), 1e-6),
                           renders["blurred"][..., None].repeat(3, -1) / max(renders["sharp"].max(), 1e-6)],
                          ["pinhole projector", f"lens radius {lens_mm:g} mm, focus {focus:.2f} m"], columns=2,
                          cell=480)
    write_png(os.path.join(out, "defocus_sheet.png"), sheet)
    return {"defocus_blur_error_pct": round(max(errors), 2) if errors else None,
            "defocus_blur_error_pct_mean": round(float(np.mean(errors)), 2) if errors else None,
            "defocus_bands_counted": len(counted), "defocus_min_blur_px": args.min_blur_px,
            "defocus_in_focus_measured_px_max": round(max((b["measured_px"] for b in in_focus), default=0.0), 3),
            "defocus_lens_radius_mm": lens_mm, "defocus_focus_m": round(focus, 3), "defocus_bands": bands}


# -- inter-reflection ------------------------------------------------------------------------
def interreflection_run(args, out) -> dict:
    scene, projector, camera, target = headless.build_demo_setup("corner", "wood", folder=out,
                                                                 camera_resolution=args.interreflection_camera)
    camera.lapig_camera.noise = 0.0
    camera.lapig_camera.auto_exposure = False
    ours_t = LightTransport(projector_lens_radius_mm=0.0, vignetting=0.0)
    # the reference is the other method (two renders, with and without bounces), converged, at full size
    ref_t = LightTransport(projector_lens_radius_mm=0.0, vignetting=0.0, bounces=12, bounce_method="difference",
                           indirect_samples=args.reference_samples, indirect_downscale=1, indirect_smooth_px=0.0)
    white = np.full((600, 800, 3), 235, np.uint8)
    half = white.copy()
    half[:, 400:] = 0  # one wall lit: the other wall's light is all bounce
    frames = [white, half]
    result = {}
    times = {}
    for name, t in (("direct", FAST), ("ours", ours_t), ("reference", ref_t)):
        with CyclesCaptureDevice(scene, projector, camera, target, transport=t, ambient=0.0) as device:
            t0 = time.perf_counter()
            result[name] = _linear(device, frames)
            times[name] = time.perf_counter() - t0
    obj = result["direct"][0].max(-1) > 1e-5
    figures = {}
    for i, frame_name in enumerate(("white", "half")):
        ours = (result["ours"][i] - result["direct"][i]).mean(-1)
        ref = (result["reference"][i] - result["direct"][i]).mean(-1)
        h, w = ours.shape
        b = 8
        blocks = lambda im: im[:h // b * b, :w // b * b].reshape(h // b, b, w // b, b).mean(axis=(1, 3))
        m = blocks(obj.astype(np.float32)) > 0.99
        ob, rb = blocks(ours)[m], blocks(ref)[m]
        figures[frame_name] = {
            "block_l1_pct": round(float(np.abs(ob - rb).sum() / rb.sum() * 100), 2),
            "total_pct": round(float(abs(ob.sum() - rb.sum()) / rb.sum() * 100), 2),
            "bounce_fraction_of_direct": round(float(ref[obj].sum() / max(result["direct"][i].mean(-1)[obj].sum(),
                                                                          1e-9)), 4)}
    sheet = labelled_grid([np.clip(x / max(result["reference"][0].max(), 1e-6), 0, 1)
                           for x in (result["direct"][1], result["ours"][1], result["reference"][1])] +
                          [np.clip((result[k][1] - result["direct"][1]) * 8 / max(result["reference"][0].max(), 1e-6),
                                   0, 1) for k in ("ours", "reference")],
                          ["direct only (half lit)", "ours: direct + bounce pass", "reference (1024 spp)",
                           "our bounce light x8", "reference bounce x8"], columns=5, cell=240)
    write_png(os.path.join(out, "interreflection_sheet.png"), sheet)
    return {"interreflection_error_pct": max(f["block_l1_pct"] for f in figures.values()),
            "interreflection": figures, "interreflection_reference_samples": args.reference_samples,
            "interreflection_camera": list(args.interreflection_camera), "bounce_method": ours_t.bounce_method,
            "interreflection_render_s": {k: round(v, 2) for k, v in times.items()}}


def bounce_noise_run(args, out) -> dict:
    """Noise the bounce pass adds: two Realistic renders of the same frame with two seeds (no ambient,
    no sensor noise), exposed as the camera would, against the camera model's own sensor noise."""
    from ...lapig_core.optics.camera_model import auto_exposure_stops

    scene, projector, camera, target = headless.build_demo_setup("corner", "sakura", folder=out,
                                                                 camera_resolution=(480, 360))
    sensor = camera.lapig_camera.noise
    frame = np.random.default_rng(3).integers(0, 256, (600, 800, 3)).astype(np.uint8)
    spread = {}
    for name, transport in (("fast", FAST), ("realistic", scene_state.light_transport(projector, camera))):
        renders = []
        for seed in (0, 1):
            with CyclesCaptureDevice(scene, projector, camera, target, transport=transport, ambient=0.0,
                                     seed=seed) as device:
                white = _linear(device, [np.full((600, 800, 3), 255, np.uint8)])[0]
                stops = auto_exposure_stops(white, mask=white.max(-1) > 1e-6)
                renders.append(_linear(device, [frame])[0] * 2 ** stops)
        on = white.max(-1) > 1e-6
        spread[name] = float(np.var((renders[0] - renders[1])[on]) / 2)
    # Fast renders differ between seeds too (the pixel-centre jitter flips projector pixels at their
    # edges): the bounce pass's own noise is what Realistic adds on top
    std = math.sqrt(max(spread["realistic"] - spread["fast"], 0.0))
    return {"bounce_noise_std": round(std, 5), "seed_spread_std_fast": round(math.sqrt(spread["fast"]), 5),
            "seed_spread_std_realistic": round(math.sqrt(spread["realistic"]), 5), "camera_noise_std": round(sensor, 5),
            "bounce_noise_of_camera_noise": round(std / sensor, 3) if sensor else None}


# -- speed -----------------------------------------------------------------------------------
def speed_run(args, out) -> dict:
    figures = {}
    for shape in ("panel", "corner"):
        for mode in ("REALISTIC", "FAST"):
            scene, projector, camera, target = headless.build_demo_setup(shape, "sakura", folder=out,
                                                                         camera_resolution=(480, 360))
            projector.lapig_projector.transport_mode = mode
            count = max(5, args.patterns)
            settings = scene_state.capture_settings(scene, out_dir=os.path.join(out, f"speed_{shape}_{mode}"),
                                                    setup_name="speed", train_count=count - count // 5,
                                                    test_count=count // 5)
            timings = headless.run_capture(scene, settings)["meta"]["timings"]
            key = "captures_per_second_" + ("realistic" if mode == "REALISTIC" else "fast")
            figures.setdefault(key, {})[shape] = round(timings["pattern_count"] / timings["patterns_s"], 3)
            _log(args, f"  speed {shape} {mode}: {figures[key][shape]} captures/s")
    return figures


# -- compensation on the realistic setups ------------------------------------------------------
def compensation_case(args, data, spec):
    """One realistic setup as the compensation studies use it: (capture set, surface tensors, reachable pixels,
    the first args.compensate test images made into desired captures, the classical model fitted on every
    training pair)."""
    from ...lapig_core.photometric.classical import ClassicalModel
    from ...lapig_core.photometric.targets import desired_targets, reachable_mask
    from ...lapig_core.photometric.training_data import SurfaceTensors

    cs = syn.load_setup(data, spec.name)
    mask = reachable_mask(cs.cam_black, cs.cam_white)
    count = min(args.compensate, len(cs.prj_test))
    targets = desired_targets(cs.prj_test[:count], cs.cam_black, cs.cam_white, mask)
    return cs, SurfaceTensors.from_capture_set(cs), mask, targets, ClassicalModel.fit(cs.prj_train, cs.cam_train)


def _write_partial(out, part, per_setup):
    """The part's per-setup rows so far, as out/<part>_partial.json (whole or not at all)."""
    import json

    text = json.dumps(per_setup, indent=1, sort_keys=True, default=float)
    atomic_write_bytes(os.path.join(out, f"{part}_partial.json"), text.encode("utf-8"))


def compensation_run(args, data, out) -> tuple[dict, list]:
    import torch

    from .projection_render import render_working_images
    from ...lapig_core.common import metrics
    from ...lapig_core.photometric import choice
    from ...lapig_core.photometric.finetune import CAMERA_SPACE, PAPER_LOSS, cpu_recipe, finetune
    from ...lapig_core.photometric.training import predict
    from ...lapig_core.photometric.training_data import to_numpy, to_tensor
    from ...lapig_core.capture.dataset import setup_dir_of
    from .noise_floor import below_floor, noise_floor
    from ..research import projector_space_choice

    torch.manual_seed(0)
    specs = realistic_specs(args)
    syn.render_synthetic_setups(specs, data, train=args.train_pairs, test=args.test_pairs, seed=600,
                                skip_existing=True)
    per_setup, sheet = {}, []

    def figures(pred, target, mask, reach=None):
        out = {"psnr_masked": round(metrics.masked_psnr(pred, target, mask), 4),
               "psnr": round(metrics.psnr(pred, target), 4), "ssim": round(metrics.ssim(pred, target), 4)}
        if reach is not None:  # where the classical model reaches the target, and where it would clip
            out["psnr_reachable"] = psnr_over(pred, target, reach)
            out["psnr_unreachable"] = psnr_over(pred, target, mask[None] & ~reach)
        return out

    for spec in specs:
        _log(args, f"{spec.name}:")
        cs, surf, mask, targets, classical = compensation_case(args, data, spec)
        count = len(targets)
        # the held-back pairs the choice validates on are the test pairs after the compensated ones
        val = slice(count, None) if len(cs.prj_test) - count >= 4 else slice(None)
        learned, seconds = {}, {}
        first = args.pair_counts[0]
        # the app's fine-tune (camera-space loss) at every pair count, and beside it the paper's loss on the
        # app's pair count: the same network, start, pairs and iterations
        runs = [(p, CAMERA_SPACE) for p in args.pair_counts] + [(first, PAPER_LOSS)]
        for pairs, loss in runs:
            n = min(pairs, len(cs.prj_train))
            key = f"{pairs}" if loss == CAMERA_SPACE else f"{pairs}_paper_loss"  # JSON keys: str
            model, result = finetune(cs, "CompenNeSt", "compensation", count=n,
                                     recipe=cpu_recipe("CompenNeSt", "compensation", args.iterations, loss=loss),
                                     weights_dir=getattr(args, "weights", None),
                                     classical=classical if n == len(cs.prj_train) else None)
            learned[key] = model
            seconds[key] = round(result.seconds, 1)
            _log(args, f"  CompenNeSt on {n} pairs, {loss} loss: {seconds[key]} s")
        # the choice without a rig (train_models alone): in the simulated captures of the setup's PCNet, fine-tuned
        # on all pairs as Train does
        simulator, _ = finetune(cs, "PCNet", "simulation", recipe=cpu_recipe("PCNet", "simulation", args.iterations),
                                weights_dir=getattr(args, "weights", None))
        picked = choice.choose_by_simulation(
            choice.learned_compensate(learned[f"{first}"], surf.s), classical.compensate,
            choice.learned_simulate(simulator, surf.s, surf.i_min, surf.i_max), cs.prj_test[val], cs.cam_black,
            cs.cam_white, cs.projector_valid)
        by_pairs = projector_space_choice.choose(
            choice.learned_compensate(learned[f"{first}"], surf.s), classical.compensate, cs.cam_test[val],
            cs.prj_test[val], cs.projector_valid, cs.cam_black, cs.cam_white)
        images = {f"compennest_{p}": to_numpy(predict(learned[p], to_tensor(targets), surf.s)) for p in learned}
        images["classical"] = classical.compensate(targets)
        images["uncompensated"] = targets
        names = list(images)
        scene, projector, camera, target = syn.build_setup(spec, os.path.join(data, "textures"))
        rendered = render_working_images(scene, projector, camera, target, setup_dir_of(cs),
                                         np.concatenate([images[k] for k in names]), seed=7)
        caps = {k: rendered[i * count:(i + 1) * count] for i, k in enumerate(names)}
        again = render_working_images(scene, projector, camera, target, setup_dir_of(cs), targets, seed=8)
        reach = classical.reachable(targets) & mask[None]
        row = {k: figures(caps[k], targets, mask, reach) for k in names}
        row["reachable_share"] = round(float(reach.sum() / max(1, mask.sum() * count)), 4)
        # the app's choice (Train in Blender): the rig renders both compensations of the held-back images that
        # are not the ones measured above, and the better capture decides
        v = choice.verification(cs, learned[f"{first}"], classical, images=cs.prj_test[val])
        rendered_pick = choice.choose_by_captures(v, render_working_images(
            scene, projector, camera, target, setup_dir_of(cs), v.images, seed=9))
        chosen_key = "classical" if rendered_pick.chosen == choice.CLASSICAL else f"compennest_{first}"
        row["chosen"] = {**row[chosen_key], "which": rendered_pick.chosen, "validation": rendered_pick.to_dict(),
                         "pcnet_choice": picked.to_dict(), "projector_space_choice": by_pairs.to_dict()}
        pcnet_key = "classical" if picked.chosen == choice.CLASSICAL else f"compennest_{first}"
        row["pcnet_chosen_behind_best_db"] = round(max(row["classical"]["psnr_masked"],
                                                       row[f"compennest_{first}"]["psnr_masked"])
                                                   - row[pcnet_key]["psnr_masked"], 4)
        floor = noise_floor(caps["uncompensated"], again, mask)
        floor["noise_floor_psnr_reachable"] = psnr_over(again, caps["uncompensated"], reach)
        row.update(floor)
        row.update(below_floor(row, floor["noise_floor_psnr"]))
        best = max(row["classical"]["psnr_masked"], row[f"compennest_{first}"]["psnr_masked"])
        row["chosen_behind_best_db"] = round(best - row["chosen"]["psnr_masked"], 4)
        row["learned_minus_classical_db"] = round(row[f"compennest_{first}"]["psnr_masked"]
                                                  - row["classical"]["psnr_masked"], 4)
        row["paper_loss_minus_classical_db"] = round(row[f"compennest_{first}_paper_loss"]["psnr_masked"]
                                                     - row["classical"]["psnr_masked"], 4)
        row["compennest_train_s"] = seconds
        per_setup[spec.name] = row
        _log(args, f"  {row}")
        _write_partial(out, "compensation", per_setup)  # a late crash keeps the setups already measured
        i = 0
        sheet += [(targets[i], f"{spec.name}: target"), (caps["uncompensated"][i], "uncompensated"),
                  (caps["classical"][i], "classical"), (caps[f"compennest_{first}"][i], f"CompenNeSt {first}"),
                  (caps[f"compennest_{args.pair_counts[-1]}"][i], f"CompenNeSt {args.pair_counts[-1]}"),
                  (caps[f"compennest_{first}_paper_loss"][i], f"CompenNeSt {first}, paper loss")]
    return per_setup, sheet


# -- what the realistic transport leaves to a model with spatial context -------------------------
def headroom_run(args, data) -> dict:
    from dataclasses import replace

    from ...lapig_core.photometric.classical import ClassicalModel
    from ...lapig_core.photometric.targets import reachable_mask

    specs = realistic_specs(args)
    twins = [replace(s, name=f"{s.name}_fast_twin", transport="FAST") for s in specs]
    syn.render_synthetic_setups(specs + twins, data, train=args.train_pairs, test=args.test_pairs, seed=600,
                                skip_existing=True)
    per_setup = {}
    for spec, twin in zip(specs, twins):
        row = {}
        for label, name in (("realistic", spec.name), ("fast", twin.name)):
            cs = syn.load_setup(data, name)
            mask = reachable_mask(cs.cam_black, cs.cam_white)
            model = ClassicalModel.fit(cs.prj_train, cs.cam_train)
            row[f"classical_sim_psnr_masked_{label}"] = psnr_over(model.simulate(cs.prj_test), cs.cam_test, mask)
            row[f"classical_fit_residual_{label}"] = round(model.residual, 5)
        row["transport_cost_db"] = round(row["classical_sim_psnr_masked_fast"]
                                         - row["classical_sim_psnr_masked_realistic"], 4)
        per_setup[spec.name] = row
        _log(args, f"  headroom {spec.name}: {row}")
    return {"headroom_per_setup": per_setup,
            "transport_cost_db_mean": round(float(np.mean([r["transport_cost_db"] for r in per_setup.values()])), 4)}


# -- the PCNet table on the realistic setups ----------------------------------------------------
def pcnet_run(args, data) -> dict:
    """The paper's PCNet table (PCNet, CompenNeSt reversed and the classical model on 8 / 48 / 125 pairs,
    simulating the held-out test captures) on the realistic setups (the same captures as the
    compensation part: rendered on first use)."""
    from ...lapig_core.photometric.finetune import CPU_ITERATIONS
    from ...lapig_core.photometric.targets import reachable_mask
    from ...lapig_core.photometric.training_data import SurfaceTensors
    from .bench_models import PAPER, SIZES, simulation_table

    specs = realistic_specs(args)
    syn.render_synthetic_setups(specs, data, train=args.train_pairs, test=args.test_pairs, seed=600,
                                skip_existing=True)
    iterations = args.iterations or CPU_ITERATIONS["PCNet"]
    tables = {}
    for spec in specs:
        cs = syn.load_setup(data, spec.name)
        table, _ = simulation_table(cs, SurfaceTensors.from_capture_set(cs), reachable_mask(cs.cam_black, cs.cam_white),
                                    iterations, args)
        tables[spec.name] = table
        _log(args, f"  PCNet table {spec.name}: {table}")
    # a column's pairs are min(size, the captured pairs): say so where fewer were captured than it names
    out = {"pcnet_table_per_setup": tables, "pcnet_table_iterations": iterations, "pcnet_table_paper": PAPER,
           "pcnet_table_pairs_used": {str(n): min(n, args.train_pairs) for n in SIZES}}
    for n in SIZES:
        for key in ("pcnet", "compennest_reversed", "classical"):
            for m in ("psnr", "ssim", "psnr_masked"):
                out[f"{key}_{m}_{n}"] = round(float(np.mean([t[f"{key}_{n}"][m] for t in tables.values()])), 4)
    out["pcnet_ahead_of_reversed_at_every_size"] = all(
        out[f"pcnet_psnr_{n}"] > out[f"compennest_reversed_psnr_{n}"] for n in SIZES)
    return out


def look_run(args, data, out) -> str:
    """Raw captures of the corner, the vase and the bust under a projected image, Fast against Realistic."""
    import cv2

    from ...lapig_core.common.surfaces import make_surface

    picture = (cv2.resize(make_surface("stripe", 256, 77), (800, 600)) * 255).astype(np.uint8)
    y, x = np.mgrid[0:600, 0:800]
    checker = (((x // 50 + y // 50) % 2) * 215 + 20).astype(np.uint8)[..., None].repeat(3, -1)
    images, labels = [], []
    for spec in syn.REALISTIC_SETUPS:
        if spec.shape not in ("corner", "vase", "statue"):
            continue
        scene, projector, camera, target = syn.build_setup(spec, os.path.join(out, "textures"))
        realistic = scene_state.light_transport(projector, camera)
        for t in (FAST, realistic):
            with CyclesCaptureDevice(scene, projector, camera, target, transport=t, ambient=spec.ambient) as device:
                device.lock_exposure(np.full((600, 800, 3), 255, np.uint8))
                for frame, name in ((checker, "checker"), (picture, "picture")):
                    images.append(device.capture([frame])[0])
                    labels.append(f"{spec.shape} {spec.finish}, {t.mode.lower()}, {name}")
    path = os.path.join(out, "transport_look_sheet.png")
    write_png(path, labelled_grid(images, labels, columns=4, cell=400, title="raw captures: Fast | Realistic"))
    return path


def run(args) -> dict:
    import torch

    t0 = time.perf_counter()
    out = os.path.abspath(args.out)
    os.makedirs(out, exist_ok=True)
    os.makedirs(os.path.join(out, "textures"), exist_ok=True)
    data = os.path.abspath(args.transport_data)
    parts = set(args.parts.split(",")) if args.parts else {"defocus", "interreflection", "speed", "compensation",
                                                            "look", "noise"}
    summary = {}
    if "look" in parts:
        summary["look_sheet"] = look_run(args, data, out)
    if "defocus" in parts:
        summary.update(defocus_run(args, out))
        _log(args, f"defocus: {summary['defocus_blur_error_pct']} %")
    if "interreflection" in parts:
        summary.update(interreflection_run(args, out))
        _log(args, f"interreflection: {summary['interreflection_error_pct']} %")
    if "noise" in parts:
        summary.update(bounce_noise_run(args, out))
    if "speed" in parts:
        summary.update(speed_run(args, out))
    if "pcnet" in parts:
        summary.update(pcnet_run(args, data))
    if "headroom" in parts:
        summary.update(headroom_run(args, data))
    if "compensation" in parts:
        per_setup, sheet = compensation_run(args, data, out)
        first = args.pair_counts[0]
        summary["noise_floor_psnr"] = {k: v["noise_floor_psnr"] for k, v in per_setup.items()}
        summary["learned_minus_classical_db"] = round(float(np.mean(
            [v["learned_minus_classical_db"] for v in per_setup.values()])), 4)
        if len(args.pair_counts) > 1:
            last = args.pair_counts[-1]
            summary[f"learned_{last}_minus_classical_db"] = round(float(np.mean(
                [v[f"compennest_{last}"]["psnr_masked"] - v["classical"]["psnr_masked"] for v in per_setup.values()])), 4)
        summary["paper_loss_minus_classical_db"] = round(float(np.mean(
            [v["paper_loss_minus_classical_db"] for v in per_setup.values()])), 4)
        from ...lapig_core.photometric.finetune import CAMERA_SPACE, PAPER_LOSS, cpu_recipe

        summary["compensation_iterations"] = {
            loss: cpu_recipe("CompenNeSt", "compensation", args.iterations, loss=loss).iterations
            for loss in (CAMERA_SPACE, PAPER_LOSS)}
        summary["compensation_loss"] = "camera-space (the app's); paper_loss_*: the paper's l1 / l1+SSIM"
        summary["chosen_behind_best_db_max"] = max(v["chosen_behind_best_db"] for v in per_setup.values())
        summary["chosen"] = {k: v["chosen"]["which"] for k, v in per_setup.items()}
        summary["chosen_by"] = "the rig's renders of both compensations of 8 other held-back images (Train's choice)"
        summary["pcnet_chosen_behind_best_db_max"] = max(v["pcnet_chosen_behind_best_db"] for v in per_setup.values())
        for key in ["uncompensated", "classical", "chosen", f"compennest_{first}_paper_loss"] + \
                [f"compennest_{p}" for p in args.pair_counts]:
            summary[f"{key}_psnr_masked_mean"] = round(float(np.mean([v[key]["psnr_masked"] for v in per_setup.values()])), 4)
            summary[f"{key}_ssim_mean"] = round(float(np.mean([v[key]["ssim"] for v in per_setup.values()])), 4)
        summary["compensation_pairs_learned"] = first
        summary["per_setup"] = per_setup
        sheet_path = os.path.join(out, "transport_compensation_sheet.png")
        write_png(sheet_path, labelled_grid([im for im, _ in sheet], [lb.split(": ")[-1] for _, lb in sheet],
                                            columns=6, cell=220, title="rendered compensation, realistic setups"))
        summary["compensation_sheet"] = sheet_path
    summary.update({"bench_total_s": round(time.perf_counter() - t0, 1), "cpu_threads": torch.get_num_threads(),
                    "machine": platform.processor() or platform.machine(), "blender": bpy.app.version_string,
                    "pretrained_weights": getattr(args, "weights", None) or "shipped"})
    return summary
