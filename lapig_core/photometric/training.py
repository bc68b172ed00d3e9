"""Training loop for CompenNeSt and PCNet: the paper's recipes, deterministic, cancellable.

`Trainer.steps()` is a generator of (progress, message), so the same loop runs to completion in a
script, is stepped by the add-on's job engine, or runs on a worker thread. A cancel (closing the
generator, or a threading.Event) stops it between iterations with the weights of the last step.
"""
from __future__ import annotations

import copy
import time
from contextlib import nullcontext
from dataclasses import dataclass, field, replace

import torch

from . import losses
from ..common import denormals, metrics
from ..common.adam import Adam
from ..common.compute_device import module_device, moved
from ..common.thread_tuner import ThreadTuner
from .training_data import PairSet


class TrainingError(RuntimeError):
    """Training cannot go on (diverged, bad data); the message says what to do."""


CAMERA_LOSS = "camera"  # a loss-schedule name: losses.CameraSpaceLoss, which the Trainer is given


@dataclass(frozen=True)
class Recipe:
    iterations: int
    batch_size: int = 8
    lr: float = 1e-3
    weight_decay: float = 1e-4
    lr_steps: tuple = ()  # iterations where lr is multiplied by lr_gamma
    lr_gamma: float = 0.2
    loss_schedule: tuple = ((0, "l1"),)  # (first iteration, loss name), ascending
    crop: int | None = None  # random square crops: the nets are fully convolutional
    seed: int = 0

    @property
    def needs_camera_loss(self) -> bool:
        """Whether the schedule names CAMERA_LOSS (the Trainer must then be given the setup's loss)."""
        return any(name == CAMERA_LOSS for _, name in self.loss_schedule)

    def loss_at(self, iteration: int) -> str:
        name = self.loss_schedule[0][1]
        for start, loss_name in self.loss_schedule:
            if iteration >= start:
                name = loss_name
        return name

    def scaled(self, iterations: int, **changes) -> "Recipe":
        """The same recipe over fewer (or more) iterations: milestones scale with it."""
        f = iterations / self.iterations
        return replace(self, iterations=iterations,
                       lr_steps=tuple(int(round(s * f)) for s in self.lr_steps),
                       loss_schedule=tuple((int(round(s * f)), n) for s, n in self.loss_schedule), **changes)


# The paper's recipes (NOTES section 2).
COMPENNEST_FINETUNE = Recipe(800, loss_schedule=((0, "l1"), (200, "l1+ssim")))
PCNET_TRAIN = Recipe(1500, lr_steps=(1000,), loss_schedule=((0, "l1+l2"), (600, "l1+l2+ssim")))
PAPER_RECIPES = {"CompenNeSt": COMPENNEST_FINETUNE, "PCNet": PCNET_TRAIN}


def apply_model(model, x, s, i_min=None, i_max=None):
    """Run either architecture on a batch: PCNet takes the capture bounds, CompenNeSt does not."""
    if getattr(model, "ARCH_NAME", "") == "PCNet":
        return model(x, s, i_min, i_max)
    return model(x, s)


def predict(model, pairs_x, s, i_min=None, i_max=None, batch_size=8) -> torch.Tensor:
    """Inference in batches (one surface s for all of x), where the model is; the result where pairs_x is."""
    model.eval()
    device = module_device(model)
    s, i_min, i_max = (moved(v, device) for v in (s, i_min, i_max))
    out = []
    with torch.no_grad():
        for start in range(0, len(pairs_x), batch_size):
            xb = pairs_x[start:start + batch_size].to(device)
            out.append(apply_model(model, xb, s.expand(len(xb), -1, -1, -1), i_min, i_max).to(pairs_x.device))
    return torch.cat(out)


def evaluate_pairs(model, pairs: PairSet, batch_size=8, per_pixel_bounds=True) -> dict:
    """PSNR / RMSE / SSIM of the model's output against the pairs' targets, all setups together."""
    preds = []
    for k, surf in enumerate(pairs.surfaces):
        sel = (pairs.setup_index == k).nonzero().flatten()
        if len(sel) == 0:
            continue
        lo, hi = (surf.i_min, surf.i_max) if per_pixel_bounds else (None, None)
        preds.append((predict(model, pairs.x[sel], surf.s, lo, hi, batch_size), pairs.y[sel]))
    pred = torch.cat([p for p, _ in preds])
    target = torch.cat([t for _, t in preds])
    return metrics.evaluate(pred, target)

