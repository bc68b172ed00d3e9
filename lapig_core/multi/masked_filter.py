# SPDX-License-Identifier: GPL-3.0-or-later
"""A Gaussian blur that stays inside a mask (normalised convolution).

A plain blur near a mask's edge mixes in whatever lies outside (zeros, garbage); dividing the blurred
masked values by the blurred mask averages only the pixels inside, so the edge keeps its level.
"""
from __future__ import annotations

import cv2
import numpy as np


def masked_gaussian(values: np.ndarray, mask: np.ndarray, sigma: float, fill: float = 0.0) -> np.ndarray:
    """(H,W[,C]) values blurred by a Gaussian of `sigma` pixels over the pixels of `mask` (H,W) only.

    Inside the mask each result is the Gaussian-weighted mean of the masked pixels around it; outside it
    is `fill`. sigma <= 0 returns the values (float32) with `fill` outside the mask.
    """
    v = np.asarray(values, np.float32)
    m = np.asarray(mask, bool)
    inside = m if v.ndim == 2 else m[..., None]
    if sigma <= 0:
        return np.where(inside, v, np.float32(fill)).astype(np.float32)
    weight = cv2.GaussianBlur(m.astype(np.float32), (0, 0), sigma, borderType=cv2.BORDER_CONSTANT)
    total = cv2.GaussianBlur(np.where(inside, v, 0.0).astype(np.float32), (0, 0), sigma,
                             borderType=cv2.BORDER_CONSTANT)
    if v.ndim == 3:
        weight = weight[..., None]
    out = total / np.maximum(weight, 1e-12)
    return np.where(inside, out, np.float32(fill)).astype(np.float32)
