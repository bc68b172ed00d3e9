# SPDX-License-Identifier: GPL-3.0-or-later
"""The look of several projectors: LGST on the object as the camera sees it, jointly compensated.

One projector's pipeline works in its projector frame; K projectors share only the camera's, so here the
look is made there: LGST turns the all-white-together capture (the object lit by every projector) and the
prompt into the target the camera should see, then joint_solve.joint_compensate finds each projector's
image, the K images together showing the target as closely as their summed range allows.

With psa=True (the default, as one projector's Generate) the look first adapts to the projectors' joint
reach (multi/joint_psa: psa/adaptation.run_psa on the K projectors as one virtual projector in camera space,
at LGST's working size), then both the adapted and the un-adapted look are compensated jointly: the result
keeps both (JointLook.without), as one projector's result keeps target and target_nopsa.
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import cv2
import numpy as np

from .joint_model import JointModel
from .joint_solve import JointCompensation, joint_compensate, reach

PSA_NOTE = "no surface adaptation (PSA): the look is compensated as it is"


@dataclass
class JointLook:
    """target: (H,W,3) the look in camera space; compensation: each projector's frame and the predicted capture;
    describe: the LGST backend's account of the look; reach_share: the share of the target's values on the
    reached object within the projectors' summed range [I-, I+]; seconds: LGST's and the solve's."""

    target: np.ndarray
    compensation: JointCompensation
    describe: dict
    reach_share: float
    lgst_seconds: float
    without: "JointLook | None" = None  # the look without PSA, compensated the same way (None: PSA not run)
    psa: dict | None = None  # what PSA did (iterations, seconds, stopped, losses), None when not run
    # (H,W,3) the joint model's capture of the projector images themselves (JointModel.predict(frames)): what
    # the rig shows, the frames' resampling included; compensation.predicted is the drives' in camera space,
    # finer than a projector coarser than the camera can show. None: not computed (the drives' stands in)
    simulated: np.ndarray | None = None
    # PSA's state of the look (theta and the tone field, lists of tensors) where PSA ran: the result keeps it as
    # look_state.npz, and a show's morphs and motions start from it (show/joint_setup)
    state: dict | None = None

    @property
    def shown(self) -> np.ndarray:
        """The predicted capture of the look: `simulated` where computed, else the drives' prediction."""
        return self.compensation.predicted if self.simulated is None else self.simulated

    @property
    def frames(self) -> list:
        return self.compensation.frames


def _tensor(image: np.ndarray):
    import torch

    return torch.from_numpy(np.ascontiguousarray(image.transpose(2, 0, 1)))[None].float()


def _image(tensor) -> np.ndarray:
    return tensor.detach()[0].permute(1, 2, 0).clamp(0, 1).cpu().numpy().astype(np.float32)


def working_surface(surface: np.ndarray, working_size: int) -> np.ndarray:
    """The surface at a long side of `working_size` at most (LGST's cost grows with its pixels)."""
    h, w = surface.shape[:2]
    scale = min(1.0, working_size / max(h, w))
    if scale >= 1.0:
        return surface
    size = (max(8, round(w * scale / 4) * 4), max(8, round(h * scale / 4) * 4))
    return cv2.resize(surface, size, interpolation=cv2.INTER_AREA)


def prepare_backend(surface: np.ndarray, prompt: str, backend: str, seed: int = 0, mix=None, backend_options=None,
                    working_size: int = 256):
    """(the LGST backend prepared on the surface at the working size, why it fell back or None, that surface)."""
    from ..lgst import prepared_backend

    small = working_surface(surface, working_size)
    lgst, fallback = prepared_backend(backend, _tensor(small), prompt, seed=seed, mix=mix, options=backend_options)
    return lgst, fallback, small


def _describe(lgst, fallback) -> dict:
    describe = lgst.describe()
    if fallback:
        describe["fallback"] = fallback
        describe.setdefault("notes", []).append(fallback)
    return describe


