"""What a surface can show of a look: the truth the artist is told (issue 13).

- reachability: the share of the look's pixels whose three channels all lie inside the projector's
  physical range [I-, I+] (within REACH_TOLERANCE);
- clamp bound: PSNR(clamp(I, I-, I+), I), the best any compensation could do for that look;
- a plain message when a look is mostly out of reach, saying which way (too bright, too dark, or the
  wrong colour for the surface) and what PSA did about it.
All take (1,3,H,W) tensors (or (H,W,3) numpy arrays) and an optional on-object mask (H,W).
"""
from __future__ import annotations

import math

import numpy as np
import torch

from ..common.metrics import to_nchw
from ..common.psnr import psnr_from_mse

REACH_TOLERANCE = 2.0 / 255  # two 8-bit levels: within the camera's noise of the bound
MOSTLY_OUT = 0.5  # below this share a look is "mostly out of reach" and the artist is told


def _tensors(look, i_min, i_max, mask):
    look, i_min, i_max = (to_nchw(t) for t in (look, i_min, i_max))
    m = None if mask is None else torch.as_tensor(np.asarray(mask, bool))
    return look, i_min.to(look.device), i_max.to(look.device), m


def _over_pixels(per_pixel: torch.Tensor, mask) -> float:
    """Mean of an (N,H,W) map over the masked pixels (all when mask is None)."""
    values = per_pixel[:, mask] if mask is not None else per_pixel.flatten()
    return float(values.to(torch.float64).mean()) if values.numel() else math.nan


def reachability(look, i_min, i_max, mask=None) -> float:
    """Share of the look's pixels (on the object when mask is given) inside [I-, I+] in every channel."""
    look, i_min, i_max, mask = _tensors(look, i_min, i_max, mask)
    inside = ((look >= i_min - REACH_TOLERANCE) & (look <= i_max + REACH_TOLERANCE)).all(dim=1)
    return _over_pixels(inside, mask)


def clamp_bound_psnr(look, i_min, i_max, mask=None) -> float:
    """PSNR of clamp(I, I-, I+) against I (on the object when mask is given); inf when all of I is
    reachable. No projector image can bring the capture closer to the look than this."""
    look, i_min, i_max, mask = _tensors(look, i_min, i_max, mask)
    clamped = torch.minimum(torch.maximum(look, i_min), i_max)
    mse = _over_pixels(((clamped - look) ** 2).mean(dim=1), mask)
    return psnr_from_mse(mse)


def out_of_reach_split(look, i_min, i_max, mask=None) -> dict:
    """Which way the look leaves the range: the share of pixels above I+ (too bright for the
    surface) and below I- (darker than its black level), in any channel."""
    look, i_min, i_max, mask = _tensors(look, i_min, i_max, mask)
    above = (look > i_max + REACH_TOLERANCE).any(dim=1)
    below = (look < i_min - REACH_TOLERANCE).any(dim=1)
    return {"above": _over_pixels(above, mask), "below": _over_pixels(below, mask)}


def surface_truth(before, after, i_min, i_max, mask=None) -> dict:
    """The figures of one result: reachability and the clamp bound of the un-adapted look (before)
    and of the adapted one (after; None without PSA), and the message for the artist ('' if none)."""
    def figures(look):
        bound = clamp_bound_psnr(look, i_min, i_max, mask)
        return {"reachability": round(reachability(look, i_min, i_max, mask), 4),
                "clamp_bound_psnr": None if math.isinf(bound) else round(bound, 2),
                **{k: round(v, 4) for k, v in out_of_reach_split(look, i_min, i_max, mask).items()}}

    out = {"before_psa": figures(before), "after_psa": figures(after) if after is not None else None}
    out["message"] = reach_message(out["before_psa"], out["after_psa"])
    return out


def reach_message(before: dict, after: dict | None) -> str:
    """One plain sentence when the look is mostly out of the surface's reach, '' otherwise."""
    if before["reachability"] >= MOSTLY_OUT:
        return ""
    shown = f"this surface can show {before['reachability']:.0%} of the look"
    if before["above"] >= before["below"]:
        why = "the surface is too dark for a bright look"
        did, advice = "PSA made it darker", "try a darker prompt or more light (a brighter projector)"
    else:
        why = "the surface's black level is brighter than the look's dark parts"
        did, advice = "PSA lifted them", "try a lighter prompt or less ambient light"
    if after is None:
        return f"{shown.capitalize()}: {why}; turn on surface adaptation (PSA), or {advice}"
    return (f"{shown.capitalize()} ({after['reachability']:.0%} after adaptation): {why}, so {did}; "
            f"{advice}")
