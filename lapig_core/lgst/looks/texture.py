"""Surfaces of the medium: paper grain, canvas weave, and watercolour (a soft wash whose pigment pools
darker at the edges of each area, on grainy paper)."""
from __future__ import annotations

import math

import torch

from .ops import blur, fixed_noise, luminance, px, saturate, soft_steps
from .stage import Stage, tensor


def _paper(h, w, device):
    fibres = fixed_noise(h, w, seed=3, share=0.004, device=device)
    blotches = fixed_noise(h, w, seed=4, share=0.05, device=device)
    return 0.7 * fibres + 0.3 * blotches


def paper_grain(x, p, surface=None):
    h, w = x.shape[-2:]
    return x * (1 + p["strength"] * _paper(h, w, x.device)) + p["tone"] * (1 - x) * 0.15


def paper_stage() -> Stage:
    return Stage("paper_grain", "texture", paper_grain, {"strength": tensor(0.09), "tone": tensor(0.3)},
                 {"strength": 0.05, "tone": 0.2})


def canvas(x, p, surface=None):
    h, w = x.shape[-2:]
    period = px(x, 0.008, 2.5)
    yy = torch.arange(h, dtype=x.dtype, device=x.device).view(-1, 1)
    xx = torch.arange(w, dtype=x.dtype, device=x.device).view(1, -1)
    weave = torch.sin(2 * math.pi * yy / period) * torch.sin(2 * math.pi * xx / period)
    irregular = fixed_noise(h, w, seed=9, share=0.01, device=x.device)
    return x * (1 + p["strength"] * (0.7 * weave + 0.3 * irregular).view(1, 1, h, w))


def canvas_stage() -> Stage:
    return Stage("canvas_weave", "texture", canvas, {"strength": tensor(0.1)}, {"strength": 0.05})


def watercolour(x, p, surface=None):
    h, w = x.shape[-2:]
    wash = blur(x, px(x, 0.006))
    wash = 1 - (1 - saturate(wash, p["saturation"]).clamp(0, 1)) * p["density"].clamp(0.1, 1.2)  # lighter
    # pigment pools at the rims of each area: darker where the wash differs from its wider blur
    wide = blur(wash, px(x, 0.02))
    rim = torch.relu(luminance(wide) - luminance(wash)) + 0.5 * (wash - wide).abs().mean(1, keepdim=True)
    pooled = wash * (1 - p["edge_darkening"] * (rim * 6).clamp(0, 1))
    granulation = 1 + p["granulation"] * _paper(h, w, x.device)
    return pooled * granulation


def watercolour_stage() -> Stage:
    return Stage("watercolour_wash", "medium", watercolour,
                 {"density": tensor(0.75), "saturation": tensor(1.15), "edge_darkening": tensor(0.5),
                  "granulation": tensor(0.08)},
                 {"density": 0.2, "saturation": 0.3, "edge_darkening": 0.2, "granulation": 0.05})


def clay(x, p, surface=None):
    """Modelling clay: smooth rounded blobs of a few saturated colours, lit from the top left as if each
    area were a raised lump (the shading is the slope of a blurred height made from the flat colours)."""
    smooth = blur(x, px(x, 0.01))
    if "colours" in p:  # named colours: each lump one of them (by its tone and its own colour)
        from .patterns import palette_inks, ranked_tone

        flat = palette_inks(saturate(smooth, 1.3).clamp(0, 1), ranked_tone(smooth), p["colours"].clamp(0, 1),
                            p["sharpness"] * 2, p["saturation"].new_tensor(0.5))
        flat = saturate(flat, p["saturation"]).clamp(0, 1)
    else:
        flat = saturate(soft_steps(smooth.clamp(0, 1), 5, p["sharpness"]), p["saturation"]).clamp(0, 1)
    height = blur(luminance(flat), px(x, 0.012))
    gy = height[..., 1:, :] - height[..., :-1, :]
    gx = height[..., :, 1:] - height[..., :, :-1]
    gy = torch.nn.functional.pad(gy, (0, 0, 0, 1), mode="replicate")
    gx = torch.nn.functional.pad(gx, (0, 1, 0, 0), mode="replicate")
    slope = (gx + gy) * max(x.shape[-2:]) / 8  # the same relief at any resolution
    light = 1 + p["relief"] * torch.tanh(-slope * 4)
    sheen = p["sheen"] * torch.relu(torch.tanh(-slope * 4)) ** 3
    return flat * light + sheen


def clay_stage(colours=None) -> Stage:
    params = {"sharpness": tensor(4.0), "saturation": tensor(1.35), "relief": tensor(0.22), "sheen": tensor(0.1)}
    scales = {"sharpness": 2.0, "saturation": 0.3, "relief": 0.15, "sheen": 0.1}
    if colours:
        from .patterns import sorted_palette

        params["colours"], scales["colours"] = tensor(sorted_palette(colours, colours)), 0.2
    return Stage("modelling_clay", "medium", clay, params, scales,
                 note="named colours" if colours else "the image's colours, 5 steps")