def make_look(surface: np.ndarray, prompt: str, backend: str, seed: int = 0, mix=None, backend_options=None,
              working_size: int = 256) -> tuple[np.ndarray, dict]:
    """(the look at the surface's size (H,W,3) float32, the backend's describe()). A backend that cannot run
    here falls back to the offline default, as one projector's stylize does, and says so."""
    lgst, fallback, _ = prepare_backend(surface, prompt, backend, seed, mix, backend_options, working_size)
    return _image(lgst.render_at(_tensor(surface))), _describe(lgst, fallback)


def _reach_share(model: JointModel, target: np.ndarray, on: np.ndarray) -> float:
    lo, hi = reach(model)
    inside = (target >= lo - 1 / 255) & (target <= hi + 1 / 255)
    return float(inside[on].mean()) if on.any() else 0.0


def _compensated(model: JointModel, look: np.ndarray, surface: np.ndarray, on: np.ndarray, describe: dict,
                 lgst_seconds: float) -> JointLook:
    """The JointLook of `look`: the target (the surface where no projector reaches: nothing can change it there)
    and its joint compensation."""
    target = np.where(model.reached.any(axis=0)[..., None], look, surface).astype(np.float32)
    compensation = joint_compensate(model, target)
    return JointLook(target, compensation, describe, _reach_share(model, target, on), lgst_seconds,
                     simulated=model.predict(compensation.frames))


def stylize_joint(model: JointModel, surface: np.ndarray, prompt: str, backend: str, seed: int = 0, mix=None,
                  backend_options=None, working_size: int = 256, object_mask: np.ndarray | None = None,
                  psa: bool = True, psa_settings=None, lgst_surface: np.ndarray | None = None,
                  on_progress=None, cancel_event=None) -> JointLook:
    """surface: the all-white-together capture (H,W,3) in [0,1]; object_mask: where the camera sees the object
    (None: where some projector reaches). Off the reach the target keeps the surface: nothing can change it.

    psa: adapt the look to the joint reach first (multi/joint_psa); the returned look is the adapted one and
    its `without` the un-adapted one. psa_settings: psa.adaptation.PSASettings (None: the defaults).
    lgst_surface: the capture LGST styles when not `surface` (stack_psa_gain: one look for two rigs)."""
    t0 = time.perf_counter()
    reached = model.reached.any(axis=0)
    on = reached if object_mask is None else reached & object_mask
    if not psa:
        look, describe = make_look(surface if lgst_surface is None else lgst_surface, prompt, backend, seed, mix,
                                   backend_options, working_size)
        describe.setdefault("notes", []).append(PSA_NOTE)
        return _compensated(model, look, surface, on, describe, time.perf_counter() - t0)
    from ..psa.adaptation import PSASettings, run_psa
    from .joint_psa import joint_surface_models

    styled = surface if lgst_surface is None else lgst_surface
    lgst, fallback, small = prepare_backend(styled, prompt, backend, seed, mix, backend_options, working_size)
    full = _tensor(styled)
    import torch

    with torch.no_grad():
        plain = _image(lgst.render_at(full))
    h, w = small.shape[:2]
    on_small = cv2.resize(on.astype(np.float32), (w, h), interpolation=cv2.INTER_AREA) > 0.5 if (h, w) != on.shape \
        else on
    models = joint_surface_models(model, (h, w), on_small, small)
    settings = psa_settings or PSASettings(seed=seed)
    result = run_psa(lgst, models, settings, on_progress=on_progress, cancel_event=cancel_event)
    with torch.no_grad():
        adapted = _image(result.look.render_at(full))
    lgst_seconds = time.perf_counter() - t0
    describe = _describe(lgst, fallback)
    summary = {"iterations": result.iterations, "warm_start_steps": result.warm_start_steps,
               "seconds": round(result.seconds, 3), "stopped": result.stopped,
               "first_psa_loss": result.first_psa_loss,
               "best_psa_loss": result.history[result.best_iteration]["psa_loss"],
               "settings": settings.to_dict(), "working_size": [w, h], "models": "joint reach (virtual projector)"}
    field = getattr(result.look, "field", None)
    if field is not None:
        summary["tone_field"] = field.summary()
    looks = [_compensated(model, image, surface, on, describe, lgst_seconds) for image in (adapted, plain)]
    looks[0].without, looks[0].psa = looks[1], summary
    looks[0].state = result.look.state() if hasattr(result.look, "state") else None
    return looks[0]
