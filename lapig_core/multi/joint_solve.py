# SPDX-License-Identifier: GPL-3.0-or-later
"""The joint compensation of K projectors: one box-constrained least squares per camera pixel.

With the joint model's M_k and o, the linear drives q_k = f_p,k(P_k) seen at camera pixel x are chosen
in [0, 1]^3 each to minimise

    || W (sum_k M_k q_k - r) ||^2  +  lambda * sum_k || q_k - w_k s ||^2,   r = t^gamma_c - o

W: the camera response's slope at the target (box_solve.response_weights: the error in the encoded units
PSNR counts). The second term pulls the K drives towards the blend's split: w_k the blend weights and s
a level shared by the projectors, left free (it is eliminated: what is penalised is the part of
(q_1 .. q_K) not proportional to (w_1 .. w_K), channel by channel). q_k = w_k s is what each projector's
alpha map times one shared image gives, so where the split can show the target the solution is that
split, and where it cannot (one projector grazes, the target is bright) the others take over. lambda is
small against the data term: the target comes first, the split decides among the many ways to reach it.
Then each projector's drives go back into its own frame (CameraMap.to_projector) and are encoded with
f_p,k^-1.
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from ..photometric.box_solve import response_weights
from .blend import blend_weights
from .box_qp import box_quadratic
from .joint_model import JointModel

DEFAULT_SPLIT_WEIGHT = 1e-3  # lambda, relative to each pixel's data curvature (trace / unknowns)
_RIDGE = 1e-9  # keeps a pixel's system positive definite where M is rank deficient (a dead channel)
_CHUNK = 32768  # camera pixels per block: bounds memory at (chunk, 3K, 3K) float64


@dataclass
class JointCompensation:
    """drives: (K,H,W,3) linear drives per camera pixel; frames: one (h_k,w_k,3) float32 encoded image per
    projector; predicted: (H,W,3) the model's capture of the drives; seconds: the solve's time."""

    drives: np.ndarray
    frames: list
    predicted: np.ndarray
    seconds: float


def reach(model: JointModel) -> tuple[np.ndarray, np.ndarray]:
    """(I-, I+): (H,W,3) float32 encoded captures of every projector black and of every projector that
    reaches at full white. The reachable range at a pixel is the sum of the reaching projectors' ranges."""
    white = model.o + model.M.sum(axis=-1).sum(axis=0)
    encode = np.float32(1.0 / model.gamma_c)
    return (np.power(np.clip(model.o, 0, 1), encode).astype(np.float32),
            np.power(np.clip(white, 0, 1), encode).astype(np.float32))


def joint_drives(model: JointModel, target: np.ndarray, weights: np.ndarray | None = None,
                 split_weight: float = DEFAULT_SPLIT_WEIGHT, weighted: bool = True) -> np.ndarray:
    """Desired capture (H,W,3), encoded in [0,1] -> (K,H,W,3) float32 linear drives in [0,1] per camera pixel.

    weights: (K,H,W) blend weights (None: blend.blend_weights of the model's maps); weighted: the error
    in encoded units (False: in linear light, as box_solve's weighted=False)."""
    t = np.asarray(target, np.float64)
    if t.shape != model.shape + (3,):
        raise ValueError(f"target must be {model.shape + (3,)}, got {t.shape}")
    y = np.power(np.clip(t, 0.0, 1.0), model.gamma_c)
    wt = response_weights(y, model.gamma_c) if weighted else np.ones_like(y)
    return joint_drives_linear(model, y, wt, weights, split_weight)


