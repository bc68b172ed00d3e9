# SPDX-License-Identifier: GPL-3.0-or-later
"""The projector-space comparison of two compensators, which the benchmarks record beside the
product's choice (lapig_core.photometric.choice: the rig's renders, else PCNet's simulated captures).

Both compensators recover the projector images of held-back captures, counted only where a capture
lies inside the surface's range (above I- and below I+ by UNCLIPPED_MARGIN): where it sits at the
black or the white end many projector values make the same capture, and the comparison there is noise
(over all registered pixels it had picked CompenNeSt on the tilted relief, 4.5 dB behind rendered). It
misses three of the five realistic setups, so the product does not use it. Reached by
tools/bench/bench_transport.py and tests/core/test_compensator_choice.py.
"""
from __future__ import annotations

import math

import numpy as np

from ...lapig_core.common.psnr import psnr_from_mse
from ...lapig_core.photometric.choice import CLASSICAL, LEARNED, MAX_PSNR, CompensatorChoice

UNCLIPPED_MARGIN = 0.02  # a capture this far inside (I-, I+) identifies its projector value (noise ~0.003)


def identifiable(cam: np.ndarray, black: np.ndarray | None, white: np.ndarray | None,
                 mask: np.ndarray | None) -> np.ndarray:
    """(N, H, W, 3) bool: the pixels and channels whose capture identifies the projector value
    (registered, and inside (I-, I+) by UNCLIPPED_MARGIN; without I- and I+ every registered one)."""
    cam = np.asarray(cam, np.float32)
    keep = np.ones(cam.shape, bool)
    if black is not None and white is not None:
        keep &= (cam > np.asarray(black, np.float32)[None] + UNCLIPPED_MARGIN) \
            & (cam < np.asarray(white, np.float32)[None] - UNCLIPPED_MARGIN)
    if mask is not None:
        keep &= np.asarray(mask, bool)[None, ..., None]
    return keep


def validation_psnr(compensate, cam: np.ndarray, prj: np.ndarray, mask: np.ndarray | None,
                    black: np.ndarray | None = None, white: np.ndarray | None = None) -> float:
    """Mean PSNR of compensate(captures) against the projector images that made them, over the
    identifiable pixels of each pair (`identifiable`); a pair with none counts as nothing."""
    pred = np.asarray(compensate(cam), np.float32)
    keep = identifiable(cam, black, white, mask)
    values = []
    for p, t, k in zip(pred, np.asarray(prj, np.float32), keep):
        if k.any():
            values.append(min(MAX_PSNR, psnr_from_mse(float(np.mean((p - t)[k] ** 2)))))
    return float(np.mean(values)) if values else math.nan


def choose(learned, classical, cam_val, prj_val, mask=None, black=None, white=None) -> CompensatorChoice:
    """Compare two compensators (callables numpy -> numpy) on held-back pairs, over their identifiable
    pixels (black, white: the I- and I+ captures); ties go to the learned one."""
    n = len(cam_val)
    if n == 0:
        return CompensatorChoice(LEARNED, None, None, 0, "no held-back pairs to compare on")
    lp = validation_psnr(learned, cam_val, prj_val, mask, black, white)
    cp = validation_psnr(classical, cam_val, prj_val, mask, black, white)
    if math.isnan(lp) or math.isnan(cp):
        return CompensatorChoice(LEARNED, None, None, n, "the held-back captures are clipped everywhere")
    return CompensatorChoice(CLASSICAL if cp > lp else LEARNED, round(lp, 4), round(cp, 4), n)
