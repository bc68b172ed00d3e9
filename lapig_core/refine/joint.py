# SPDX-License-Identifier: GPL-3.0-or-later
"""Closed-loop refinement in camera space, for a rig of any number K of projectors (issue 36): project all K
images, capture once, correct every image jointly; numpy and OpenCV only.

The rounds are refine/loop.RefinementLoop's, as for one projector in projector space (loop.Refinement); each
round projects every projector's image at once and takes one registered camera capture (camera space, the only
frame the K share). The step is a
damped Gauss-Newton step through the joint model's linearisation, per camera pixel in linear units

    q_{n+1} = argmin_{0<=q_k<=1} || W (sum_k M_k q_k + o - (sum_k M_k q_n,k + o + alpha (y_target - y_n))) ||^2
              + the blend's split pull

solved by the same joint box QP as the open-loop compensation (joint_solve.joint_drives_linear, box_qp):
the projectors that reach a pixel share its correction, within each one's range. The change of each
projector's drive goes back into its own frame (CameraMap.to_projector, 0 past its footprint's bleed, corrected a few
times for what the frame's resampling blurs) and is added to its linear light, so each image keeps its own
detail; the next round's drives are the new light sampled
into camera space. The rest is Refinement's: the target clamped to the joint reach [I-, I+]; per-pixel
damping (halved where the error grew, raised back where it fell); the first round captured twice (the noise
floor and the capture noise) and checked against the model's prediction (refine/check); more captures
averaged once the error left is about their noise; stop when a round gains less than `stop_gain_db`
(0.05 dB) or at the cap, keeping the images whose capture came nearest the target.

Entry points (the benchmark `bench multi` and the add-on's Refine call them):
- JointRefinement(model, target, valid, start_frames, settings=RefineSettings(), back_projection=3):
  request() -> (frames, repeats), take(captures (repeats,H,W,3)); .images, .record (refine/loop.RefineRecord),
  .done;
- loop.run(refinement, capture(frames, repeats) -> (repeats,H,W,3) in [0,1], cancel=None) -> RefineRecord;
- device_capture(device): such a capture function over a MultiProjectorDevice (tools/fakes/fake_rig.FakeRigDevice, Cycles);
- refine_gain_db_multi(model, device, target, valid=None, settings=None) -> (RefineRecord, MultiRefinement):
  open-loop joint compensation of `target` with `model`, refined on `device`; record.refined_psnr -
  record.open_loop_psnr is the gain (bench multi's figure of that name).
"""
from __future__ import annotations

from typing import Sequence

import numpy as np

from ..multi.blend import blend_weights
from ..multi.joint_model import JointModel
from ..multi.joint_solve import DEFAULT_SPLIT_WEIGHT, joint_compensate, joint_drives_linear, reach
from ..photometric.box_solve import response_weights
from .loop import RefineError, RefinementLoop, RefineRecord, RefineSettings, damping, run

BACK_PROJECTION = 3  # corrections of each step's change as the projector frame resamples it (_into_frame)