# On a thread without flush-to-zero, training makes subnormal weights (dead weights decaying) and moments (the
# squares of tiny gradients: 7 % of PCNet's after 300 iterations); every 10 iterations they are set to zero, for
# about 1 % of a step (common/denormals).
SCRUB_EVERY = 10


@dataclass
class TrainResult:
    iterations: int = 0
    seconds: float = 0.0  # training time, validation excluded
    history: list = field(default_factory=list)  # dicts: iteration, loss, [val psnr/rmse/ssim]
    nan_recoveries: int = 0
    cancelled: bool = False
    threads: dict | None = None  # on the CPU: the thread counts the steps ran with (common/thread_tuner)

    @property
    def final(self) -> dict:
        return self.history[-1] if self.history else {}


class Trainer:
    def __init__(self, model, pairs: PairSet, recipe: Recipe, val_pairs: PairSet | None = None,
                 eval_every: int = 100, report_every: int = 10, cancel_event=None, max_nan_recoveries=3,
                 camera_loss: losses.CameraSpaceLoss | None = None, device=None, tune_threads: bool = True):
        """camera_loss: the setup's camera-space loss, needed when the recipe's schedule names CAMERA_LOSS.
        device: where to train (None: where the model and the pairs are, the CPU); the model is moved there
        and stays, the pairs and the loss are copied there once.
        tune_threads: on the CPU, time the steps and keep the faster torch thread count (common/thread_tuner);
        False keeps the count as it is (benchmarks that compare something else at a fixed count)."""
        if len(pairs) == 0:
            raise TrainingError("no training pairs")
        h, w = pairs.x.shape[-2:]
        if recipe.needs_camera_loss:
            if camera_loss is None:
                raise TrainingError("this recipe's camera-space loss needs the setup's fitted classical model")
            if len(pairs.surfaces) != 1:
                raise TrainingError("the camera-space loss is one setup's: train on that setup's pairs alone")
            if camera_loss.size != (h, w):
                raise TrainingError(f"the camera-space loss is {camera_loss.size[0]}x{camera_loss.size[1]}, "
                                    f"the training images {h}x{w}")
        crop = recipe.crop
        if crop is not None and (crop > min(h, w) or crop % 4):
            raise TrainingError(f"crop {crop} must be a multiple of 4 and at most the image size {h}x{w}")
        if h % 4 or w % 4:
            raise TrainingError(f"image size {h}x{w} must be a multiple of 4 for these networks")
        # scalar capture bounds while training (NOTES: PCNet clamps to global min/max then)
        self._y_min, self._y_max = float(pairs.y.min()), float(pairs.y.max())
        if device is not None:
            model.to(device)
            pairs = pairs.to(device)
            val_pairs = val_pairs.to(device) if val_pairs is not None else None
            camera_loss = camera_loss.to(device) if camera_loss is not None else None
        self.camera_loss = camera_loss
        self.model, self.pairs, self.recipe, self.val_pairs = model, pairs, recipe, val_pairs
        self.eval_every, self.report_every = eval_every, report_every
        self.cancel_event, self.max_nan_recoveries = cancel_event, max_nan_recoveries
        self.tune_threads = tune_threads
        self.result = TrainResult()

    def _sample(self, gen: torch.Generator):
        r = self.recipe
        idx = torch.randint(len(self.pairs), (min(r.batch_size, len(self.pairs)),), generator=gen)
        x, s, y = self.pairs.batch(idx)
        rows = cols = slice(None)
        if r.crop is not None:
            h, w = x.shape[-2:]
            top = int(torch.randint(0, h - r.crop + 1, (1,), generator=gen)) // 4 * 4
            left = int(torch.randint(0, w - r.crop + 1, (1,), generator=gen)) // 4 * 4
            rows, cols = slice(top, top + r.crop), slice(left, left + r.crop)
            x, s, y = x[..., rows, cols], s[..., rows, cols], y[..., rows, cols]
        return x, s, y, (rows, cols)

    def _loss(self, name: str, pred, y, crop):
        if name == CAMERA_LOSS:
            return self.camera_loss.cropped(*crop)(pred, y)
        return losses.photometric_loss(name, pred, y)

    def _cancelled(self) -> bool:
        return self.cancel_event is not None and self.cancel_event.is_set()

    def steps(self):
        r, res = self.recipe, self.result
        torch.manual_seed(r.seed)
        gen = torch.Generator().manual_seed(r.seed)
        opt = Adam(self.model.parameters(), lr=r.lr, weight_decay=r.weight_decay)
        on_cpu = module_device(self.model).type == "cpu"
        if on_cpu:  # subnormal weights and moments slow some CPUs several times (common/denormals)
            denormals.scrub_module(self.model)
        good_state = copy.deepcopy(self.model.state_dict())
        tuner = ThreadTuner() if on_cpu and self.tune_threads else None
        try:
            yield from self._loop(opt, gen, good_state, on_cpu, tuner)
        finally:  # a cancel closes the generator: the worker thread gets its thread count back all the same
            if tuner is not None:
                tuner.restore()
                res.threads = tuner.summary()
        if on_cpu:
            denormals.scrub_module(self.model)  # what is saved and used next is clean
        self.model.eval()

    def _loop(self, opt, gen, good_state, on_cpu: bool, tuner):
        r, res = self.recipe, self.result
        t0 = time.perf_counter()
        eval_time = 0.0  # validation is bookkeeping: train_seconds leaves it out
        running = None
        it = 0
        while it < r.iterations:
            if self._cancelled():
                res.cancelled = True
                break
            lr = r.lr * r.lr_gamma ** sum(it >= s for s in r.lr_steps) * 0.5 ** res.nan_recoveries
            for group in opt.param_groups:
                group["lr"] = lr
            self.model.train()
            with tuner.step() if tuner is not None else nullcontext():  # the step alone: no report, no yield
                x, s, y, crop = self._sample(gen)
                pred = apply_model(self.model, x, s, self._y_min, self._y_max)
                loss = self._loss(r.loss_at(it), pred, y, crop)
                finite = bool(torch.isfinite(loss))
                if finite:
                    opt.zero_grad(set_to_none=True)
                    loss.backward()
                    opt.step()
            if not finite:
                self._recover(opt, good_state, it)
                continue
            it += 1
            value = float(loss.detach())
            running = value if running is None else 0.9 * running + 0.1 * value
            if on_cpu and it % SCRUB_EVERY == 0:
                denormals.scrub(denormals.module_tensors(self.model) + opt.moments())
            if it % 50 == 0:
                good_state = copy.deepcopy(self.model.state_dict())
            if it % self.report_every == 0 or it == r.iterations:
                entry = {"iteration": it, "loss": round(running, 5), "lr": lr,
                         "train_seconds": round(time.perf_counter() - t0 - eval_time, 3)}
                if self.val_pairs is not None and (it % self.eval_every == 0 or it == r.iterations):
                    te = time.perf_counter()
                    entry.update({"val_" + k: v for k, v in evaluate_pairs(self.model, self.val_pairs).items()})
                    eval_time += time.perf_counter() - te
                res.history.append(entry)
                res.iterations, res.seconds = it, time.perf_counter() - t0 - eval_time
                msg = f"iteration {it}/{r.iterations}, loss {running:.4f}"
                if "val_psnr" in entry:
                    msg += f", validation {entry['val_psnr']:.2f} dB"
                yield it / r.iterations, msg
        if self._cancelled():  # asked during the last report (a job paused there): no loop top checks it
            res.cancelled = True
        res.iterations, res.seconds = it, time.perf_counter() - t0 - eval_time

    def _recover(self, opt, good_state, it):
        """A NaN/inf loss: go back to the last good weights with half the learning rate."""
        self.result.nan_recoveries += 1
        if self.result.nan_recoveries > self.max_nan_recoveries:
            raise TrainingError(f"training diverged (non-finite loss at iteration {it}) "
                                f"{self.max_nan_recoveries} times: check the captures for NaN, "
                                f"or lower the learning rate")
        self.model.load_state_dict(good_state)
        opt.reset_state()

    def run(self, on_progress=None) -> TrainResult:
        for progress, message in self.steps():
            if on_progress:
                on_progress(progress, message)
        return self.result

