"""Many small symmetric positive-definite systems at once (one per pixel: 3x3 and 4x4 normal equations), solved by
Cholesky in plain numpy array arithmetic, without LAPACK.

Why: numpy's batched np.linalg.solve / inv call LAPACK once per matrix, and the threaded OpenBLAS that numpy ships
synchronises its threads on each call. On a busy 2-core machine that made the classical model's fit (the first look
after Capture) take 52 s instead of 1.5 s: 20,000 4x4 inverses took 0.15-12.8 s with two BLAS threads against 7 ms
with one (BENCHMARKS, issue 28). Here each step is one vectorised operation over all the pixels, whatever the load.
"""
from __future__ import annotations

import numpy as np



def cholesky(g: np.ndarray) -> np.ndarray:
    """(..., k, k) SPD matrices -> their lower Cholesky factors L (g = L L^T)."""
    g = np.asarray(g, np.float64)
    k = g.shape[-1]
    low = np.zeros_like(g)
    for j in range(k):
        pivot = g[..., j, j] - (low[..., j, :j] ** 2).sum(-1)
        # a pivot that is not positive (a matrix that is not SPD): NaN, which callers' finiteness checks catch
        low[..., j, j] = np.sqrt(np.where(pivot > 0, pivot, np.nan))
        for i in range(j + 1, k):
            low[..., i, j] = (g[..., i, j] - (low[..., i, :j] * low[..., j, :j]).sum(-1)) / low[..., j, j]
    return low


def cho_solve(low: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Solve L L^T x = b for each matrix: low (..., k, k) from cholesky(), b (..., k, m)."""
    b = np.asarray(b, np.float64)
    k = low.shape[-1]
    z = np.empty(np.broadcast_shapes(low.shape[:-1], b.shape[:-2] + (k,)) + b.shape[-1:], np.float64)
    for i in range(k):  # L z = b
        z[..., i, :] = (b[..., i, :] - (low[..., i, :i, None] * z[..., :i, :]).sum(-2)) / low[..., i, i, None]
    x = np.empty_like(z)
    for i in reversed(range(k)):  # L^T x = z
        x[..., i, :] = (z[..., i, :] - (low[..., i + 1:, i, None] * x[..., i + 1:, :]).sum(-2)) / low[..., i, i, None]
    return x


def spd_solve(g: np.ndarray, b: np.ndarray) -> np.ndarray:
    """x with g x = b, for (..., k, k) SPD g and (..., k, m) b."""
    return cho_solve(cholesky(g), b)


def spd_inverse(g: np.ndarray) -> np.ndarray:
    """The inverses of (..., k, k) SPD matrices."""
    g = np.asarray(g, np.float64)
    return spd_solve(g, np.broadcast_to(np.eye(g.shape[-1]), g.shape))
