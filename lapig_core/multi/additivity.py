# SPDX-License-Identifier: GPL-3.0-or-later
"""The camera's gamma from the one thing several projectors add: their light.

Captures of one projector alone fix only the ratio of the projector's gamma to the camera's (C = (M P^gp +
o)^(1/gc) hardly changes when both scale together), and one projector's compensation needs no more. Several
projectors' light adds up in linear light only, so their joint model needs the camera's gamma itself: where
two or more projectors overlap, the all-white-together capture T, each projector's white alone A_k and the
all-black B satisfy

    T^g - B^g = sum_k (A_k^g - B^g)

at the true g. `additive_gamma` finds that g by a grid search on the overlap's unclipped pixels; the joint
fit then keeps each projector's searched ratio and scales its gamma to it.
"""
from __future__ import annotations

from typing import Sequence

import numpy as np

GAMMA_GRID = np.arange(1.0, 4.0001, 0.01)
MIN_PIXELS = 50  # overlap pixels below which additivity says nothing
_CLIPPED = 0.99


def additive_gamma(together: np.ndarray, alone_whites: Sequence[np.ndarray], black: np.ndarray,
                   reached: np.ndarray) -> float | None:
    """The camera gamma that makes the projectors' light add up, or None where fewer than MIN_PIXELS overlap.
    together, alone_whites[k], black: (H,W,3) captures (uint8 or float in [0,1]); reached: (K,H,W) bool."""
    scale = lambda a: np.asarray(a, np.float64) / (255.0 if np.asarray(a).dtype == np.uint8 else 1.0)
    t, b = scale(together), scale(black)
    overlap = (np.asarray(reached).sum(axis=0) >= 2) & (t.max(axis=-1) < _CLIPPED)
    if overlap.sum() < MIN_PIXELS:
        return None
    t, b = t[overlap], b[overlap]
    a = [scale(w)[overlap] for w in alone_whites]
    errors = []
    for g in GAMMA_GRID:
        tg, bg = t ** g, b ** g
        rest = sum(x ** g - bg for x in a)
        errors.append(np.mean(((tg - bg - rest) / np.maximum(tg, 1e-6)) ** 2))
    return float(GAMMA_GRID[int(np.argmin(errors))])
