# SPDX-License-Identifier: GPL-3.0-or-later
"""The training frames each projector shows alone during a capture of several projectors.

The joint model samples a projector image at the point each camera pixel sees (CameraMap.sample), so its
training frames must be smooth: where a frame has detail finer than a camera pixel, what the camera
integrates and what the map samples differ, and that difference is fitted as error. Smooth random colour
fields (a few cells, cubic) span the colours the model must learn without that.
"""
from __future__ import annotations

import cv2
import numpy as np


def smooth_frames(projector_size, n: int, seed: int = 0, cells=(4, 3)) -> np.ndarray:
    """(n,h,w,3) float32 training frames: smooth random colour fields (a few cells, cubic), the first two
    black and white. Smooth, so sampling them at a camera pixel hardly depends on where in the pixel."""
    w, h = projector_size
    rng = np.random.default_rng(seed)
    out = np.empty((n, h, w, 3), np.float32)
    for i in range(n):
        coarse = rng.random((cells[1], cells[0], 3)).astype(np.float32)
        out[i] = cv2.resize(coarse, (w, h), interpolation=cv2.INTER_CUBIC).clip(0, 1)
    out[:min(n, 2)] = np.arange(min(n, 2), dtype=np.float32)[:, None, None, None]
    return out