class JointRefinement(RefinementLoop):
    """The loop's state for one target of K projectors, in camera space.

    model: the rig's JointModel (its M_k are the step's Jacobian); target (H,W,3) encoded desired capture (the
    look, PSA's adapted one); valid (H,W) the camera pixels compared (on the object, reached); start: one
    encoded image per projector (h_k,w_k,3), the open-loop compensation."""

    def __init__(self, model: JointModel, target, valid, start: Sequence[np.ndarray],
                 settings: RefineSettings = RefineSettings(), weights: np.ndarray | None = None,
                 split_weight: float = DEFAULT_SPLIT_WEIGHT, back_projection: int = BACK_PROJECTION):
        problem = settings.problem()
        if problem:
            raise RefineError(problem)
        target = np.asarray(target, np.float32)
        if target.shape != model.shape + (3,):
            raise RefineError(f"the look is {target.shape[1]}x{target.shape[0]} but the joint model is "
                              f"{model.shape[1]}x{model.shape[0]}: generate again for this capture")
        if len(start) != model.count:
            raise RefineError(f"one start image per projector: {model.count}, got {len(start)}")
        valid = np.asarray(valid, bool) & model.reached.any(axis=0)
        if not valid.any():
            raise RefineError("no projector reaches a pixel of the object in this capture: nothing to refine")
        self.model, self.valid = model, valid
        self.split_weight, self.back_projection = split_weight, int(back_projection)
        self.weights = blend_weights(model.maps) if weights is None else np.asarray(weights)
        lo, hi = reach(model)
        self.target = np.clip(target, lo, hi)  # reachable by all of them together
        self.y_target = np.power(self.target.astype(np.float64), model.gamma_c)
        self.response = response_weights(self.y_target, model.gamma_c)
        self.light = []
        for k, (frame, m) in enumerate(zip(start, model.maps)):
            frame = np.asarray(frame, np.float64)
            if frame.shape != (m.projector_size[1], m.projector_size[0], 3):
                raise RefineError(f"projector {k + 1}'s image must be {m.projector_size[0]}x{m.projector_size[1]}, "
                                  f"got {frame.shape}")
            self.light.append(np.power(np.clip(frame, 0, 1), model.gamma_p[k]))
        self.q = self._drives()
        self.alpha = np.full(model.shape, settings.damping)
        self._begin(settings)

    # -- the images to capture and the captures back
    @property
    def images(self) -> list:
        """The current projector images, one (h_k,w_k,3) float32 encoded per projector."""
        return [np.power(lt, 1.0 / g).astype(np.float32) for lt, g in zip(self.light, self.model.gamma_p)]

    def _drives(self) -> np.ndarray:
        """(K,H,W,3) the linear light each projector's image sends to each camera pixel (the model's q_k)."""
        return np.stack([m.sample(lt.astype(np.float32)) for m, lt in zip(self.model.maps, self.light)]).astype(
            np.float64)

    def _state(self):
        return [lt.copy() for lt in self.light]

    def _restore(self, light) -> None:
        self.light = light
        self.q = self._drives()

    def _rounds(self, captures):
        """request()'s images projected together and captured `repeats` times (repeats,H,W,3) -> (1, repeats, ...)."""
        if captures.shape != (self.repeats,) + self.model.shape + (3,):
            raise RefineError(f"expected {self.repeats} captures shaped {self.model.shape + (3,)}, got "
                              f"{captures.shape}")
        return captures[None]

    def _predicted(self):
        return self.model.predict(self.images)[None]

    def _step(self, mean) -> None:
        mean = mean[0]  # the one camera view
        model = self.model
        y = np.power(np.clip(mean.astype(np.float64), 0, 1), model.gamma_c)
        err_pix = ((self.response * (self.y_target - y)) ** 2).sum(-1)
        self.alpha = damping(self.alpha, self.previous_err, err_pix, self.settings)
        self.previous_err = err_pix
        lin_pred = np.einsum("khwij,khwj->hwi", model.M.astype(np.float64), self.q) + model.o
        wanted = lin_pred + self.alpha[..., None] * (self.y_target - y)
        q = joint_drives_linear(model, wanted, self.response, self.weights, self.split_weight)
        for k, m in enumerate(model.maps):
            change = np.where(self.valid[..., None], q[k] - self.q[k], 0.0).astype(np.float32)
            self.light[k] = np.clip(self.light[k] + self._into_frame(m, change), 0.0, 1.0)
        self.q = self._drives()
        self.record.iterations += 1
        self._choose_repeats(mean[None])

    def _into_frame(self, camera_map, change: np.ndarray) -> np.ndarray:
        """A camera-space change of one projector's light -> the change of its frame whose sampling gives it back:
        to_projector (an average, which the sampling blurs again), then `back_projection` corrections of what
        the sampling misses (a Landweber iteration of sample . to_projector; a sharp look's edges gain ~1 dB)."""
        bleed = camera_map.bleed_pixels()  # as the open loop's frames carry their edges (joint_solve.projector_frames)
        light = camera_map.to_projector(change, outside=0.0, bleed=bleed)
        inside = self.valid[..., None]
        for _ in range(self.back_projection):
            missed = np.where(inside, change - camera_map.sample(light), 0.0).astype(np.float32)
            light = light + camera_map.to_projector(missed, outside=0.0, bleed=bleed)
        return light


def device_capture(device):
    """capture(images, repeats) over a MultiProjectorDevice: the K images shown together `repeats` times, each
    grab a new noise draw where the device can vary it; float captures in [0,1] at the device's camera size."""
    def capture(images, repeats):
        frames = [np.round(np.clip(im, 0, 1) * 255).astype(np.uint8) for im in images]  # the device's contract
        shots = device.capture([frames] * repeats)
        return np.stack([np.asarray(s, np.float32) / (255.0 if np.asarray(s).dtype == np.uint8 else 1.0)
                         for s in shots])
    return capture


def refine_gain_db_multi(model: JointModel, device, target: np.ndarray, valid: np.ndarray | None = None,
                         settings: RefineSettings | None = None) -> tuple[RefineRecord, JointRefinement]:
    """Open loop (model's joint compensation of `target`) against refined on `device` (a MultiProjectorDevice
    whose camera is the model's): the record's refined_psnr - open_loop_psnr is `refine_gain_db_multi`.
    valid: the pixels compared (None: where some projector reaches)."""
    valid = model.reached.any(axis=0) if valid is None else np.asarray(valid, bool)
    start = joint_compensate(model, target).frames
    refinement = JointRefinement(model, target, valid, start, settings or RefineSettings())
    return run(refinement, device_capture(device)), refinement
