# SPDX-License-Identifier: GPL-3.0-or-later
"""The refinement carried to the native-resolution output.

The loop measures at the working frame (where the registration and the model live); the native
projector image is finer. The light the loop added per working pixel (linear units, x = p^gamma_p) is
smooth where the errors it corrects are (bounce light, defocus, gloss, a model's bias), so it is
resampled to the native frame and added to the native image's own light, then clipped to the
projector's range: the native image keeps its detail and gains the loop's correction.
"""
from __future__ import annotations

import cv2
import numpy as np


def refine_native(native: np.ndarray, correction: np.ndarray, gamma_p: float) -> np.ndarray:
    """native (H,W,3) encoded projector image in [0,1]; correction (h,w,3) linear light from
    Refinement.linear_correction() for this image -> the refined native image (H,W,3) float32."""
    native = np.asarray(native, np.float32)
    h, w = native.shape[:2]
    up = cv2.resize(np.asarray(correction, np.float32), (w, h), interpolation=cv2.INTER_LINEAR)
    x = np.power(np.clip(native, 0, 1), np.float32(gamma_p)) + up
    return np.power(np.clip(x, 0, 1), np.float32(1.0 / gamma_p)).astype(np.float32)
