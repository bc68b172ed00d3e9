"""Desired appearances for compensation tests: what the viewer should see, in capture space.

A test image is mapped linearly into the range the projector can reach on most of the surface
(per channel: the 75th percentile of I- to the 25th percentile of I+ over the reachable pixels), so
darker or saturated parts of the surface are hard and most of the frame is reachable. Pixels the
projector cannot change (off the object, shadows) keep their I- value: nothing can be done there.
"""
from __future__ import annotations

import numpy as np


def reachable_mask(cam_black: np.ndarray, cam_white: np.ndarray, threshold: float = 0.03) -> np.ndarray:
    """(H, W) bool: pixels where white projection brightens the capture noticeably."""
    return (np.asarray(cam_white) - np.asarray(cam_black)).max(axis=-1) > threshold


def reachable_range(cam_black, cam_white, mask=None, low_pct=75.0, high_pct=25.0):
    mask = reachable_mask(cam_black, cam_white) if mask is None else mask
    if not mask.any():
        raise ValueError("the projector does not reach the surface anywhere in the captures")
    lo = np.percentile(cam_black[mask], low_pct, axis=0)
    hi = np.percentile(cam_white[mask], high_pct, axis=0)
    return lo.astype(np.float32), np.maximum(hi, lo + 0.05).astype(np.float32)


def desired_targets(images, cam_black, cam_white, mask=None) -> np.ndarray:
    """(N, H, W, 3) test images in [0,1] -> desired captures (N, H, W, 3)."""
    mask = reachable_mask(cam_black, cam_white) if mask is None else mask
    lo, hi = reachable_range(cam_black, cam_white, mask)
    desired = lo + np.asarray(images, np.float32) * (hi - lo)
    return np.where(mask[None, ..., None], desired, cam_black[None]).astype(np.float32)
