# SPDX-License-Identifier: GPL-3.0-or-later
"""`python -m lapig_addon bench layout --json [--capture DIR]`: the networks' activations in NCHW (before) against
channels-last (now: lapig_core/photometric/archs/layout), side by side in one process, on the CPU.

With NCHW tensors torch's oneDNN convolutions reorder every layer's input into their blocked layout and the
output back; with channels-last they take the tensors as they are. Measured, per layout, on a worker thread with
flush-to-zero as the add-on's jobs run:
  * train: the app's Train iteration of each network (Trainer.steps(), the CPU recipe: batch 8 of 64 px crops, the
    recipe's loss, Adam), from the same pretrained weights, blocks of BLOCK iterations, the layouts alternating;
  * psa: one stylize of an explicit style mix with PSA run to its cap (the stop rule off: the warm start and every
    joint step, as bench preview's prompt_to_preview_seconds_capped), its PSA seconds and its simulated PSNR;
  * compensate_1080p: CompenNeSt's compensation of a 1920 x 1080 frame (native_output.compensate_frame, one tile),
    and the largest difference between the two layouts' frames.
The capture is the device check's fixture (128 x 96) unless --capture names one (e.g. the demo's, 256 x 192). The
layouts alternate in ABBA order, so a machine whose load drifts shifts both alike; the figures are medians.
"""
from __future__ import annotations

import copy
import os
import statistics
import time

import torch

from .device_fixture import FIXTURE

NETWORKS = (("CompenNeSt", "compensation"), ("PCNet", "simulation"))
LAYOUTS = ("nchw", "channels_last")
BLOCK, TRAIN_ROUNDS, PSA_ROUNDS, FRAME_ROUNDS = 5, 6, 4, 4
MIX = "starry_blue_yellow:1"
FRAME_1080P = (1920, 1080)


def rounds(count: int):
    """The layouts' order in each of `count` rounds: ABBA..., so that a drift over the run (the machine warming,
    the allocator's pages) falls on both alike."""
    for i in range(count):
        yield LAYOUTS if i % 2 == 0 else LAYOUTS[::-1]


def use_layout(name: str):
    """Make the networks run in `name`: the arch modules' conversions, or none (NCHW throughout, as before)."""
    from ...lapig_core.photometric.archs import compennest, layout, pcnet

    same = lambda t: t  # noqa: E731
    for module in (compennest, pcnet):
        module.into, module.out_of = (layout.into, layout.out_of) if name == "channels_last" else (same, same)


def time_train(cs, classical, arch: str, role: str) -> dict:
    from ...lapig_core.photometric.finetune import start_model
    from ...lapig_core.photometric.training_data import pairs_from_capture_sets
    from .bench_train_step import app_trainer

    pairs = pairs_from_capture_sets([cs], role)
    start = start_model(arch, role)
    steps = {}
    for name in LAYOUTS:
        use_layout(name)
        # both layouts from the same weights, at the same thread count
        steps[name] = app_trainer(cs, classical, arch, role, BLOCK * TRAIN_ROUNDS * 4 + 10, pairs=pairs,
                                  model=copy.deepcopy(start)).steps()
        next(steps[name])  # warm-up: first-touch pages, kernel selection
    times = {name: [] for name in LAYOUTS}
    for order in rounds(TRAIN_ROUNDS):
        for name in order:
            use_layout(name)
            for _ in range(BLOCK):
                t = time.perf_counter()
                next(steps[name])
                times[name].append(time.perf_counter() - t)
    for gen in steps.values():
        gen.close()
    return _compare({name: 1000 * statistics.median(v) for name, v in times.items()}, "ms")


def _compare(figures: dict, unit: str) -> dict:
    before, now = figures["nchw"], figures["channels_last"]
    return {f"nchw_{unit}": round(before, 3), f"channels_last_{unit}": round(now, 3), "ratio": round(now / before, 3)}


