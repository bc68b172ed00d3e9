"""The repeatability limit of a setup: the same projector images captured twice, with different
noise seeds (the camera's sensor noise and Cycles' sampling). No compensation can be verified
beyond the PSNR between the two captures."""
from __future__ import annotations

import numpy as np

from ...lapig_core.common import metrics


def noise_floor(first: np.ndarray, second: np.ndarray, mask) -> dict:
    """PSNR (masked, as the compensation figures) and SSIM between two captures of the same images."""
    psnr = [metrics.masked_psnr(a, b, mask) for a, b in zip(first, second)]
    return {"noise_floor_psnr": round(float(np.mean(psnr)), 3),
            "noise_floor_ssim": round(float(np.mean([metrics.ssim(a, b) for a, b in zip(first, second)])), 4)}


def below_floor(figures: dict, floor_psnr: float) -> dict:
    """How far each method's masked PSNR is below the noise floor (dB), beside each figure."""
    return {f"{key}_below_noise_floor_db": round(floor_psnr - value["psnr_masked"], 3)
            for key, value in figures.items() if isinstance(value, dict) and "psnr_masked" in value}
