"""`python -m lapig_addon bench models --json`: the photometric models on setups pretraining never saw.

Per benchmark setup (synthetic_setups.BENCH_SETUPS, rendered on first use):
  * the paper's PCNet table: PCNet, CompenNeSt reversed and the classical per-pixel model, each
    trained on 8 / 48 / 125 pairs, simulating the held-out test captures;
  * compensation measured for real: desired appearances are compensated by CompenNeSt (fine-tuned
    on 8 pairs with the app's camera-space loss, and with the paper's loss beside it) and by the
    classical model, projected and captured with Cycles through the same rig, and compared with the
    desired images; the uncompensated projection is rendered beside them;
  * fine-tuning time: both models from the pretrained weights to within 0.5 dB of the figure a
    run twice as long converges to, and the same budget from scratch.
"""
from __future__ import annotations

import os
import platform
import time

import bpy
import numpy as np
import torch

from ...lapig_core.common import metrics
from ...lapig_core.photometric.classical import ClassicalModel
from ...lapig_core.photometric.finetune import CPU_ITERATIONS, PAPER_LOSS, cpu_recipe, finetune
from ...lapig_core.common.imageio import write_png
from ...lapig_core.capture.dataset import setup_dir_of
from ...lapig_core.common.sheets import labelled_grid
from ...lapig_core.photometric.targets import desired_targets, reachable_mask
from ...lapig_core.photometric.training import predict
from ...lapig_core.photometric.training_data import SurfaceTensors, to_numpy, to_tensor
from .. import synthetic_setups as syn
from .noise_floor import below_floor, noise_floor
from .projection_render import render_working_images

SIZES = (8, 48, 125)
PAPER = {"pcnet_psnr_8": 26.77, "pcnet_psnr_48": 30.74, "pcnet_psnr_125": 31.14,
         "compennest_reversed_psnr_8": 25.78, "compennest_reversed_psnr_48": 29.93,
         "compennest_reversed_psnr_125": 30.59}


def _log(args, msg):
    if not args.json:
        print(msg, flush=True)


def _figures(pred, target, mask) -> dict:
    out = {k: round(v, 4) for k, v in metrics.evaluate(pred, target).items()}
    out["psnr_masked"] = round(metrics.masked_psnr(pred, target, mask), 4)
    return out


def simulation_table(cs, surf, mask, iterations, args) -> tuple[dict, object]:
    test_x = to_tensor(cs.prj_test)
    rows, pcnet_full = {}, None
    for n in SIZES:
        n_used = min(n, len(cs.prj_train))
        for key, arch in (("pcnet", "PCNet"), ("compennest_reversed", "CompenNeSt")):
            model, result = finetune(cs, arch, "simulation", count=n_used,
                                     recipe=cpu_recipe(arch, "simulation", iterations), weights_dir=getattr(args, "weights", None))
            bounds = (surf.i_min, surf.i_max) if arch == "PCNet" else (None, None)
            pred = to_numpy(predict(model, test_x, surf.s, *bounds))
            rows[f"{key}_{n}"] = {**_figures(pred, cs.cam_test, mask), "train_s": round(result.seconds, 1)}
            if arch == "PCNet":
                pcnet_full = model
            _log(args, f"  {key} on {n_used} pairs: {rows[f'{key}_{n}']}")
        classical = ClassicalModel.fit(cs.prj_train[:n_used], cs.cam_train[:n_used])
        rows[f"classical_{n}"] = {**_figures(classical.simulate(cs.prj_test), cs.cam_test, mask),
                                  "train_s": round(classical.fit_seconds, 1)}
        _log(args, f"  classical on {n_used} pairs: {rows[f'classical_{n}']}")
    return rows, pcnet_full


