"""Per-setup fine-tuning of the photometric models from the shipped pretrained weights.

The paper's recipes (training.PAPER_RECIPES) take minutes on a GPU. On a 2-core CPU we keep
their structure (batch 8, Adam 1e-3, weight decay 1e-4, the same loss switch and lr step at the
same fractions) but train on random 64 px crops for fewer iterations: starting from pretrained
weights, that reaches within 0.5 dB of the converged figure (see `bench models`).

The compensation network's loss is ours, not the paper's: its error as the camera sees it, through the
setup's classical model (CAMERA_SPACE_FINETUNE below); the paper's recipe stays one argument away.
"""
from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import torch

from . import checkpoints
from ..capture.dataset import CaptureSet
from ..common.atomic import remove_partial_writes
from ..common.compute_device import device_of
from .classical import ClassicalModel
from .losses import CameraSpaceLoss
from .targets import reachable_mask
from .training import CAMERA_LOSS, PAPER_RECIPES, Recipe, Trainer
from .training_data import pairs_from_capture_sets

# The paper fine-tunes CompenNeSt on 8 pairs; here it takes every captured pair, as PCNet does. The CPU
# recipe's iterations are fixed, so that costs no more time, and rendered on the five realistic setups it
# was 0.1 to 2.4 dB ahead of 8 pairs (the marble bust +2.4 dB, and 1.1 dB ahead of the classical model
# there: BENCHMARKS, "Compensation on all five realistic setups"). Benchmarks name the paper's 8 explicitly.
PAPER_COMPENSATION_PAIRS = 8
CPU_ITERATIONS = {"CompenNeSt": 300, "PCNet": 300}  # the paper's recipes at CPU scale
CPU_CROP = 64
# The app's compensation fine-tune: the error as the camera sees it (losses.CameraSpaceLoss), Adam 1e-3 x0.2 at
# 70 %, no weight decay. Rendered, it is 0.8 to 2.4 dB ahead of the paper's projector-space l1 / l1+SSIM (300
# iterations) on each of the five realistic setups, and 0.9 to 2.4 dB on the three direct-light ones (BENCHMARKS,
# issue 16, "CompenNeSt fine-tuned in camera space"). PAPER_LOSS names the paper's recipe (the benchmarks that
# reproduce the paper).
# 1000 iterations: 0.1 to 0.8 dB ahead of 300 on the corner, the niche, the vase and the relief (rendered; the
# bust was not measured), for a longer Train (the demo's: 121 s, against 42-81 s with the paper's recipe).
# Shorter, measured on the five realistic setups (BENCHMARKS, issue 28): 700 iterations cost 0.021 dB of the chosen
# compensation's mean (0.10 on the bust), 500 cost 0.033 (0.16), for about 31 / 52 s less Train on 2 cores.
CAMERA_SPACE_FINETUNE = Recipe(1000, weight_decay=0.0, lr_steps=(700,), loss_schedule=((0, CAMERA_LOSS),))
CAMERA_SPACE, PAPER_LOSS = "camera", "paper"
MODEL_FILES = {("CompenNeSt", "compensation"): "compennest.pt", ("PCNet", "simulation"): "pcnet.pt",
               ("CompenNeSt", "simulation"): "compennest_reversed.pt"}


def cpu_recipe(arch: str, role: str, iterations: int | None = None, seed: int = 0, loss: str = CAMERA_SPACE) -> Recipe:
    """The recipe at CPU scale; fewer iterations give a rough, quick fine-tune (tests, previews).

    loss: for the compensation, CAMERA_SPACE (the app's) or PAPER_LOSS; the simulation always trains on the
    paper's loss (it is already in camera space)."""
    if loss not in (CAMERA_SPACE, PAPER_LOSS):
        raise ValueError(f"unknown fine-tuning loss {loss!r}; use {CAMERA_SPACE!r} or {PAPER_LOSS!r}")
    if role == "compensation" and loss == CAMERA_SPACE:
        base, default = CAMERA_SPACE_FINETUNE, CAMERA_SPACE_FINETUNE.iterations
    else:
        base, default = PAPER_RECIPES["PCNet" if role == "simulation" else "CompenNeSt"], CPU_ITERATIONS[arch]
    return base.scaled(iterations or default, crop=CPU_CROP, seed=seed)