def time_psa(cs, classical) -> dict:
    from ...lapig_core.common import metrics
    from ...lapig_core.photometric import choice as compensator_choice
    from ...lapig_core.photometric.finetune import start_model
    from ...lapig_core.pipeline import SavedModels, as_image, stylize, surface_models
    from ...lapig_core.psa.adaptation import PSASettings

    capped = PSASettings(stop_ratio=0.0)  # every joint step runs
    comp, sim = start_model("CompenNeSt", "compensation"), start_model("PCNet", "simulation")
    # the choice measured here and handed over: surface_models would otherwise measure it and save it into the
    # capture's models folder (the shipped fixture's, by default)
    chosen, _ = compensator_choice.fit_and_choose(cs, comp, sim, classical)
    models = {}
    for name in LAYOUTS:
        use_layout(name)
        saved = SavedModels(copy.deepcopy(comp), copy.deepcopy(sim), chosen, classical)
        models[name] = surface_models(cs, saved=saved)
        stylize(cs, models[name], "", mix=MIX, psa=False)  # loads the style net, caches the surface's features
    seconds, psnr, iterations = {n: [] for n in LAYOUTS}, {}, {}
    for order in rounds(PSA_ROUNDS):
        for name in order:
            use_layout(name)
            res = stylize(cs, models[name], "", mix=MIX, settings=capped, seed=0).with_psa
            seconds[name].append(res.seconds)
            psnr[name] = round(metrics.psnr(as_image(res.simulated), as_image(res.target)), 4)
            iterations[name] = res.iterations
    return {**_compare({n: statistics.median(v) for n, v in seconds.items()}, "s"),
            "simulated_psnr": psnr, "joint_iterations": iterations, "warm_start_steps": capped.warm_start_steps}


def time_compensate(cs, size=FRAME_1080P) -> dict:
    from ...lapig_core.native_output import compensate_frame
    from ...lapig_core.photometric.finetune import start_model
    from .bench_device import frame_inputs

    width, height = size
    target, s = frame_inputs(cs, torch.device("cpu"), size)
    net = start_model("CompenNeSt", "compensation").eval()
    tile = max(width, height)
    frames, times = {}, {n: [] for n in LAYOUTS}
    for order in rounds(FRAME_ROUNDS):
        for name in order:
            use_layout(name)
            net.clear_surface_cache()
            t = time.perf_counter()
            with torch.no_grad():
                frames[name] = compensate_frame(net, target, s, tile)
            times[name].append(time.perf_counter() - t)
    return {**_compare({n: statistics.median(v) for n, v in times.items()}, "s"),
            "max_abs_difference": float((frames["nchw"] - frames["channels_last"]).abs().max()),
            "frame": [width, height]}


def measure(capture=None) -> dict:
    from ...lapig_core.capture.dataset import load_capture_set
    from ...lapig_core.photometric.classical import ClassicalModel
    from .bench_train_step import on_a_worker

    cs = load_capture_set(os.path.abspath(capture) if capture else FIXTURE)
    classical = ClassicalModel.fit(cs.prj_train, cs.cam_train)
    jobs = {arch: (lambda a=arch, r=role: time_train(cs, classical, a, r)) for arch, role in NETWORKS}
    jobs["psa"] = lambda: time_psa(cs, classical)
    jobs["compensate_1080p"] = lambda: time_compensate(cs)
    try:
        out = on_a_worker(jobs)
    finally:
        use_layout("channels_last")  # the add-on's own
    train = {arch: out[arch] for arch, _ in NETWORKS}
    both = {n: sum(train[a][f"{n}_ms"] for a in train) for n in LAYOUTS}
    return {"train_step_ratio": round(both["channels_last"] / both["nchw"], 3),
            "psa_ratio": out["psa"]["ratio"], "compensate_1080p_ratio": out["compensate_1080p"]["ratio"],
            "train": train, "psa": out["psa"], "compensate_1080p": out["compensate_1080p"],
            "capture": capture or str(FIXTURE), "frame": list(cs.frame_size), "torch": torch.__version__,
            "torch_threads": torch.get_num_threads()}


def run(args) -> dict:
    t0 = time.perf_counter()
    out = measure(getattr(args, "capture", None))
    return {"benchmark": "layout", **out, "loadavg_1m": round(os.getloadavg()[0], 2),
            "bench_total_s": round(time.perf_counter() - t0, 1)}
