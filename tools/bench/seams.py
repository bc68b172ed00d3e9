# SPDX-License-Identifier: GPL-3.0-or-later
"""Seam and overlap figures of several projectors in camera space (issue 36, `bench multi`), numpy + OpenCV.

- blend_edges(reached, mask): the pixels where one projector's reach ends while another's goes on (the
  edges the blend must hide), on the object mask;
- seam_ratio(error, reached, mask, band_px=8): mean abs error within `band_px` camera pixels of every blend
  edge over the mean abs error elsewhere on the mask (1: no seam; > 1: the edges show);
- white_uniformity_pct(white, reached, mask): the captured blended white's mean linear light in the overlap
  against each single-reach side; the largest relative difference, percent;
- psnr_on(a, b, mask): PSNR in dB of encoded [0,1] images on a mask (nan for an empty mask).
"""
from __future__ import annotations

import math

import cv2
import numpy as np


def _reached(reached) -> np.ndarray:
    r = np.asarray(reached, bool)
    if r.ndim != 3:
        raise ValueError(f"reached must be (K,H,W), got {r.shape}")
    return r


def blend_edges(reached, mask=None) -> np.ndarray:
    """(H,W) bool: pixels of some projector's reach that touch (4-neighbourhood) a pixel it does not reach but
    another projector does, and that pixel itself: both sides of every hand-over; restricted to `mask`."""
    r = _reached(reached)
    anyone = r.any(axis=0)
    edge = np.zeros(r.shape[1:], bool)
    kernel = np.ones((3, 3), np.uint8)
    kernel[0, 0] = kernel[0, 2] = kernel[2, 0] = kernel[2, 2] = 0
    for mine in r:
        others = anyone & ~mine
        if not mine.any() or not others.any():
            continue
        grow_mine = cv2.dilate(mine.astype(np.uint8), kernel).astype(bool)
        grow_others = cv2.dilate(others.astype(np.uint8), kernel).astype(bool)
        edge |= (mine & grow_others) | (others & grow_mine)
    if mask is not None:
        edge &= np.asarray(mask, bool)
    return edge


def near_edges(reached, mask=None, band_px: float = 8.0) -> np.ndarray:
    """(H,W) bool: on `mask`, within band_px (Euclidean) of a blend edge."""
    edge = blend_edges(reached, None)
    if not edge.any():
        near = np.zeros(edge.shape, bool)
    else:
        dist = cv2.distanceTransform((~edge).astype(np.uint8), cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
        near = dist <= band_px
    return near & (np.ones_like(near) if mask is None else np.asarray(mask, bool))


def seam_ratio(error, reached, mask=None, band_px: float = 8.0) -> float:
    """error: (H,W) or (H,W,C) absolute error; nan when there is no blend edge or nothing elsewhere."""
    e = np.abs(np.asarray(error, np.float64))
    if e.ndim == 3:
        e = e.mean(axis=-1)
    m = np.ones(e.shape, bool) if mask is None else np.asarray(mask, bool)
    near = near_edges(reached, m, band_px)
    far = m & ~near
    if not near.any() or not far.any():
        return math.nan
    rest = float(e[far].mean())
    return float(e[near].mean()) / rest if rest > 0 else math.inf


def white_uniformity_pct(white, reached, mask=None, gamma_c: float = 2.2,
                         adjacent_px: float | None = None) -> dict:
    """white: (H,W,3) encoded capture of the blended white. Regions: the overlap (reached by >= 2) and each
    projector's side (reached by it alone; adjacent_px: only within that many pixels of the overlap, which
    leaves out the light's and the surface's slow changes across a wide wall). Returns {"overlap": mean,
    "sides": [mean per projector],
    "pct": max over sides |overlap / side - 1| * 100} in linear light (nan when a region is empty)."""
    r = _reached(reached)
    lin = np.power(np.clip(np.asarray(white, np.float64), 0, 1), gamma_c)
    lum = lin.mean(axis=-1) if lin.ndim == 3 else lin
    m = np.ones(lum.shape, bool) if mask is None else np.asarray(mask, bool)
    count = r.sum(axis=0)
    overlap = m & (count >= 2)
    sides = [m & mine & (count == 1) for mine in r]
    if adjacent_px is not None and overlap.any():
        dist = cv2.distanceTransform((~overlap).astype(np.uint8), cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
        sides = [s & (dist <= adjacent_px) for s in sides]

    def mean(region):
        return float(lum[region].mean()) if region.any() else math.nan

    o = mean(overlap)
    side_means = [mean(s) for s in sides]
    diffs = [abs(o / s - 1.0) * 100 for s in side_means if s == s and s > 0 and o == o]
    return {"overlap": o, "sides": side_means, "pct": max(diffs) if diffs else math.nan}


def psnr_on(a, b, mask=None) -> float:
    """PSNR (dB) of two encoded [0,1] images on `mask` (None: everywhere); nan for an empty mask."""
    d = np.asarray(a, np.float64) - np.asarray(b, np.float64)
    if mask is not None:
        d = d[np.asarray(mask, bool)]
    if d.size == 0:
        return math.nan
    mse = float(np.mean(d * d))
    return math.inf if mse == 0 else 10.0 * math.log10(1.0 / mse)
