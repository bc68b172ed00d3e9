# SPDX-License-Identifier: GPL-3.0-or-later
"""The black level where projectors overlap, and the contrast it costs.

A projector showing black still leaks white / contrast. Blending dims each projector's white in an
overlap, but not its black: where K projectors overlap black is the sum of their blacks while white
stays at the blend's level, so black is about K times brighter relative to white than where one
projector reaches, and contrast falls by as much (NOTES section 12; raising the rest to match, black-level
uplift, costs that contrast everywhere instead). Computed in linear light per camera pixel, as black
relative to the blended white, so the surface's albedo cancels.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..photometry.units import black_level_from_contrast
from .joint_model import JointModel

_LUMA = np.array([0.2126, 0.7152, 0.0722])  # Rec. 709 luminance of linear RGB


def projector_blacks(model: JointModel, contrasts) -> np.ndarray:
    """(K,H,W,3) float32: each projector's black light in linear capture units, its white (M_k . 1) over its
    contrast ratio (one per projector, e.g. from its spec sheet)."""
    ratio = np.array([black_level_from_contrast(c) for c in contrasts], np.float32)
    if ratio.shape != (model.count,):
        raise ValueError(f"one contrast ratio per projector: {model.count}, got {len(ratio)}")
    return (model.M.sum(axis=-1) * ratio[:, None, None, None]).astype(np.float32)


@dataclass
class BlackUplift:
    """Black relative to white (linear) where one projector reaches and where several overlap; the ratio
    (uplift), the contrast ratios and the share of contrast lost; by_count: uplift per overlap count."""

    single_black: float
    overlap_black: float
    uplift: float
    single_contrast: float
    overlap_contrast: float
    contrast_cost: float
    by_count: dict = field(default_factory=dict)

    def sentence(self) -> str:
        if not np.isfinite(self.uplift):
            return "No projectors overlap, so black is no brighter anywhere."
        return (f"Where projectors overlap black is {self.uplift:.1f}x as bright as where one reaches: "
                f"contrast falls from {self.single_contrast:.0f}:1 to {self.overlap_contrast:.0f}:1 there "
                f"({100 * self.contrast_cost:.0f}% lost).")


def black_uplift(blacks: np.ndarray, whites: np.ndarray, reached: np.ndarray,
                 weights: np.ndarray | None = None) -> BlackUplift:
    """blacks, whites: (K,H,W,3) linear light of each projector at black and at full white (above black);
    reached: (K,H,W) bool; weights: (K,H,W) blend weights (None: an even split where reached). Medians
    over the pixels one projector reaches and over those two or more reach."""
    reached = np.asarray(reached, bool)
    count = reached.sum(axis=0)
    if weights is None:
        weights = reached / np.maximum(count, 1)
    black = _luminance(blacks, reached).sum(axis=0)
    white = (_luminance(whites, reached) * weights).sum(axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        relative = np.where(white > 0, black / white, np.nan)

    def median(mask) -> float:
        vals = relative[mask & np.isfinite(relative)]
        return float(np.median(vals)) if vals.size else float("nan")

    single, overlap = median(count == 1), median(count >= 2)
    by_count = {int(n): median(count == n) / single for n in np.unique(count[count >= 2])}
    return BlackUplift(single, overlap, overlap / single, 1.0 / single, 1.0 / overlap, 1.0 - single / overlap,
                       by_count)


def _luminance(light: np.ndarray, reached: np.ndarray) -> np.ndarray:
    """(K,H,W,3) linear light -> (K,H,W) luminance, 0 where the projector does not reach."""
    return np.einsum("khwc,c->khw", np.asarray(light, np.float64) * reached[..., None], _LUMA)


def model_black_uplift(model: JointModel, contrasts, weights: np.ndarray | None = None) -> BlackUplift:
    """black_uplift of a fitted joint model, each projector's black from its contrast ratio."""
    whites = model.M.sum(axis=-1)
    return black_uplift(projector_blacks(model, contrasts), whites, model.reached, weights)
