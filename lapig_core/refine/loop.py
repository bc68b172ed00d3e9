# SPDX-License-Identifier: GPL-3.0-or-later
"""Closed-loop refinement: project, capture, compare with the target, correct, repeat (numpy only).

The open-loop compensation is only as good as the model it inverts; the rig's own captures say what
the model got wrong (bounce light, defocus, gloss, registration). Each iteration works in the classical
model's linearised coordinates, x = p^gamma_p (projector light) and y = c^gamma_c (captured light),
where the model is linear with the per-pixel Jacobian M. The step is a damped Gauss-Newton step
through M, projected onto the projector's range:

    x_{k+1} = argmin_{0<=x<=1} || W (M (x - x_k) - alpha (y_target - y_k)) ||

(photometric.box_solve), y_k the captured light. The target is the reachable one, clamped to the
surface's range [I-, I+]: light the projector cannot add is not chased. Per-pixel damping: a pixel
whose error grew since the last capture halves its alpha, one that improved raises it back.

Noise: the first capture is taken twice, which measures the rig's repeatability (the noise floor: the
PSNR between two captures of one image) and the capture noise. A step feeds the capture's noise into
the image; once the error left is about the capture noise, averaging repeated captures pays (its
noise falls as 1/repeats), and not before.

Stopping: when an iteration gains less than `stop_gain_db` on the captures, or at the cap. The image
kept is the one whose capture came nearest the target.

The loop does not capture by itself: `Refinement` says which images to capture (`request`) and
takes the registered captures (`take`), so the same code runs inside a job's steps on Blender's main
thread (Cycles), on a worker thread (a real rig), or with a plain function (`run`).
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import cv2
import numpy as np

from ..common.psnr import masked_psnr
from ..photometric.box_solve import box_compensate_linear, response_weights
from ..photometric.classical import ClassicalModel
from .check import RegistrationCheckError, registration_problem


class RefineError(ValueError):
    """Refinement cannot run or must stop: the message says why and what to do."""


@dataclass(frozen=True)
class RefineSettings:
    iterations: int = 4  # the cap on correcting steps (each one a capture round)
    damping: float = 0.8  # alpha of the step at first: less than 1 so noise is not fed back whole
    min_damping: float = 0.1
    stop_gain_db: float = 0.05
    max_repeats: int = 4  # captures averaged per image at most
    # average more captures once the systematic error left is below this multiple of the averaged
    # capture's own noise: from there on the step would mostly copy noise into the image
    average_below_noise: float = 1.0
    check_registration: bool = True

    def problem(self) -> str:
        if not 1 <= self.iterations <= 50:
            return f"refinement iterations must be 1 to 50, got {self.iterations}"
        if not 0 < self.damping <= 1:
            return f"the refinement's damping must be in (0, 1], got {self.damping}"
        if self.max_repeats < 1:
            return f"max_repeats must be at least 1, got {self.max_repeats}"
        return ""


@dataclass
class RefineRecord:
    """What a refinement did, for result.json, the panel's line and the benchmark."""
    open_loop_psnr: float = math.nan  # the start image's first capture against the reachable target
    refined_psnr: float = math.nan  # the kept image's capture against the reachable target
    noise_floor_psnr: float = math.nan  # two captures of the start image against each other
    iterations: int = 0  # correcting steps taken
    captures: int = 0  # images captured (repeats and the noise pair included)
    seconds: float = 0.0
    stopped: str = ""  # "gain below 0.05 dB", "cap", ...
    history: list = field(default_factory=list)  # PSNR of each capture round
    repeats: list = field(default_factory=list)  # captures averaged per round

    def to_dict(self) -> dict:
        r = lambda v: None if not math.isfinite(v) else round(float(v), 3)  # noqa: E731
        return {"open_loop_psnr": r(self.open_loop_psnr), "refined_psnr": r(self.refined_psnr),
                "noise_floor_psnr": r(self.noise_floor_psnr), "gain_db": r(self.refined_psnr - self.open_loop_psnr),
                "iterations": self.iterations, "captures": self.captures, "seconds": round(self.seconds, 2),
                "stopped": self.stopped, "history": [r(v) for v in self.history], "repeats": list(self.repeats)}

    def line(self) -> str:
        """The panel's words: 'refined on the rig 33.1 -> 38.4 dB (floor 41.2) in 3 steps, 4.1 s'."""
        return (f"refined on the rig {self.open_loop_psnr:.1f} -> {self.refined_psnr:.1f} dB "
                f"(noise floor {self.noise_floor_psnr:.1f}) in {self.iterations} steps, {self.seconds:.1f} s")


def round_stop(record: RefineRecord, psnr: float, repeats: int, settings: RefineSettings) -> str | None:
    """Record one round's PSNR (a single capture's: comparable every round) and say why the loop stops now: the
    step cap, or a gain below stop_gain_db (None: it steps). One projector's loop and several's share it."""
    record.history.append(psnr)
    record.repeats.append(repeats)
    gain = psnr - record.history[-2] if len(record.history) > 1 else math.inf
    if record.iterations >= settings.iterations:
        return "cap"
    if gain < settings.stop_gain_db:
        return f"gain below {settings.stop_gain_db:g} dB"
    return None