def compensation_run(spec, cs, surf, mask, pcnet, iterations, args, textures) -> tuple[dict, list]:
    count = min(args.compensate, len(cs.prj_test))
    pairs = min(args.compensation_pairs, len(cs.prj_train))
    targets = desired_targets(cs.prj_test[:count], cs.cam_black, cs.cam_white, mask)
    model, result = finetune(cs, "CompenNeSt", "compensation", count=pairs,
                             recipe=cpu_recipe("CompenNeSt", "compensation", args.iterations),
                             weights_dir=getattr(args, "weights", None))
    learned = to_numpy(predict(model, to_tensor(targets), surf.s))
    # beside the app's camera-space loss: the paper's loss, same network, start, pairs and iterations
    paper_model, _ = finetune(cs, "CompenNeSt", "compensation", count=pairs,
                              recipe=cpu_recipe("CompenNeSt", "compensation", args.iterations, loss=PAPER_LOSS),
                              weights_dir=getattr(args, "weights", None))
    paper = to_numpy(predict(paper_model, to_tensor(targets), surf.s))
    # the classical model on the same pairs as CompenNeSt, and on all of them
    classical_same = ClassicalModel.fit(cs.prj_train[:max(pairs, 4)], cs.cam_train[:max(pairs, 4)]).compensate(targets)
    classical_all = ClassicalModel.fit(cs.prj_train, cs.cam_train).compensate(targets)
    # project and capture them all for real, through the same rig
    scene, projector, camera, target = syn.build_setup(spec, textures)
    rendered = render_working_images(scene, projector, camera, target, setup_dir_of(cs),
                                     np.concatenate([learned, classical_same, classical_all, targets, paper]), seed=7)
    ours, same, theirs, plain, ours_paper = (rendered[i * count:(i + 1) * count] for i in range(5))
    # the same uncompensated images again, other noise seeds: the setup's repeatability limit
    again = render_working_images(scene, projector, camera, target, setup_dir_of(cs), targets, seed=8)
    figures = {"compensated": _figures(ours, targets, mask),
               "compensated_paper_loss": _figures(ours_paper, targets, mask),
               "classical_compensated_same_pairs": _figures(same, targets, mask),
               "classical_compensated": _figures(theirs, targets, mask),
               "uncompensated": _figures(plain, targets, mask), "compensation_pairs": pairs,
               "compennest_train_s": round(result.seconds, 1)}
    floor = noise_floor(plain, again, mask)
    figures.update(floor)
    figures.update(below_floor(figures, floor["noise_floor_psnr"]))
    simulated = None
    if pcnet is not None:
        simulated = to_numpy(predict(pcnet, to_tensor(learned), surf.s, surf.i_min, surf.i_max))
        figures["simulated"] = _figures(simulated, targets, mask)
        figures["simulated_vs_rendered"] = _figures(simulated, ours, mask)
    row_images = []
    for i in range(min(2, count)):
        row_images += [(targets[i], "target (desired)"), (plain[i], "uncompensated capture"),
                       (theirs[i], "classical compensated"), (ours[i], "CompenNeSt compensated")]
        row_images += [(simulated[i], "PCNet simulated")] if simulated is not None else []
        row_images += [(learned[i], "projector image (ours)")]
    return figures, row_images


def first_within(history, threshold) -> float | None:
    for entry in history:
        if entry.get("val_psnr", -np.inf) >= threshold:
            return entry["train_seconds"]
    return None


