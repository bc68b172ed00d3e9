# SPDX-License-Identifier: GPL-3.0-or-later
"""Where a show's flicker comes from (bench show, issue 38): the flicker split by the surface's reach, the
floor's affine fit, and a sheet of one pair of frames.

measured: frame index -> (captured, target, valid), channel-last images at one size. The flicker of a pair
(p, q) is |change of the captured - change of the target| over |change of the target|; here it is summed
over pixels and pairs (bench_show._flicker averages per pair first: the same when the valid mask is fixed).

A pixel of a pair is out of reach where either frame's target lies outside the classical model's
[I- - margin, I+ + margin] in some channel: there the compensation clips, and no projector frame shows the
target's change. clip_flicker is what a perfect compensator limited to that reach would score: the targets
clamped to [I-, I+] against the targets.
"""
from __future__ import annotations

import math

import numpy as np

REACH_MARGIN = 0.02


def resized(image: np.ndarray, shape_hw) -> np.ndarray:
    """image (h, w, c) at (H, W) (bilinear), unchanged when it is already there."""
    if tuple(image.shape[:2]) == tuple(shape_hw):
        return image
    import cv2

    return cv2.resize(image, (int(shape_hw[1]), int(shape_hw[0])), interpolation=cv2.INTER_LINEAR)


def out_of_reach(target: np.ndarray, i_min: np.ndarray, i_max: np.ndarray, margin: float = REACH_MARGIN):
    """(H, W) bool: the target lies outside [I- - margin, I+ + margin] in some channel."""
    return ((target < i_min - margin) | (target > i_max + margin)).any(axis=-1)


def _pairs(measured: dict, indices: list, reach=None):
    for p, q in zip(indices, indices[1:]):
        (cp, tp, vp), (cq, tq, vq) = measured[p], measured[q]
        err = np.abs((cq - cp) - (tq - tp)).mean(axis=-1)
        change = np.abs(tq - tp).mean(axis=-1)
        out = np.zeros_like(vp) if reach is None else (
            out_of_reach(tp, *reach) | out_of_reach(tq, *reach))
        yield err, change, vp & vq, out


def flicker_split(measured: dict, indices: list, reach) -> dict:
    """The flicker over all pixels, over the pixels in reach and out of it, the share of the pixels out of
    reach and the share of the flicker's numerator they carry. reach: (I-, I+) at the measured size."""
    sums = {k: 0.0 for k in ("err", "change", "err_in", "change_in", "err_out", "change_out", "n", "n_out")}
    for err, change, valid, out in _pairs(measured, indices, reach):
        inside, outside = valid & ~out, valid & out
        sums["err"] += float(err[valid].sum())
        sums["change"] += float(change[valid].sum())
        sums["err_in"] += float(err[inside].sum())
        sums["change_in"] += float(change[inside].sum())
        sums["err_out"] += float(err[outside].sum())
        sums["change_out"] += float(change[outside].sum())
        sums["n"] += float(valid.sum())
        sums["n_out"] += float(outside.sum())
    ratio = lambda a, b: a / b if b > 0 else math.nan  # noqa: E731
    return {"flicker": ratio(sums["err"], sums["change"]),
            "in_reach": ratio(sums["err_in"], sums["change_in"]),
            "out_of_reach": ratio(sums["err_out"], sums["change_out"]),
            "out_of_reach_pixels": ratio(sums["n_out"], sums["n"]),
            "out_of_reach_error_share": ratio(sums["err_out"], sums["err"])}


def clipped(measured: dict, reach) -> dict:
    """The targets clamped to the reach, as if captured: what a perfect compensator limited to [I-, I+]
    would show."""
    lo, hi = reach
    return {i: (np.clip(t, lo, hi), t, v) for i, (_, t, v) in measured.items()}


def affine_fitted(measured: dict) -> dict:
    """The captures mapped by one affine per channel (captured -> target, least squares over every valid
    pixel of every frame): a camera's gain and offset taken out, its per-pixel shading left in."""
    caps = np.concatenate([c[v] for c, _, v in measured.values()])
    tgts = np.concatenate([t[v] for _, t, v in measured.values()])
    gain, offset = np.ones(caps.shape[-1], np.float32), np.zeros(caps.shape[-1], np.float32)
    for ch in range(caps.shape[-1]):
        a = np.stack([caps[:, ch], np.ones(len(caps))], axis=1)
        (gain[ch], offset[ch]), *_ = np.linalg.lstsq(a, tgts[:, ch], rcond=None)
    return {i: (c * gain + offset, t, v) for i, (c, t, v) in measured.items()}


def pair_sheet(measured: dict, p: int, q: int, reach, path: str, scale: int = 4, gain: float = 4.0) -> str:
    """A PNG of one pair of frames: target change, captured change, their difference (each 0.5 + gain x
    change), and the pixels out of reach (white), side by side, each `scale` times enlarged."""
    import cv2

    (cp, tp, vp), (cq, tq, vq) = measured[p], measured[q]
    valid = (vp & vq)[..., None]
    show = lambda d: np.clip(0.5 + gain * d, 0, 1) * valid  # noqa: E731
    out = (out_of_reach(tp, *reach) | out_of_reach(tq, *reach))[..., None].repeat(3, -1).astype(np.float32)
    panels = [show(tq - tp), show(cq - cp), show((cq - cp) - (tq - tp)), out * valid]
    sheet = np.concatenate([np.pad(x, ((2, 2), (2, 2), (0, 0)), constant_values=0.2) for x in panels], axis=1)
    sheet = cv2.resize(sheet, None, fx=scale, fy=scale, interpolation=cv2.INTER_NEAREST)
    cv2.imwrite(path, cv2.cvtColor(np.round(sheet * 255).astype(np.uint8), cv2.COLOR_RGB2BGR))
    return path
