# SPDX-License-Identifier: GPL-3.0-or-later
"""Many small box-constrained convex quadratic programs at once (one per camera pixel), numpy only.

    minimise 0.5 x^T H x - g^T x   subject to 0 <= x <= 1,   H symmetric positive definite, x in R^n

photometric/box_solve enumerates the 3^3 = 27 active sets of one projector's 3 unknowns; K projectors
have 3K unknowns and 3^(3K) sets (531441 for K = 4), so here the primal active-set method walks to the
optimum instead: from a feasible point, solve with the working set's unknowns held at their bounds; step
towards that solution until an unknown meets a bound (which joins the set); at a stationary point
release the held unknown whose multiplier has the wrong sign, or stop when none has. Each step lowers
the cost, so it cannot cycle; every pixel takes its own steps, all pixels in one array operation.
A system with some unknowns held is solved as the full n x n one with those rows and columns replaced
by the identity, so one batched Cholesky (common/small_spd) serves every pixel's working set.
"""
from __future__ import annotations

import numpy as np

from ..common.small_spd import spd_solve

_STEP_TOL = 1e-10  # a step shorter than this (unknowns live in [0, 1]) is a stationary point


def box_quadratic(h: np.ndarray, g: np.ndarray, frozen: np.ndarray | None = None,
                  max_steps: int | None = None) -> np.ndarray:
    """Per pixel argmin_{0<=x<=1} 0.5 x^T h x - g^T x: h (P,n,n) SPD, g (P,n) -> x (P,n) float64.

    frozen (P,n) bool: unknowns held at 0 throughout (a projector that does not reach the pixel).
    max_steps (default 4n + 8) bounds the walk; a pixel still walking then returns its last point,
    feasible and no worse than the clipped unconstrained solution it started from.
    """
    h = np.asarray(h, np.float64)
    g = np.asarray(g, np.float64)
    p, n = g.shape
    frozen = np.zeros((p, n), bool) if frozen is None else np.asarray(frozen, bool)
    low, high = frozen.copy(), np.zeros((p, n), bool)
    x = _solve_held(h, g, low, high)
    low |= x < 0
    high |= (x > 1) & ~low
    x = np.where(high, 1.0, np.where(low, 0.0, x))
    walking = np.flatnonzero((low & ~frozen).any(1) | high.any(1))  # the unconstrained optimum left the box
    # multipliers are compared with the scale of each pixel's curvature
    mu_tol = 1e-9 * (np.trace(h, axis1=1, axis2=2) / n + 1e-30)
    for _ in range(4 * n + 8 if max_steps is None else max_steps):
        if walking.size == 0:
            break
        hw, gw, xw = h[walking], g[walking], x[walking]
        lo, hi, fz = low[walking], high[walking], frozen[walking]
        d = _solve_held(hw, gw, lo, hi) - xw
        moving = (np.abs(d) > _STEP_TOL).any(1)
        finished = np.zeros(len(walking), bool)
        if (~moving).any():  # stationary on the working set: is every held bound still pressing?
            grad = np.einsum("pij,pj->pi", hw, xw) - gw
            mu = np.where(lo & ~fz, grad, np.where(hi, -grad, np.inf))
            worst = np.argmin(mu, axis=1)
            rows = np.arange(len(walking))
            optimal = mu[rows, worst] >= -mu_tol[walking]
            finished = ~moving & optimal
            free = ~moving & ~optimal
            lo[free, worst[free]] = False
            hi[free, worst[free]] = False
        if moving.any():
            xw, lo, hi = _step(xw, d, lo, hi, moving)
        x[walking], low[walking], high[walking] = xw, lo, hi
        walking = walking[~finished]
    return np.clip(x, 0.0, 1.0)


def _solve_held(h, g, low, high) -> np.ndarray:
    """Minimiser over the unknowns not held, the held ones fixed at 0 (low) or 1 (high)."""
    held = low | high
    value = high.astype(np.float64)
    rhs = np.where(held, value, g - np.einsum("pij,pj->pi", h, value))
    reduced = np.where(held[:, :, None] | held[:, None, :], 0.0, h)
    idx = np.arange(h.shape[-1])
    reduced[:, idx, idx] += held
    return spd_solve(reduced, rhs[..., None])[..., 0]


def _step(x, d, low, high, moving):
    """Move the moving pixels along d as far as the box lets them (at most the whole step); the unknown
    that stops a shortened step joins the working set at its bound."""
    free = ~(low | high)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(free & (d < 0), -x / d, np.where(free & (d > 0), (1.0 - x) / d, np.inf))
    ratio = np.maximum(ratio, 0.0)
    first = np.argmin(ratio, axis=1)
    rows = np.arange(len(x))
    alpha = np.minimum(ratio[rows, first], 1.0)
    alpha = np.where(moving, alpha, 0.0)
    x = x + alpha[:, None] * d
    blocked = moving & (ratio[rows, first] < 1.0)
    to_high = blocked & (d[rows, first] > 0)
    to_low = blocked & ~to_high
    low[to_low, first[to_low]] = True
    high[to_high, first[to_high]] = True
    x = np.where(high, 1.0, np.where(low, 0.0, x))
    return x, low, high
