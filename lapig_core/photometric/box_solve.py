# SPDX-License-Identifier: GPL-3.0-or-later
"""The classical compensation as a box-constrained least squares in camera space (numpy only).

ClassicalModel.compensate solves M x = t^gamma_c - o and clips x to the projector's range afterwards:
where a target is out of reach, the clip moves x along the projector's axes, which is not where the
camera's error is smallest (one saturated channel drags the others' hue). Here x = p^gamma_p is
chosen inside [0, 1]^3 to minimise the camera's error directly:

    min_x || W (M x - r) ||^2   subject to 0 <= x <= 1,   r = t^gamma_c - o

W is the camera response's slope at the target, per channel, so the error is measured in the encoded
units the PSNR counts (a linear-light error in a dark channel weighs more). Three unknowns per pixel:
the exact optimum is among the 27 ways of holding each unknown at 0, at 1 or free, solving for the
free ones and clipping; every candidate is feasible and the best one is the box optimum.
"""
from __future__ import annotations

import itertools

import numpy as np

from ..common.small_spd import spd_solve
from .classical import ClassicalModel

_FREE, _LOW, _HIGH = 0, 1, 2
_PATTERNS = np.array(list(itertools.product((_FREE, _LOW, _HIGH), repeat=3)), np.int8)  # (27, 3)
_RIDGE = 1e-9  # keeps a rank-deficient reduced system (a dead channel) solvable: min-norm-like answer
_MIN_LEVEL = 1e-3  # linear level below which the response's slope is taken as at this level (it is infinite at 0)
_CHUNK = 65536  # pixels per block: bounds memory at (27, chunk, 3, 3)


def response_weights(target_linear: np.ndarray, gamma_c: float) -> np.ndarray:
    """d(encoded)/d(linear) of the camera response at the target, per channel: (1/gc) y^(1/gc - 1)."""
    y = np.maximum(target_linear, _MIN_LEVEL)
    return (1.0 / gamma_c) * np.power(y, 1.0 / gamma_c - 1.0)


def box_least_squares(a: np.ndarray, r: np.ndarray) -> np.ndarray:
    """Per pixel argmin_{0<=x<=1} ||a x - r||^2; a (P, 3, 3), r (P, 3) -> x (P, 3) float64.

    Enumerates the 27 active sets: with some unknowns held at a bound, the others solve the reduced
    normal equations; each candidate is clipped into the box (so feasible) and the cheapest one kept.
    The optimum's own active set yields it exactly, so the minimum over candidates is the optimum.
    """
    a = np.asarray(a, np.float64)
    r = np.asarray(r, np.float64)
    out = np.empty(r.shape, np.float64)
    for s in range(0, len(r), _CHUNK):
        out[s:s + _CHUNK] = _box_block(a[s:s + _CHUNK], r[s:s + _CHUNK])
    return out


def _box_block(a: np.ndarray, r: np.ndarray) -> np.ndarray:
    """Most pixels' targets are reachable: their unconstrained solution lies in the box and is the optimum,
    so only the others go through the 27 active sets."""
    g = np.swapaxes(a, 1, 2) @ a
    tr = np.trace(g, axis1=1, axis2=2)[:, None, None]
    x = spd_solve(g + _RIDGE * (tr + 1e-12) * np.eye(3), (np.swapaxes(a, 1, 2) @ r[..., None]))[..., 0]
    outside = ((x < 0) | (x > 1)).any(-1)
    if outside.any():
        x[outside] = _active_sets(a[outside], r[outside])
    return x


def _active_sets(a: np.ndarray, r: np.ndarray) -> np.ndarray:
    p = len(r)
    g = np.swapaxes(a, 1, 2) @ a  # (P, 3, 3)
    tr = np.trace(g, axis1=1, axis2=2)[:, None, None]
    eye = np.eye(3)
    best_x = np.zeros((p, 3))
    best_cost = np.full(p, np.inf)
    for pattern in _PATTERNS:
        free = pattern == _FREE
        fixed = np.where(pattern == _HIGH, 1.0, 0.0)  # value of the held unknowns (free ones: 0 for now)
        x = np.broadcast_to(fixed, (p, 3)).copy()
        if free.any():
            # reduced system over the free unknowns: (A_f^T A_f) x_f = A_f^T (r - A_h x_h)
            rhs = r - np.einsum("pij,j->pi", a, fixed)
            af = a[:, :, free]
            gf = np.swapaxes(af, 1, 2) @ af + _RIDGE * (tr + 1e-12) * eye[:free.sum(), :free.sum()]
            xf = spd_solve(gf, (np.swapaxes(af, 1, 2) @ rhs[..., None]))[..., 0]
            x[:, free] = np.clip(xf, 0.0, 1.0)
        resid = np.einsum("pij,pj->pi", a, x) - r
        cost = (resid * resid).sum(-1)
        better = cost < best_cost - 1e-15
        best_x[better] = x[better]
        best_cost[better] = cost[better]
    return best_x


def box_compensate_linear(model: ClassicalModel, target_linear: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """x (N,H,W,3) in [0,1]: linear projector light whose modelled linear capture M x + o comes nearest
    `target_linear` (N,H,W,3), each channel's error scaled by `weights` (same shape)."""
    n, h, w, _ = target_linear.shape
    m = np.broadcast_to(model.M.astype(np.float64), (n, h, w, 3, 3)).reshape(-1, 3, 3)
    wt = weights.reshape(-1, 3).astype(np.float64)
    r = (target_linear - model.o.astype(np.float64)).reshape(-1, 3)
    x = box_least_squares(wt[:, :, None] * m, wt * r)
    return x.reshape(n, h, w, 3)


def box_compensate(model: ClassicalModel, target: np.ndarray, weighted: bool = True) -> np.ndarray:
    """Desired capture(s) (encoded, [0,1]) -> projector image(s) in [0,1], float32: the box-constrained
    camera-space solve, the same shape as `target` ((H,W,3) or (N,H,W,3))."""
    t, single = model._check(target, "target")
    y = np.power(t.astype(np.float64), model.gamma_c)
    wts = response_weights(y, model.gamma_c) if weighted else np.ones_like(y)
    x = box_compensate_linear(model, y, wts)
    out = np.power(x, 1.0 / model.gamma_p).astype(np.float32)
    return out[0] if single else out
