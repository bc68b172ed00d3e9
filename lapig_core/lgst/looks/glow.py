"""Light: bloom (a soft glow around the bright parts) and neon (glowing coloured tubes along the edges
on a darkened image)."""
from __future__ import annotations

import torch

from .ops import blur, normalised_edges, px, ramp, stretched_luminance
from .stage import Stage, tensor

NEON = ((1.0, 0.1, 0.75), (0.1, 0.9, 1.0), (0.75, 1.0, 0.2))  # magenta, cyan, acid green


def bloom(x, p, surface=None):
    # relative to the image's own range, so a light image does not bloom all over
    bright = torch.relu(stretched_luminance(x) - p["threshold"]) / (1 - p["threshold"]).clamp_min(0.05)
    glow = blur(x * bright, px(x, 0.03)) + blur(x * bright, px(x, 0.008))
    return (x * p["base"] + p["strength"] * glow).clamp(0, 1)


def bloom_stage() -> Stage:
    return Stage("soft_glow", "medium", bloom,
                 {"threshold": tensor(0.7), "strength": tensor(0.55), "base": tensor(0.9)},
                 {"threshold": 0.1, "strength": 0.3, "base": 0.2})


def neon(x, p, surface=None):
    edges = normalised_edges(x, px(x, 0.006))
    tube = torch.sigmoid((edges - p["threshold"]) / 0.08)
    colour = ramp(stretched_luminance(x), p["colours"].clamp(0, 1))  # tube colour follows the tone
    light = tube * colour
    glow = blur(light, px(x, 0.012)) * 1.6 + blur(light, px(x, 0.04)) * 1.2
    base = x * p["ambient"].clamp(0, 1)
    return (base + light + p["glow"] * glow).clamp(0, 1)


def neon_stage(colours=None) -> Stage:
    cs = list(colours) if colours else list(NEON)
    return Stage("neon_glow", "medium", neon,
                 {"threshold": tensor(0.6), "ambient": tensor(0.22), "glow": tensor(1.0), "colours": tensor(cs)},
                 {"threshold": 0.1, "ambient": 0.1, "glow": 0.3, "colours": 0.2},
                 note="named colours" if colours else "magenta, cyan, green")