def timing_run(cs, iterations, args) -> dict:
    """Seconds of training until validation is within 0.5 dB of a twice-as-long run's best."""
    out = {}
    long = 2 * iterations
    for key, arch, role in (("compennest", "CompenNeSt", "compensation"), ("pcnet", "PCNet", "simulation")):
        curves = {}
        for start in ("pretrained", "scratch"):
            _, result = finetune(cs, arch, role, recipe=cpu_recipe(arch, role, long), val_count=8,
                                 eval_every=max(10, long // 30), from_pretrained=start == "pretrained",
                                 weights_dir=getattr(args, "weights", None))
            curves[start] = result.history
        converged = max(e.get("val_psnr", -np.inf) for e in curves["pretrained"])
        out[f"{key}_converged_psnr"] = round(converged, 3)
        out[f"{key}_finetune_seconds"] = first_within(curves["pretrained"], converged - 0.5)
        out[f"{key}_scratch_seconds"] = first_within(curves["scratch"], converged - 0.5)
        out[f"{key}_scratch_best_psnr"] = round(max(e.get("val_psnr", -np.inf) for e in curves["scratch"]), 3)
        out[f"{key}_scratch_total_seconds"] = round(curves["scratch"][-1]["train_seconds"], 1)
        _log(args, f"  timing {key}: {out}")
    out["finetune_seconds"] = round(out["compennest_finetune_seconds"] + out["pcnet_finetune_seconds"], 1)
    scratch = [out[f"{k}_scratch_seconds"] for k in ("compennest", "pcnet")]
    out["scratch_seconds"] = None if None in scratch else round(sum(scratch), 1)
    return out


def run(args) -> dict:
    t0 = time.perf_counter()
    torch.manual_seed(0)
    out = os.path.abspath(args.out)
    os.makedirs(out, exist_ok=True)
    data = os.path.abspath(args.data)
    specs = syn.BENCH_SETUPS[:args.setups]
    syn.render_synthetic_setups(specs, data, train=125, test=30, seed=500, skip_existing=True)
    iterations = args.iterations or CPU_ITERATIONS["PCNet"]
    per_setup, sheet = {}, []
    if getattr(args, "timing_only", False):
        cs = syn.load_setup(data, specs[0].name)
        return {**timing_run(cs, iterations, args), "setup": specs[0].name, "iterations": iterations,
                "cpu_threads": torch.get_num_threads(), "bench_total_s": round(time.perf_counter() - t0, 1),
                "machine": platform.processor() or platform.machine()}
    for spec in specs:
        _log(args, f"{spec.name}:")
        cs = syn.load_setup(data, spec.name)
        surf = SurfaceTensors.from_capture_set(cs)
        mask = reachable_mask(cs.cam_black, cs.cam_white)
        table, pcnet = ({}, None) if args.compensation_only else simulation_table(cs, surf, mask, iterations, args)
        comp, images = compensation_run(spec, cs, surf, mask, pcnet, iterations, args, os.path.join(data, "textures"))
        per_setup[spec.name] = {"simulation": table, "compensation": comp, "reachable_fraction": float(mask.mean())}
        sheet += [(im, f"{spec.name}: {label}") for im, label in images]
    timing = timing_run(syn.load_setup(data, specs[0].name), iterations, args) \
        if args.timing else {}

    def mean(path):
        values = []
        for r in per_setup.values():
            v = r
            for k in path:
                v = v[k]
            values.append(v)
        return round(float(np.mean(values)), 4)

    summary = {}
    if not args.compensation_only:
        for n in SIZES:
            for key in ("pcnet", "compennest_reversed", "classical"):
                for m in ("psnr", "rmse", "ssim", "psnr_masked"):
                    summary[f"{key}_{m}_{n}"] = mean(("simulation", f"{key}_{n}", m))
        summary["pcnet_ahead_of_reversed_at_every_size"] = all(
            summary[f"pcnet_psnr_{n}"] > summary[f"compennest_reversed_psnr_{n}"] for n in SIZES)
    for key in ("compensated", "compensated_paper_loss", "classical_compensated", "classical_compensated_same_pairs",
                "uncompensated") + (() if args.compensation_only else ("simulated",)):
        for m in ("psnr", "ssim", "rmse", "psnr_masked"):
            summary[f"{key}_{m}"] = mean(("compensation", key, m))
    summary["compensation_pairs"] = args.compensation_pairs
    summary["noise_floor_psnr"] = mean(("compensation", "noise_floor_psnr"))
    for key in ("compensated", "compensated_paper_loss", "classical_compensated", "classical_compensated_same_pairs",
                "uncompensated"):
        summary[f"{key}_below_noise_floor_db"] = round(summary["noise_floor_psnr"] - summary[f"{key}_psnr_masked"], 3)
    summary.update(timing)
    sheet_path = os.path.join(out, "models_sheet.png")
    write_png(sheet_path, labelled_grid([im for im, _ in sheet], [lb.split(": ")[1] for _, lb in sheet],
                                        columns=5 if args.compensation_only else 6, cell=200, title="bench models: " + ", ".join(s.name for s in specs)))
    summary.update({"sheet": sheet_path, "setups": [s.name for s in specs], "per_setup": per_setup,
                    "paper": PAPER, "iterations": iterations,
                    "compensation_iterations": cpu_recipe("CompenNeSt", "compensation", args.iterations).iterations,
                    "crop": cpu_recipe("PCNet", "simulation").crop,
                    "bench_total_s": round(time.perf_counter() - t0, 1), "cpu_threads": torch.get_num_threads(),
                    "machine": platform.processor() or platform.machine(), "blender": bpy.app.version_string,
                    "pretrained_weights": getattr(args, "weights", None) or "shipped"})
    return summary