def joint_drives_linear(model: JointModel, wanted: np.ndarray, response: np.ndarray,
                        weights: np.ndarray | None = None, split_weight: float = DEFAULT_SPLIT_WEIGHT) -> np.ndarray:
    """The joint solve in linear units: wanted (H,W,3) linear capture (not clipped: a refinement step may ask
    beyond [0, 1]), response (H,W,3) each channel's error weight -> (K,H,W,3) float32 drives in [0,1]."""
    k_count, (h, w) = model.count, model.shape
    if weights is None:
        weights = blend_weights(model.maps)
    y = np.asarray(wanted, np.float64).reshape(-1, 3)
    wt = np.asarray(response, np.float64).reshape(-1, 3)
    r = y - model.o.reshape(-1, 3)
    m = model.M.reshape(k_count, -1, 3, 3)
    reached = model.reached.reshape(k_count, -1)
    split = _unit_split(np.asarray(weights, np.float64).reshape(k_count, -1), reached)
    out = np.zeros((k_count, h * w, 3), np.float64)
    todo = np.flatnonzero(reached.any(axis=0))
    for s in range(0, todo.size, _CHUNK):
        idx = todo[s:s + _CHUNK]
        a = wt[idx, :, None, None] * np.moveaxis(m[:, idx], 0, 2)  # (P, 3, K, 3): W M_k
        a = a.reshape(len(idx), 3, 3 * k_count)  # unknowns ordered (projector, channel)
        hess = np.swapaxes(a, 1, 2) @ a
        grad = np.einsum("pik,pi->pk", a, wt[idx] * r[idx])
        scale = np.trace(hess, axis1=1, axis2=2) / (3 * k_count) + 1e-12
        hess += (split_weight * scale)[:, None, None] * _split_penalty(split[:, idx])
        hess[:, range(3 * k_count), range(3 * k_count)] += (_RIDGE * scale)[:, None]
        frozen = np.repeat(~reached[:, idx].T, 3, axis=1)
        q = box_quadratic(hess, grad, frozen)
        out[:, idx] = q.reshape(len(idx), k_count, 3).transpose(1, 0, 2)
    return out.reshape(k_count, h, w, 3).astype(np.float32)


def _unit_split(weights: np.ndarray, reached: np.ndarray) -> np.ndarray:
    """(K,P) blend weights -> unit vectors over the reaching projectors (even where the weights are all 0)."""
    wts = np.where(reached, np.maximum(weights, 0.0), 0.0)
    norm = np.linalg.norm(wts, axis=0)
    even = reached / np.sqrt(np.maximum(reached.sum(axis=0), 1))
    return np.where(norm > 1e-9, wts / np.maximum(norm, 1e-30), even)


def _split_penalty(unit: np.ndarray) -> np.ndarray:
    """(K,P) unit split -> (P,3K,3K): min over s of sum_k ||q_k - w_k s||^2 = q^T ((I - u u^T) (x) I_3) q."""
    k_count = unit.shape[0]
    across = np.eye(k_count) - np.einsum("kp,jp->pkj", unit, unit)  # (P,K,K)
    return np.einsum("pkj,ab->pkajb", across, np.eye(3)).reshape(-1, 3 * k_count, 3 * k_count)


def projector_frames(model: JointModel, drives: np.ndarray) -> list:
    """(K,H,W,3) linear drives per camera pixel -> one encoded (h_k,w_k,3) float32 image per projector:
    resampled into its frame (averaged, holes filled; the edge carried a bleed past its footprint, black
    beyond: CameraMap.bleed_pixels), then f_p,k^-1."""
    return [np.power(np.clip(m.to_projector(q, bleed=m.bleed_pixels()), 0.0, 1.0), np.float32(1.0 / gp)).astype(np.float32)
            for m, q, gp in zip(model.maps, drives, model.gamma_p)]


def joint_compensate(model: JointModel, target: np.ndarray, weights: np.ndarray | None = None,
                     split_weight: float = DEFAULT_SPLIT_WEIGHT, weighted: bool = True) -> JointCompensation:
    """Desired capture (H,W,3) -> each projector's image, the drives and their predicted capture."""
    t0 = time.perf_counter()
    drives = joint_drives(model, target, weights, split_weight, weighted)
    frames = projector_frames(model, drives)
    return JointCompensation(drives, frames, model.predict_linear(drives), time.perf_counter() - t0)
