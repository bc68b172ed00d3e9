"""PSNR for data range 1, in numpy: the one definition the refinement (numpy only), the surface's reach
and the torch metrics (common/metrics) share."""
from __future__ import annotations

import math

import numpy as np


def psnr_from_mse(mse: float) -> float:
    """10 log10(1 / MSE); inf for identical images, nan for a nan MSE (no pixels)."""
    return math.inf if mse == 0 else 10.0 * math.log10(1.0 / mse)


def masked_psnr(a, b, mask) -> float:
    """PSNR of channel-last images a against b over the pixels of mask, (H, W) for every image or
    (N, H, W) one per image, every channel counted; nan when the mask is empty."""
    mask = np.asarray(mask, bool)
    if not mask.any():
        return math.nan
    err = ((np.asarray(a, np.float64) - np.asarray(b, np.float64)) ** 2).mean(-1)
    return psnr_from_mse(float(err[..., mask].mean()))