def device_recipe(arch: str, role: str, iterations: int | None = None, device=None) -> Recipe:
    """Train's recipe on `device`: the CPU recipe, except that on a GPU the compensation fine-tunes on whole images
    instead of 64 px crops. Rendered on the five realistic setups, whole images were 0.21-0.41 dB ahead (the
    bust's chosen compensation 33.91 against 33.51 dB; the niche's 0.06 dB below the classical one it displaced),
    for 12x the pixels a step: 15-50 minutes on 2 CPU cores,
    seconds on a GPU. The paper's own recipe on whole images (8 pairs, its loss) was 2.2 and 3.1 dB behind and
    never chosen (BENCHMARKS, "The recipe a GPU affords")."""
    recipe = cpu_recipe(arch, role, iterations)
    if role == "compensation" and device_of(device).type != "cpu":
        recipe = replace(recipe, crop=None)
    return recipe


def camera_space_loss(cs: CaptureSet, classical: ClassicalModel) -> CameraSpaceLoss:
    """The setup's camera-space loss: its classical model's M and gamma_p, over the pixels the projector
    reaches (I+ noticeably above I-; all pixels where it reaches none, rather than no loss at all)."""
    m = torch.from_numpy(np.ascontiguousarray(classical.M)).permute(2, 3, 0, 1)  # (3, 3, H, W), rows: camera
    weight = reachable_mask(cs.cam_black, cs.cam_white)
    if not weight.any():
        weight = np.ones_like(weight)
    return CameraSpaceLoss(m, classical.gamma_p, torch.from_numpy(weight.astype(np.float32))[None, None])


def start_model(arch: str, role: str, from_pretrained: bool = True, seed: int = 0, weights_dir=None):
    """weights_dir: where the pretrained weights are (default: the shipped ones)."""
    if from_pretrained:
        # pretrained on random crops: the weights fit any working size (the nets are convolutional)
        model, _ = checkpoints.load_pretrained(arch, role, weights_dir=weights_dir)
        return model
    return checkpoints.new_model(arch, seed)


def finetune(cs: CaptureSet, arch: str, role: str, count: int | None = None, recipe: Recipe | None = None,
             from_pretrained: bool = True, val_count: int | None = None, eval_every: int = 50,
             on_progress=None, cancel_event=None, weights_dir=None, classical: ClassicalModel | None = None,
             device=None):
    """(model, TrainResult) fitted to one setup on its first `count` training pairs.

    classical: the setup's classical model, for a recipe with the camera-space loss (fitted here on the same
    pairs when not given). device: where it trains (None: the CPU); the model is returned there."""
    if count is None:
        count = len(cs.prj_train)
    train = pairs_from_capture_sets([cs], role, count=count)
    val = pairs_from_capture_sets([cs], role, split="test", count=val_count) if (val_count and cs.has_test) \
        else None
    model = start_model(arch, role, from_pretrained, weights_dir=weights_dir)
    recipe = recipe or cpu_recipe(arch, role)
    if recipe.crop is not None and recipe.crop >= min(train.x.shape[-2:]):
        recipe = replace(recipe, crop=None)  # small working sizes train on whole images
    camera = None
    if recipe.needs_camera_loss:
        if classical is None:
            classical = ClassicalModel.fit(cs.prj_train[:count], cs.cam_train[:count])
        camera = camera_space_loss(cs, classical)
    trainer = Trainer(model, train, recipe, val_pairs=val, eval_every=eval_every,
                      report_every=min(eval_every, 10), cancel_event=cancel_event, camera_loss=camera, device=device)
    result = trainer.run(on_progress)
    return model, result


def save_setup_model(setup_dir, model, role: str, cs: CaptureSet, **extra) -> Path:
    """Save next to the captures, stamped with the setup's fingerprint (the jobs hold the capture's
    lock: what a killed training left half-written here is theirs to remove)."""
    path = Path(setup_dir) / "models" / MODEL_FILES[(model.ARCH_NAME, role)]
    remove_partial_writes(path)
    return checkpoints.save_checkpoint(path, model, role, max(cs.frame_size), cs.meta.get("fingerprint"),
                                       working_frame=list(cs.frame_size), **extra)


def load_setup_model(setup_dir, arch: str, role: str, fingerprint: str | None = None):
    path = Path(setup_dir) / "models" / MODEL_FILES[(arch, role)]
    if not path.is_file():
        raise checkpoints.NotTrainedYet(f"no fine-tuned {arch} for this setup yet: train the models first")
    return checkpoints.load_checkpoint(path, arch=arch, role=role, fingerprint=fingerprint)