def damping(alpha: np.ndarray, previous_err, err_pix: np.ndarray, settings: RefineSettings) -> np.ndarray:
    """Per-pixel damping: back off where the last step overshot (the error grew), grow it where it did not."""
    if previous_err is None:
        return alpha
    worse = err_pix > previous_err
    return np.where(worse, np.maximum(alpha * 0.5, settings.min_damping), np.minimum(alpha * 1.5, settings.damping))


def repeats_for(err: float, noise_var: float, repeats: int, settings: RefineSettings) -> int:
    """Captures to average next round: more once the error left (err, mean squared, of a mean of `repeats`
    captures) is mostly the captures' own noise (noise_var: one capture's variance)."""
    systematic = max(err - noise_var / repeats, 0.0)  # this round's mean had noise_var / repeats
    r = 1
    while r < settings.max_repeats and systematic < settings.average_below_noise * noise_var / r:
        r *= 2
    return min(r, settings.max_repeats)


class RefinementLoop:
    """The rounds every refinement shares, whatever its model: capture (the first round twice), measure
    against the reachable target on the valid pixels, keep the best, step or stop. A subclass says what a
    round's images are and how the captures come (`images`, `_rounds`), what the model predicts for the first
    capture (`_predicted`), the step (`_step`), and how its state is kept (`_state`, `_restore`).
    Its target is (N,H,W,3) or (H,W,3) for one image; `valid` (H,W)."""

    def _begin(self, settings: RefineSettings) -> None:
        self.settings = settings
        self.repeats = 2  # the first round: the noise pair
        self.noise_var = None
        self.record = RefineRecord()
        self.best = (-math.inf, self._state())
        self.previous_err = None
        self.done = False
        self._t0 = None

    # -- the images to capture and the captures back
    def request(self):
        """(images, repeats): capture the images `repeats` times (the layout take() wants: `_rounds`)."""
        if self.done:
            raise RefineError("the refinement is finished")
        if self._t0 is None:
            self._t0 = time.perf_counter()
        return self.images, self.repeats

    def take(self, captures) -> None:
        """The registered captures of request()'s images, in [0,1]: measure, then step or stop."""
        captures = np.asarray(captures, np.float32)
        rounds = self._rounds(captures)  # (N, repeats, H, W, 3)
        rec = self.record
        rec.captures += len(captures)
        if self.noise_var is None:
            self._first(rounds)
        mean = rounds.mean(axis=1)
        psnr = masked_psnr(rounds[:, 0], self.target, self.valid)
        if psnr > self.best[0]:
            self.best = (psnr, self._state())
        stop = round_stop(rec, psnr, self.repeats, self.settings)
        if stop:
            return self._finish(stop)
        self._step(mean)

    def _first(self, rounds) -> None:
        rec = self.record
        a, b = rounds[:, 0], rounds[:, 1]
        rec.noise_floor_psnr = masked_psnr(a, b, self.valid)
        rec.open_loop_psnr = masked_psnr(a, self.target, self.valid)
        diff = (a.astype(np.float64) - b)[:, self.valid]
        self.noise_var = float((diff ** 2).mean() / 2)  # one capture's noise variance (encoded units)
        if self.settings.check_registration:
            problem = registration_problem(a, self._predicted(), self.valid)
            if problem:
                raise RegistrationCheckError(problem)

    def _choose_repeats(self, mean) -> None:
        """Average more captures once the error left is mostly the captures' own noise."""
        err = float(((mean.astype(np.float64) - self.target) ** 2).mean(-1)[:, self.valid].mean())
        self.repeats = repeats_for(err, self.noise_var, self.repeats, self.settings)

    def _finish(self, why: str) -> None:
        psnr, state = self.best
        self._restore(state)
        self.record.refined_psnr = psnr
        self.record.stopped = why
        self.record.seconds = time.perf_counter() - (self._t0 or time.perf_counter())
        self.done = True


