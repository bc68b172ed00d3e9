# SPDX-License-Identifier: GPL-3.0-or-later
"""The look of several projectors: LGST on the object as the camera sees it, jointly compensated.

One projector's pipeline works in its projector frame; K projectors share only the camera's, so here the
look is made there: LGST turns the all-white-together capture (the object lit by every projector) and the
prompt into the target the camera should see, then joint_solve.joint_compensate finds each projector's
image, the K images together showing the target as closely as their summed range allows. PSA (adapting
the look to the joint reach) is not run yet: the result says so.
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import cv2
import numpy as np

from .joint_model import JointModel
from .joint_solve import JointCompensation, joint_compensate, reach

PSA_NOTE = "no surface adaptation (PSA) yet with several projectors: the look is compensated as it is"


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


def make_look(surface: np.ndarray, prompt: str, backend: str, seed: int = 0, mix=None, backend_options=None,
              working_size: int = 256) -> tuple[np.ndarray, dict]:
    """(the look at the surface's size (H,W,3) float32, the backend's describe()). A backend that cannot run
    here falls back to the offline default, as one projector's stylize does, and says so."""
    from ..lgst import prepared_backend

    small = _tensor(working_surface(surface, working_size))
    lgst, fallback = prepared_backend(backend, small, prompt, seed=seed, mix=mix, options=backend_options)
    look = _image(lgst.render_at(_tensor(surface)))
    describe = lgst.describe()
    if fallback:
        describe["fallback"] = fallback
        describe.setdefault("notes", []).append(fallback)
    return look, describe


def stylize_joint(model: JointModel, surface: np.ndarray, prompt: str, backend: str, seed: int = 0, mix=None,
                  backend_options=None, working_size: int = 256, object_mask: np.ndarray | None = None) -> JointLook:
    """surface: the all-white-together capture (H,W,3) in [0,1]; object_mask: where the camera sees the object
    (None: where some projector reaches). Off the reach the target keeps the surface: nothing can change it."""
    t0 = time.perf_counter()
    look, describe = make_look(surface, prompt, backend, seed, mix, backend_options, working_size)
    lgst_seconds = time.perf_counter() - t0
    reached = model.reached.any(axis=0)
    target = np.where(reached[..., None], look, surface).astype(np.float32)
    compensation = joint_compensate(model, target)
    lo, hi = reach(model)
    on = reached if object_mask is None else reached & object_mask
    inside = (target >= lo - 1 / 255) & (target <= hi + 1 / 255)
    share = float(inside[on].mean()) if on.any() else 0.0
    describe.setdefault("notes", []).append(PSA_NOTE)
    return JointLook(target, compensation, describe, share, lgst_seconds)
