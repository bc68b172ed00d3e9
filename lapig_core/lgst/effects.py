"""Image effects for prompt words the 26 styles cannot express (all differentiable w.r.t. their input).

Pixel art: area-average into a coarse grid of blocks, nearest-upsample back, and quantise each channel
to a few levels (2 bits per channel = the 64-colour EGA-style palette of 1980s games). Quantisation
has zero gradient almost everywhere, so it uses a straight-through estimator: the forward pass shows
the quantised colour, the backward pass behaves like the identity, and PSA gradients still reach theta.
"""
from __future__ import annotations

import re
from dataclasses import dataclass

import torch
import torch.nn.functional as F

_PIXEL_WORDS = re.compile(r"pixel|8[\s-]?bit|16[\s-]?bit|sprite|retro game|video game|arcade", re.I)


def quantize_ste(x: torch.Tensor, levels: int) -> torch.Tensor:
    """Round each channel to `levels` evenly spaced values in [0,1]; identity gradient."""
    q = torch.round(x.clamp(0, 1) * (levels - 1)) / (levels - 1)
    return x + (q - x).detach()


def pixelate(x: torch.Tensor, blocks: int) -> torch.Tensor:
    """(B,C,H,W) -> same size, made of about `blocks` square blocks along the longer side."""
    h, w = x.shape[-2:]
    bh = max(1, round(blocks * h / max(h, w)))
    bw = max(1, round(blocks * w / max(h, w)))
    small = F.adaptive_avg_pool2d(x, (bh, bw))  # mean colour per block: smooth gradients for PSA
    return F.interpolate(small, size=(h, w), mode="nearest")


@dataclass
class PixelArt:
    blocks: int = 48
    levels: int = 4

    name = "pixel_art"
    # no built-in style is pixel art; the effect makes the blocks, and the style under it should give
    # the flat, saturated colour areas of 1980s game graphics: this text steers the style choice
    style_hint = "flat bold saturated primary colours, high contrast"

    def __call__(self, x: torch.Tensor) -> torch.Tensor:
        return quantize_ste(pixelate(x, self.blocks), self.levels)

    def label(self) -> str:
        return f"pixel_art(blocks={self.blocks}, levels/channel={self.levels})"


def effects_for_prompt(prompt: str) -> list:
    """The effects a prompt asks for, in the order they are applied."""
    effects = []
    if _PIXEL_WORDS.search(prompt or ""):
        effects.append(PixelArt())
    return effects