class Refinement(RefinementLoop):
    """The loop's state for N target images at the working frame, in projector space (one projector).

    model: the setup's classical model (its M is the step's Jacobian); targets (N,H,W,3) encoded desired
    captures (PSA's adapted target); black, white (H,W,3) I- and I+; valid (H,W) the pixels compared
    (on the object, where the registration holds); start (N,H,W,3) the open-loop projector images.
    """

    def __init__(self, model: ClassicalModel, targets, black, white, valid, start, settings=RefineSettings(),
                 native_start=None):
        """native_start (N,Hn,Wn,3): refine the native-resolution output itself. The native images are
        projected; the loop measures and steps at the working frame (where the registration and the model
        are), and each step's change of light (linear units) is resampled bilinearly onto the native image, so its
        detail stays and its captures, not the working image's, are what the loop corrects. `start` is then
        ignored: the working state is the native light averaged down."""
        problem = settings.problem()
        if problem:
            raise RefineError(problem)
        targets = np.asarray(targets, np.float32)
        if targets.ndim == 3:
            targets = targets[None]
        if targets.shape[1:3] != model.shape:
            raise RefineError(f"the targets are {targets.shape[2]}x{targets.shape[1]} but the setup's model is "
                              f"{model.shape[1]}x{model.shape[0]}: generate again for this capture")
        valid = np.asarray(valid, bool)
        if not valid.any():
            raise RefineError("the projector reaches no pixel of the object in this capture: nothing to refine")
        self.model, self.valid = model, valid
        self.target = np.clip(targets, np.asarray(black, np.float32), np.asarray(white, np.float32))  # reachable
        self.y_target = np.power(self.target.astype(np.float64), model.gamma_c)
        self.weights = response_weights(self.y_target, model.gamma_c)
        self.native = None
        if native_start is not None:
            native = np.asarray(native_start, np.float64)
            if native.ndim == 3:
                native = native[None]
            if len(native) != len(targets) or native.shape[-1] != 3:
                raise RefineError(f"expected {len(targets)} native images, got {native.shape}")
            self.native = np.power(np.clip(native, 0, 1), model.gamma_p)
            start = np.power(self._working(self.native), 1.0 / model.gamma_p)
        start = np.asarray(start, np.float32).reshape(targets.shape)
        self.x = np.power(np.clip(start.astype(np.float64), 0, 1), model.gamma_p)
        self.alpha = np.full(targets.shape[:3], settings.damping)  # per pixel
        self._begin(settings)

    # -- the images to capture and the captures back
    @property
    def images(self) -> np.ndarray:
        """The current projector images (N,H,W,3) float32, encoded: the native ones in native mode."""
        light = self.x if self.native is None else self.native
        return np.power(light, 1.0 / self.model.gamma_p).astype(np.float32)

    @property
    def working_images(self) -> np.ndarray:
        """The current images at the working frame (the native light averaged down in native mode)."""
        return np.power(self.x, 1.0 / self.model.gamma_p).astype(np.float32)

    def _working(self, light):
        """Native light (N,Hn,Wn,3) averaged onto the working frame."""
        h, w = self.model.shape
        return np.stack([cv2.resize(im, (w, h), interpolation=cv2.INTER_AREA) for im in light])

    def _state(self):
        return (self.x.copy(), None if self.native is None else self.native.copy())

    def _restore(self, state) -> None:
        self.x, self.native = state

    def _rounds(self, captures):
        """request()'s images captured image-major (image 0 repeat 0, image 0 repeat 1, ...) -> (N, repeats, ...)."""
        n = len(self.x)
        if captures.shape != (n * self.repeats,) + self.x.shape[1:]:
            raise RefineError(f"expected {n * self.repeats} captures shaped {self.x.shape[1:]}, got {captures.shape}")
        return captures.reshape((n, self.repeats) + self.x.shape[1:])

    def _predicted(self):
        return self.model.simulate(self.working_images)

    def _step(self, mean) -> None:
        m = self.model
        y = np.power(np.clip(mean.astype(np.float64), 0, 1), m.gamma_c)
        err = self.weights * (self.y_target - y)  # encoded-unit error per channel (first order)
        err_pix = (err ** 2).sum(-1)
        self.alpha = damping(self.alpha, self.previous_err, err_pix, self.settings)
        self.previous_err = err_pix
        lin_pred = np.einsum("hwij,nhwj->nhwi", m.M.astype(np.float64), self.x) + m.o
        wanted = lin_pred + self.alpha[..., None] * (self.y_target - y)
        x = box_compensate_linear(m, wanted, self.weights)
        change = np.where(self.valid[None, ..., None], x - self.x, 0.0)  # off the object: the image stays
        if self.native is None:
            self.x = self.x + change
        else:  # the change of light resampled onto the native images, which keep their own detail
            hn, wn = self.native.shape[1:3]
            up = np.stack([cv2.resize(c, (wn, hn), interpolation=cv2.INTER_LINEAR) for c in change])
            self.native = np.clip(self.native + up, 0.0, 1.0)
            self.x = self._working(self.native)
        self.record.iterations += 1
        self._choose_repeats(mean)


def run(refinement: RefinementLoop, capture, cancel=None) -> RefineRecord:
    """Drive the loop with capture(images, repeats) -> the registered captures: for a Refinement, images
    (N,H,W,3) -> (N*repeats,H,W,3) image-major; for a JointRefinement (refine/joint), K frames -> (repeats,H,W,3).
    cancel(): True stops before the next round (the record says so and the image is the best so far)."""
    while not refinement.done:
        if cancel is not None and cancel():
            refinement._finish("cancelled")
            break
        images, repeats = refinement.request()
        refinement.take(capture(images, repeats))
    return refinement.record
