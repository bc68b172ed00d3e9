"""The colours an image carries: its dominant palette (k-means) and whether a named colour is among them.

Shared by bench prompts (colour adherence) and painter_checks (a named entry's palette), so neither imports
the other.
"""
from __future__ import annotations

import colorsys

import numpy as np

# a colour is present when a cluster of at least MIN_SHARE of the image lies within these tolerances
HUE_TOL, LIGHT_TOL, MIN_SHARE = 25.0, 0.2, 0.03


def dominant_palette(img: np.ndarray, k: int = 6, seed: int = 0) -> list[tuple[np.ndarray, float]]:
    """k-means colours of an (H,W,3) image with their shares, largest first."""
    pix = img.reshape(-1, 3).astype(np.float64)
    rng = np.random.default_rng(seed)
    pix = pix[rng.choice(len(pix), size=min(len(pix), 6000), replace=False)]
    centres = pix[rng.choice(len(pix), size=k, replace=False)]
    for _ in range(20):
        label = ((pix[:, None] - centres[None]) ** 2).sum(-1).argmin(1)
        centres = np.stack([pix[label == j].mean(0) if (label == j).any() else centres[j] for j in range(k)])
    share = np.bincount(label, minlength=k) / len(label)
    return sorted(zip(centres, share), key=lambda cs: -cs[1])


def colour_present(rgb, palette) -> bool:
    h, light, sat = colorsys.rgb_to_hls(*rgb)
    for centre, share in palette:
        if share < MIN_SHARE:
            continue
        ch, cl, cs = colorsys.rgb_to_hls(*np.clip(centre, 0, 1))
        if abs(cl - light) > LIGHT_TOL:
            continue
        if sat < 0.2 or light < 0.08 or light > 0.92:  # greys, black, white: lightness only
            return True
        dh = abs(ch - h) * 360
        if min(dh, 360 - dh) <= HUE_TOL and cs >= 0.12:
            return True
    return False
