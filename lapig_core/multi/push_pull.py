# SPDX-License-Identifier: GPL-3.0-or-later
"""Filling holes in a sparsely known image by push-pull (Gortler et al., The Lumigraph, 1996).

Push: halve the image again and again, each coarse pixel the confidence-weighted mean of its 2x2 block.
Pull: from the coarsest level up, each pixel keeps its own value as far as it is known and takes the
rest from the level below it, scaled up. A hole is filled from the nearest known pixels, smoothly, at
the cost of a few whole-image passes (no per-hole search, no iterations).
"""
from __future__ import annotations

import cv2
import numpy as np


def push_pull(values: np.ndarray, confidence: np.ndarray) -> np.ndarray:
    """(H,W[,C]) values, (H,W) confidence in [0,1] (0: unknown, 1: known) -> (H,W[,C]) float32, every
    pixel filled. Pixels of confidence 1 keep their values; with nothing known at all, zeros."""
    v = np.asarray(values, np.float32)
    flat = v.ndim == 2
    if flat:
        v = v[..., None]
    c = np.clip(np.asarray(confidence, np.float32), 0.0, 1.0)
    out = _fill(np.where(c[..., None] > 0, v, 0.0).astype(np.float32), c)
    return out[..., 0] if flat else out


def _fill(v: np.ndarray, c: np.ndarray) -> np.ndarray:
    h, w = c.shape
    if (c >= 1.0).all() or (h == 1 and w == 1):
        return v
    # push: 2x2 blocks (an odd edge row or column is repeated, so every pixel counts once or twice)
    ve = np.pad(v * c[..., None], ((0, h % 2), (0, w % 2), (0, 0)), mode="edge")
    ce = np.pad(c, ((0, h % 2), (0, w % 2)), mode="edge")
    hh, ww = ce.shape[0] // 2, ce.shape[1] // 2
    sum_v = ve.reshape(hh, 2, ww, 2, -1).sum(axis=(1, 3))
    sum_c = ce.reshape(hh, 2, ww, 2).sum(axis=(1, 3))
    coarse = np.where(sum_c[..., None] > 0, sum_v / np.maximum(sum_c, 1e-12)[..., None], 0.0).astype(np.float32)
    coarse = _fill(coarse, np.minimum(sum_c, 1.0))
    # pull: the coarse level, scaled up, fills what this level does not know
    up = cv2.resize(coarse, (ww * 2, hh * 2), interpolation=cv2.INTER_LINEAR)
    up = up.reshape(hh * 2, ww * 2, -1)[:h, :w]
    return (c[..., None] * v + (1.0 - c[..., None]) * up).astype(np.float32)
