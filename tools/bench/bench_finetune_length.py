"""`python -m lapig_addon bench finetune-length --json [--lengths 1000,500]`: what Train's CompenNeSt fine-tune
buys at each length, rendered, on the realistic setups.

CompenNeSt's fine-tune is most of Train (1000 of its 1300 iterations, BENCHMARKS issue 28), so its length is the
lever on Train's time. For each realistic setup (the transport benchmark's captures, rendered when missing: the
same data as `bench transport`), the app's CompenNeSt (camera-space loss, every captured pair) is fine-tuned at
each length of --lengths with the recipe scaled to it (its lr step stays at 70 %), and, as Train does:
  * the rig (Cycles) renders the compensations of the first --compensate test images made into desired captures,
    by the classical model and by each length's network: their masked PSNR against the targets;
  * the rendered choice: both compensations of the held-back test images after those, rendered, the better
    capture decides (choice.choose_by_captures, as Train in Blender), and the chosen compensator's PSNR on the
    measured images is the figure a user gets.
The classical images are rendered once and shared by every length. Seconds are the fine-tune's own.

--variants adds the recipes a GPU makes affordable (issue 37), each beside the lengths, measured the same way:
  * paper_whole: the paper's CompenNeSt recipe (training.PAPER_RECIPES: 800 iterations, the paper's l1 then
    l1+SSIM loss, weight decay) on 8 pairs, on whole images instead of 64 px crops;
  * app_whole: the app's recipe (camera-space loss, every pair, 1000 iterations) on whole images.
A step on whole images is 12x the pixels of a 64 px crop: minutes per setup on a GPU-less machine.
"""
from __future__ import annotations

import os
import time

import numpy as np

from .projection_render import render_working_images
from ...lapig_core.capture.dataset import setup_dir_of
from ...lapig_core.common import metrics
from ...lapig_core.photometric import choice
from ...lapig_core.photometric.finetune import PAPER_COMPENSATION_PAIRS, cpu_recipe, device_recipe, finetune
from ...lapig_core.photometric.training import PAPER_RECIPES, predict
from ...lapig_core.photometric.training_data import to_numpy, to_tensor
from .. import synthetic_setups as syn
from .bench_transport import compensation_case, realistic_specs


def _lengths(args) -> list:
    text = getattr(args, "lengths", None) or "1000,500"
    try:
        lengths = [int(t) for t in text.split(",") if t.strip()]
    except ValueError:
        lengths = []
    if not lengths or min(lengths) < 1:
        raise ValueError(f"--lengths must list positive iteration counts, got {text!r}")
    return lengths


VARIANTS = ("paper_whole", "app_whole")


def _variants(args) -> list:
    names = [t.strip() for t in (getattr(args, "variants", None) or "").split(",") if t.strip()]
    unknown = [n for n in names if n not in VARIANTS]
    if unknown:
        raise ValueError(f"--variants: unknown {', '.join(unknown)}; choose from {', '.join(VARIANTS)}")
    return names


def recipe_of(key) -> tuple:
    """(recipe, training pairs or None for all) of a length (the app's recipe) or a variant's name."""
    if isinstance(key, int):
        return cpu_recipe("CompenNeSt", "compensation", key), None
    if key == "paper_whole":
        return PAPER_RECIPES["CompenNeSt"], PAPER_COMPENSATION_PAIRS
    if key == "app_whole":
        return device_recipe("CompenNeSt", "compensation", device="cuda"), None  # what a GPU's Train takes
    raise ValueError(f"unknown recipe {key!r}")


def setup_row(args, data, spec, lengths) -> dict:
    cs, surf, mask, targets, classical = compensation_case(args, data, spec)
    count = len(targets)
    val = slice(count, None) if len(cs.prj_test) - count >= 4 else slice(None)
    scene, projector, camera, target = syn.build_setup(spec, os.path.join(data, "textures"))

    def render(images, seed):
        return render_working_images(scene, projector, camera, target, setup_dir_of(cs), images, seed=seed)

    row = {"classical": round(metrics.masked_psnr(render(classical.compensate(targets), 7), targets, mask), 4)}
    verify_classical = None
    for n in lengths:
        t = time.perf_counter()
        recipe, pairs = recipe_of(n)
        model, result = finetune(cs, "CompenNeSt", "compensation", count=pairs, recipe=recipe,
                                 weights_dir=getattr(args, "weights", None), classical=classical)
        seconds = time.perf_counter() - t
        learned = np.clip(to_numpy(predict(model, to_tensor(targets), surf.s)), 0.0, 1.0)
        measured = round(metrics.masked_psnr(render(learned, 7), targets, mask), 4)
        v = choice.verification(cs, model, classical, images=cs.prj_test[val])
        if verify_classical is None:  # the classical half of the choice's renders is the same for every length
            verify_classical = render(v.classical, 9)
        picked = choice.choose_by_captures(v, np.concatenate([render(v.learned, 9),
                                                              verify_classical]))
        chosen = row["classical"] if picked.chosen == choice.CLASSICAL else measured
        row[str(n)] = {"compennest": measured, "chosen": chosen, "which": picked.chosen,
                       "validation": picked.to_dict(), "finetune_seconds": round(seconds, 1),
                       "train_seconds": round(result.seconds, 1)}
    return row


def run(args) -> dict:
    lengths = _lengths(args)
    data = os.path.abspath(args.transport_data)
    specs = realistic_specs(args)
    syn.render_synthetic_setups(specs, data, train=args.train_pairs, test=args.test_pairs, seed=600,
                                skip_existing=True)
    keys = lengths + _variants(args)
    per_setup = {}
    for spec in specs:
        per_setup[spec.name] = row = setup_row(args, data, spec, keys)
        if not args.json:
            print(f"{spec.name}: {row}", flush=True)
    mean = lambda values: round(float(np.mean(values)), 4)  # noqa: E731
    summary = {"benchmark": "finetune-length", "lengths": lengths, "variants": keys[len(lengths):],
               "per_setup": per_setup,
               "classical_mean": mean([r["classical"] for r in per_setup.values()]),
               "train_pairs": args.train_pairs, "compensated_images": args.compensate}
    longest = max(lengths)
    for n in keys:
        rows = [r[str(n)] for r in per_setup.values()]
        summary[f"compennest_mean_{n}"] = mean([r["compennest"] for r in rows])
        summary[f"chosen_mean_{n}"] = mean([r["chosen"] for r in rows])
        summary[f"finetune_seconds_mean_{n}"] = mean([r["finetune_seconds"] for r in rows])
        summary[f"which_{n}"] = {name: r[str(n)]["which"] for name, r in per_setup.items()}
        if n != longest:
            summary[f"chosen_minus_{longest}_db_{n}"] = round(summary[f"chosen_mean_{n}"]
                                                              - summary[f"chosen_mean_{longest}"], 4)
    return summary
