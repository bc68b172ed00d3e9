# SPDX-License-Identifier: GPL-3.0-or-later
"""The in-between look of two keyed looks at weight w (0: look a, 1: look b), before its tone field.

Where both looks come from one backend and their theta tensors have equal shapes, theta is interpolated
and rendered by both looks' backends, their images mixed in linear light with the same w: the
backend's non-theta choices (a prompt's effects, its content weights) differ between two prompts, and
mixing the two renders of the one interpolated theta makes w = 0 and w = 1 the keyed looks exactly.
Otherwise (two backends, or theta of other shapes) the keyed looks' images are mixed in linear light.
Either way frames.py adapts the result through the tone field as one look of its own.
"""
from __future__ import annotations

import torch

from .look_state import KeyedLook

GAMMA = 2.2  # light mixes as values ** GAMMA


def mix_linear(a: torch.Tensor, b: torch.Tensor, w: float) -> torch.Tensor:
    """((1-w) a^g + w b^g)^(1/g): a mix of the light, not of the encoded values."""
    light = (1.0 - w) * a.clamp(0, 1) ** GAMMA + w * b.clamp(0, 1) ** GAMMA
    return light.clamp_min(1e-8) ** (1.0 / GAMMA)


def shares_theta(a: KeyedLook, b: KeyedLook) -> bool:
    ta, tb = a.state.get("theta") or [], b.state.get("theta") or []
    return (a.name == b.name and len(ta) == len(tb) and len(ta) > 0
            and all(x.shape == y.shape for x, y in zip(ta, tb)))


def lerp_list(xs, ys, w: float) -> list:
    return [(1.0 - w) * x + w * y for x, y in zip(xs, ys)]


def _render(look: KeyedLook, theta: list, surface=None) -> torch.Tensor:
    """look's backend with `theta` for a moment (its own theta put back after)."""
    own = look.backend.state()
    try:
        look.backend.load_state({**own, "theta": [t.to(p.device) for t, p in zip(theta, own["theta"])]})
        with torch.no_grad():
            return look.backend.forward() if surface is None else look.backend.render_at(surface)
    finally:
        look.backend.load_state(own)


def morph_base(a: KeyedLook, b: KeyedLook, w: float, surface=None, base_a=None, base_b=None,
               move_a=None, move_b=None) -> torch.Tensor:
    """The in-between image (1,3,H,W) at w; `surface`: render at that white-lit surface's size instead of the
    working frame (base_a / base_b: the keyed looks' images at that size, for the mix fallback and the ends).
    move_a / move_b: applied to each look's image before the mix (a moving look where it stands)."""
    move_a = move_a or (lambda x: x)
    move_b = move_b or (lambda x: x)
    image_a = a.base if surface is None else base_a
    image_b = b.base if surface is None else base_b
    if w <= 0.0:
        return move_a(image_a)
    if w >= 1.0:
        return move_b(image_b)
    if shares_theta(a, b):
        theta = lerp_list(a.state["theta"], b.state["theta"], w)
        image_a, image_b = _render(a, theta, surface), _render(b, theta, surface)
    return mix_linear(move_a(image_a), move_b(image_b), w)
