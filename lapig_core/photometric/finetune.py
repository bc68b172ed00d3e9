"""Per-setup fine-tuning of the photometric models from the shipped pretrained weights.

The paper's recipes (training.PAPER_RECIPES) take minutes on a GPU. On a 2-core CPU we keep
their structure (batch 8, Adam 1e-3, weight decay 1e-4, the same loss switch and lr step at the
same fractions) but train on random 64 px crops for fewer iterations: starting from pretrained
weights, that reaches within 0.5 dB of the converged figure (see `bench models`).
"""
from __future__ import annotations

from dataclasses import replace
from pathlib import Path

from . import checkpoints
from ..capture.dataset import CaptureSet
from ..common.imageio import remove_partial_writes
from .training import PAPER_RECIPES, Recipe, Trainer
from .training_data import pairs_from_capture_sets

# The paper fine-tunes CompenNeSt on 8 pairs; here it takes every captured pair, as PCNet does. The CPU
# recipe's iterations are fixed, so that costs no more time, and rendered on the five realistic setups it
# was 0.1 to 2.4 dB ahead of 8 pairs (the marble bust +2.4 dB, and 1.1 dB ahead of the classical model
# there: BENCHMARKS, "Compensation on all five realistic setups"). Benchmarks name the paper's 8 explicitly.
PAPER_COMPENSATION_PAIRS = 8
CPU_ITERATIONS = {"CompenNeSt": 300, "PCNet": 300}
CPU_CROP = 64
MODEL_FILES = {("CompenNeSt", "compensation"): "compennest.pt", ("PCNet", "simulation"): "pcnet.pt",
               ("CompenNeSt", "simulation"): "compennest_reversed.pt"}


def cpu_recipe(arch: str, role: str, iterations: int | None = None, seed: int = 0) -> Recipe:
    """The paper's recipe at CPU scale; fewer iterations give a rough, quick fine-tune (tests, previews)."""
    paper = PAPER_RECIPES["PCNet" if role == "simulation" else "CompenNeSt"]
    return paper.scaled(iterations or CPU_ITERATIONS[arch], crop=CPU_CROP, seed=seed)


def start_model(arch: str, role: str, from_pretrained: bool = True, seed: int = 0, weights_dir=None):
    """weights_dir: where the pretrained weights are (default: the shipped ones)."""
    if from_pretrained:
        # pretrained on random crops: the weights fit any working size (the nets are convolutional)
        model, _ = checkpoints.load_pretrained(arch, role, weights_dir=weights_dir)
        return model
    return checkpoints.new_model(arch, seed)


def finetune(cs: CaptureSet, arch: str, role: str, count: int | None = None, recipe: Recipe | None = None,
             from_pretrained: bool = True, val_count: int | None = None, eval_every: int = 50,
             on_progress=None, cancel_event=None, weights_dir=None):
    """(model, TrainResult) fitted to one setup on its first `count` training pairs."""
    if count is None:
        count = len(cs.prj_train)
    train = pairs_from_capture_sets([cs], role, count=count)
    val = pairs_from_capture_sets([cs], role, split="test", count=val_count) if (val_count and cs.has_test) \
        else None
    model = start_model(arch, role, from_pretrained, weights_dir=weights_dir)
    recipe = recipe or cpu_recipe(arch, role)
    if recipe.crop is not None and recipe.crop >= min(train.x.shape[-2:]):
        recipe = replace(recipe, crop=None)  # small working sizes train on whole images
    trainer = Trainer(model, train, recipe, val_pairs=val, eval_every=eval_every,
                      report_every=min(eval_every, 10), cancel_event=cancel_event)
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
