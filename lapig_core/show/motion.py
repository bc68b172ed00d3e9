# SPDX-License-Identifier: GPL-3.0-or-later
"""The motion presets: smooth, periodic functions of time that move a look.

    drift         the look's texture slides on a small loop (a sub-pixel translation, mirrored at the edges)
    rise          a soft band of light rises over the object (the rest dimmed) and wraps round
    pulse         the light breathes: dimmed and back, in linear light
    colour_cycle  the hues swing round the grey axis and back (a rotation in linear RGB)
    world         a look of the world's own time (lgst/world/moving: water flows, fire flickers): not an image
                  op; frames.py draws the look again at t (frames.world_time)

Each acts on the look's image, before its tone field, by differentiable image ops; not on theta.
Why the image: theta means something different in every backend (a style network's normalisation, a
mix of style vectors, a diffusion latent), and no backend's theta has a "translate" or a "hue"
direction, so a preset on theta would be one per backend and still not move the texture; an image op
moves any look the same way, costs milliseconds, and leaves the keyed look's rendering (once per look) as
it was approved. Acting before the tone field keeps PSA's adaptation fixed to the object: the texture
moves, the surface's compensation does not (frames.py adapts each moved image through the field,
warm-started).

Every preset is the look itself at t = 0 (so a hold that starts moving starts where the transition
left it) and has period `period_s`. `amount` in [0, 1] scales its largest move.
"""
from __future__ import annotations

import math

import torch
from torch.nn import functional as F

GAMMA = 2.2  # the projector's transfer: light mixes as values ** GAMMA
DRIFT_MAX = 0.04  # the loop's radius at amount 1, as a share of the frame's short side
RISE_MAX = 0.7  # the dimming away from the band at amount 1
RISE_SHARPNESS = 6  # the band's power of a raised cosine: about a fifth of the frame
PULSE_MAX = 0.6  # the dimming at the pulse's low point at amount 1


def _linear(image):
    return image.clamp(0, 1) ** GAMMA


def _encoded(light):
    return light.clamp(1e-8, 1) ** (1.0 / GAMMA)


def drift(image: torch.Tensor, amount: float, phase: float) -> torch.Tensor:
    """A translation round a small circle, starting at rest; mirrored at the frame's edges."""
    h, w = image.shape[-2:]
    radius = DRIFT_MAX * amount * min(h, w)  # pixels
    angle = 2.0 * math.pi * phase
    dx, dy = radius * math.sin(angle), radius * (1.0 - math.cos(angle))
    # grid_sample's normalised coordinates: 2 / size per pixel
    theta = torch.tensor([[[1.0, 0.0, -2.0 * dx / w], [0.0, 1.0, -2.0 * dy / h]]], dtype=image.dtype,
                         device=image.device)
    grid = F.affine_grid(theta, list(image.shape), align_corners=False)
    return F.grid_sample(image, grid, mode="bilinear", padding_mode="reflection", align_corners=False)


def _band(h: int, phase: float, like: torch.Tensor) -> torch.Tensor:
    y = (torch.arange(h, dtype=like.dtype, device=like.device) + 0.5) / h
    # a raised cosine in y, moving up one frame height per period; zero slope everywhere
    return ((1.0 + torch.cos(2.0 * math.pi * (y + phase - 0.5))) / 2.0) ** RISE_SHARPNESS


def rise(image: torch.Tensor, amount: float, phase: float) -> torch.Tensor:
    """A soft band of the look's full light rising up the frame, the rest dimmed (never brighter than the
    look, so a bright look's band is not lost to the surface's clamp); faded in from t = 0, at rest there."""
    h = image.shape[-2]
    band = _band(h, phase, image)[None, None, :, None]
    fade = (1.0 - math.cos(2.0 * math.pi * phase)) / 2.0  # 0 at the period's start and end
    light = _linear(image) * (1.0 - RISE_MAX * amount * fade * (1.0 - band))
    return _encoded(light)


def pulse(image: torch.Tensor, amount: float, phase: float) -> torch.Tensor:
    """The look's light dimmed and back: never brighter than the look, so the surface can show it."""
    dim = PULSE_MAX * amount * (1.0 - math.cos(2.0 * math.pi * phase)) / 2.0
    return _encoded(_linear(image) * (1.0 - dim))


def hue_rotation(angle: float, like: torch.Tensor) -> torch.Tensor:
    """The 3x3 rotation by `angle` round the grey axis (Rodrigues): greys stay grey."""
    c, s = math.cos(angle), math.sin(angle)
    k = 1.0 / 3.0
    r = [[c + (1 - c) * k, (1 - c) * k - s * math.sqrt(k), (1 - c) * k + s * math.sqrt(k)],
         [(1 - c) * k + s * math.sqrt(k), c + (1 - c) * k, (1 - c) * k - s * math.sqrt(k)],
         [(1 - c) * k - s * math.sqrt(k), (1 - c) * k + s * math.sqrt(k), c + (1 - c) * k]]
    return torch.tensor(r, dtype=like.dtype, device=like.device)


def colour_cycle(image: torch.Tensor, amount: float, phase: float) -> torch.Tensor:
    """The hues swung by up to amount x 180 degrees and back over the period."""
    angle = amount * math.pi * math.sin(2.0 * math.pi * phase)
    rotation = hue_rotation(angle, image)
    light = torch.einsum("ij,bjhw->bihw", rotation, _linear(image))
    return _encoded(light)


PRESETS = {"drift": drift, "rise": rise, "pulse": pulse, "colour_cycle": colour_cycle}


def apply_motion(image: torch.Tensor, motion, t: float) -> torch.Tensor:
    """`image` (1,3,H,W) in [0, 1] moved by `motion` (model.Motion) at `t` seconds; None: unchanged."""
    if motion is None or motion.preset == "world":  # a world look's own time: frames.py draws it again at t
        return image
    phase = (float(t) / float(motion.period_s)) % 1.0
    return PRESETS[motion.preset](image, float(motion.amount), phase).clamp(0, 1)
