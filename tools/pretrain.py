"""Pretraining on many synthetic setups: the starting point of every per-setup fine-tune.

Each network learns from all setups at once, every sample with its own setup's surface s, on
random crops (the nets are fully convolutional; crops make CPU pretraining affordable).
CompenNeSt first warms up as an autoencoder (s = 0, x = y = projector image), as NOTES advises
when training from scratch.
"""
from __future__ import annotations

import time
from pathlib import Path

import torch

from ..lapig_core.photometric import checkpoints
from ..lapig_core.capture.dataset import load_capture_set
from ..lapig_core.photometric.training import Recipe, Trainer, evaluate_pairs
from ..lapig_core.photometric.training_data import PairSet, SurfaceTensors, pairs_from_capture_sets

JOBS = (("CompenNeSt", "compensation"), ("PCNet", "simulation"), ("CompenNeSt", "simulation"))


def pretrain_recipe(iterations: int, crop: int = 96, seed: int = 0) -> Recipe:
    # the fine-tune recipes' losses: l1 (+ l2 for simulation, folded in below) then + SSIM
    return Recipe(iterations, batch_size=8, crop=crop, seed=seed, lr_steps=(int(iterations * 0.7),),
                  loss_schedule=((0, "l1+l2"), (int(iterations * 0.4), "l1+l2+ssim")))


def autoencoder_pairs(pairs: PairSet) -> PairSet:
    """x = y = projector image with a zero surface: teaches the decoder to reproduce its input."""
    prj = pairs.y if pairs.role == "compensation" else pairs.x
    zero = [SurfaceTensors(torch.zeros_like(s.s), s.i_min, s.i_max) for s in pairs.surfaces]
    return PairSet(prj, prj, pairs.setup_index, zero, pairs.role)


def load_setups(data_root) -> list:
    """Every complete setup under data_root/<name>/setups/<name> (one root per synthetic setup)."""
    setups = sorted(p for p in Path(data_root).glob("*/setups/*")
                    if p.is_dir() and not p.name.endswith(".partial") and (p / "setup.json").exists())
    if not setups:
        raise ValueError(f"no captured setups under {data_root}: run 'python -m lapig_addon dataset' first")
    return [load_capture_set(p) for p in setups]


def pretrain_one(sets, arch: str, role: str, iterations: int, out_dir, crop=96, seed=0, warmup=200,
                 val_count=4, on_progress=None) -> dict:
    t0 = time.perf_counter()
    model = checkpoints.new_model(arch, seed)
    train = pairs_from_capture_sets(sets, role)
    val = pairs_from_capture_sets(sets, role, split="test", count=val_count)
    if arch == "CompenNeSt" and warmup:
        Trainer(model, autoencoder_pairs(train), Recipe(warmup, crop=crop, seed=seed)).run()
    trainer = Trainer(model, train, pretrain_recipe(iterations, crop, seed), report_every=50,
                      eval_every=10 ** 9)
    result = trainer.run(on_progress)
    val_metrics = evaluate_pairs(model, val)
    name = checkpoints.PRETRAINED[(arch, role)]
    path = checkpoints.save_checkpoint(
        Path(out_dir) / name, model, role, working_size=int(max(train.x.shape[-2:])),
        pretrained_on=[cs.setup for cs in sets], iterations=iterations, warmup=warmup, crop=crop, seed=seed,
        validation=val_metrics)
    return {"file": str(path), "size_mb": round(checkpoints.file_size_mb(path), 2),
            "validation": {k: round(v, 4) for k, v in val_metrics.items()},
            "final_loss": result.final.get("loss"), "seconds": round(time.perf_counter() - t0, 1),
            "iterations": iterations, "setups": len(sets), "pairs": len(train)}
