# SPDX-License-Identifier: GPL-3.0-or-later
"""PSA on the joint reach of K projectors (issue 36): the look adapts to what all of them together can show.

One projector's PSA (psa/adaptation.run_psa) takes a SurfaceModels: a differentiable compensation and
simulation with the surface's range [I-, I+]. For K projectors in camera space the least new code is a
*virtual projector*: the K projectors driven together with one shared linear drive s in [0,1]^3 per camera
pixel (q_k = s for every projector k that reaches it) show

    C = f_c( (sum_k M_k) s + o )

which is a ClassicalModel in camera space (M = sum_k M_k, gamma_p = 1: its "projector image" is the linear
drive). Its range is exactly the joint reach (s = 0: every projector black; s = 1: every reaching projector
at full white, joint_solve.reach), so photometric/classical_compensator's ClassicalCompensator and
ClassicalSimulator (the first look's torch modules) are PSA's differentiable compensation and simulation
unchanged, and run_psa runs unchanged on them. The relaxation is conservative: the joint box solve
(joint_solve.joint_compensate, which makes the projector images after PSA) chooses among 3K unknowns per
pixel, a superset of the shared drive, so what PSA counts as shown the joint solve shows at least as well.

Entry points (the benchmark `bench multi` calls them):
- joint_surface_models(model, shape=None, on_object=None) -> SurfaceModels at the working frame;
- stylize.stylize_joint(..., psa=True): the look adapted, with and without PSA kept (JointLook.without);
- simulated_psnr(model, look, mask): PSNR of the joint model's capture of a look's projector images
  against its target (encoded units, on the mask);
- tools/bench/stack_gain.stack_psa_gain(stacked, single, surface, prompt, ...) -> StackFigures: PSA's simulated PSNR with all of
  `stacked`'s projectors against `single`'s (`stack_psa_gain_db`, each against its own PSA look, as
  bench_psa counts PSA's PSNR), the same against the asked (un-adapted) look (`stack_look_gain_db`), and
  PSA against none on each (`psa_gain_db_stacked`, `psa_gain_db_single`).
- tools/fakes/fake_rig.stacked_rig(count, albedo_scale=0.3) and FakeRig.subset / true_model: the dark stacked rig of
  the tests and its one-projector counterpart.
"""
from __future__ import annotations

import cv2
import numpy as np

from ..common.psnr import masked_psnr
from ..photometric.classical import ClassicalModel
from .joint_model import JointModel


def virtual_model(model: JointModel, shape: tuple[int, int] | None = None) -> ClassicalModel:
    """The K projectors driven by one shared linear drive: ClassicalModel(gamma_c, 1, sum_k M_k, o) in camera
    space, at `shape` (H, W) when given (M and o averaged down, INTER_AREA; up: bilinear)."""
    m = model.M.sum(axis=0)  # (H,W,3,3)
    o = model.o
    if shape is not None and tuple(shape) != model.shape:
        h, w = shape
        inter = cv2.INTER_AREA if h <= model.shape[0] else cv2.INTER_LINEAR
        flat = np.ascontiguousarray(m.reshape(model.shape + (9,)))
        m = np.concatenate([cv2.resize(np.ascontiguousarray(flat[..., i:i + 3]), (w, h), interpolation=inter)
                            for i in (0, 3, 6)], axis=-1).reshape(h, w, 3, 3)
        o = cv2.resize(o, (w, h), interpolation=inter)
    return ClassicalModel(model.gamma_c, 1.0, m, o)


def virtual_reach(virtual: ClassicalModel) -> tuple[np.ndarray, np.ndarray]:
    """(I-, I+) (H,W,3) encoded: the shared drive at 0 and at 1 (joint_solve.reach of the joint model)."""
    encode = np.float32(1.0 / virtual.gamma_c)
    white = virtual.o + virtual.M.sum(axis=-1)
    return (np.power(np.clip(virtual.o, 0, 1), encode).astype(np.float32),
            np.power(np.clip(white, 0, 1), encode).astype(np.float32))


def _nchw(image: np.ndarray):
    import torch

    return torch.from_numpy(np.ascontiguousarray(np.asarray(image, np.float32).transpose(2, 0, 1)))[None]


def joint_surface_models(model: JointModel, shape: tuple[int, int] | None = None,
                         on_object: np.ndarray | None = None, surface: np.ndarray | None = None):
    """A SurfaceModels (photometric/surface_models) of the K projectors together, in camera space at `shape`
    (H, W; None: the model's): the virtual projector's ClassicalCompensator and ClassicalSimulator, i_min and
    i_max the joint reach. on_object (H,W) bool at `shape` (None: where some projector reaches, resized):
    the pixels PSA's losses count. surface: (H,W,3) at `shape`, kept as `s` (the classical modules ignore it;
    default I+)."""
    import torch

    from ..photometric.classical_compensator import ClassicalCompensator, ClassicalSimulator
    from ..photometric.surface_models import SurfaceModels

    virtual = virtual_model(model, shape)
    h, w = virtual.shape
    i_min, i_max = virtual_reach(virtual)
    if on_object is None:
        reached = model.reached.any(axis=0).astype(np.float32)
        on_object = cv2.resize(reached, (w, h), interpolation=cv2.INTER_AREA) > 0.5 if (h, w) != model.shape \
            else reached > 0.5
    on_object = np.asarray(on_object, bool)
    if on_object.shape != (h, w):
        raise ValueError(f"on_object must be {(h, w)}, got {on_object.shape}")
    s = i_max if surface is None else surface
    models = SurfaceModels(ClassicalCompensator(virtual), ClassicalSimulator(virtual), _nchw(s), _nchw(i_min),
                           _nchw(i_max), torch.from_numpy(on_object.astype(np.float32))[None, None])
    models.virtual = virtual
    return models


def simulated_psnr(model: JointModel, look, mask: np.ndarray | None = None) -> float:
    """The joint model's capture of a JointLook's projector images against its target, PSNR (dB) on `mask`
    (None: where some projector reaches)."""
    mask = model.reached.any(axis=0) if mask is None else np.asarray(mask, bool) & model.reached.any(axis=0)
    return float(masked_psnr(model.predict(look.frames), look.target, mask))
