"""Palettes: a gradient map through named colours (the prompt's "deep blue and gold"), a duotone, and
flat colour bands (the woodblock's few inks).

The colours are parameters, so PSA can move each one a little where the surface cannot show it. The
map follows luminance, stretched to the look's own range, so every named colour gets its share of
the image: the darkest named colour in the shadows, the lightest in the highlights.
"""
from __future__ import annotations

import colorsys

import torch

from .ops import band_weights, blur, equalised_luminance, keep_detail, px, ramp, soft_steps, stretched_luminance
from .stage import Stage, tensor

SCALES = {"colours": 0.2, "strength": 0.3, "sharpness": 10.0, "detail": 0.3, "plateau": 2.0}


def _lightness(rgb) -> float:
    return colorsys.rgb_to_hls(*rgb)[1]


def shade(rgb, lightness: float):
    h, _, s = colorsys.rgb_to_hls(*rgb)
    return colorsys.hls_to_rgb(h, lightness, s)


def ramp_colours(colours: list) -> list:
    """Named colours sorted dark to light; one colour gets a dark shade and a light tint of itself, so
    the image keeps its tones. Two or more stay as they are: each named colour gets its share."""
    cs = sorted((tuple(c) for c in colours), key=_lightness)
    if len(cs) == 1:
        light = _lightness(cs[0])
        return [shade(cs[0], min(0.12, light * 0.4)), cs[0], shade(cs[0], max(0.92, light))]
    return cs


def gradient_map(x, p, surface=None):
    v = stretched_luminance(x)
    cs = p["colours"].clamp(0, 1)
    if cs.shape[0] > 1 and "plateau" in p:
        # soft plateaus at each colour's place, so most pixels show a named colour, not a blend of two;
        # rescaled so the darkest and lightest tones still reach the end colours
        ends = soft_steps(torch.tensor([0.0, 1.0], device=v.device), cs.shape[0], p["plateau"])
        v = (soft_steps(v, cs.shape[0], p["plateau"]) - ends[0]) / (ends[1] - ends[0])
    mapped = ramp(v, cs)
    # keep a little of the look's own colour detail, so textures read through the new palette
    s = p["strength"].clamp(0, 1)
    return s * mapped + (1 - s) * x


def gradient_map_stage(colours: list, look: str = "named_palette", role: str = "palette",
                       strength: float = 0.85, plateau: float | None = 5.0) -> Stage:
    cs = ramp_colours(colours)
    params = {"colours": tensor(cs), "strength": tensor(strength)}
    if plateau:
        params["plateau"] = tensor(plateau)
    return Stage(look, role, gradient_map, params,
                 dict(SCALES), note=f"{len(colours)} colour(s)")


def flat_bands(x, p, surface=None):
    """Luminance cut into len(colours) flat bands, each painted one ink (the woodblock's flat colour)."""
    smooth = blur(x, px(x, 0.006))
    v = equalised_luminance(smooth)
    cs = p["colours"].clamp(0, 1)
    w = band_weights(v, cs.shape[0], p["sharpness"])
    flat = torch.einsum("bkhw,kc->bchw", w, cs)
    return keep_detail(flat, ramp(v, cs), p)
