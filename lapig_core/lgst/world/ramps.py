"""Colour ramps: a scalar field 0..1 to colour through evenly spaced stops (Blender's Color Ramp, linear), and the
blackbody ramp (temperature in kelvin to the colour of a glowing body, as Blender's Blackbody node) for fire,
embers, lava and glow."""
from __future__ import annotations

import math

import torch


def ramp(t: torch.Tensor, colours: torch.Tensor) -> torch.Tensor:
    """t (H, W) in 0..1 -> (3, H, W): linear between the n stops of colours (n, 3), evenly spaced.
    Differentiable in t and in the colours (PSA moves the stops)."""
    n = colours.shape[0]
    if n == 1:
        return colours[0].view(3, 1, 1).expand(3, *t.shape)
    pos = t.clamp(0, 1) * (n - 1)
    lo = torch.floor(pos).clamp(0, n - 2)
    f = (pos - lo).unsqueeze(0)
    lo = lo.long()
    a = colours[lo].permute(2, 0, 1)
    b = colours[lo + 1].permute(2, 0, 1)
    return a + f * (b - a)


def kelvin_rgb(kelvin: float) -> tuple[float, float, float]:
    """The colour of a black body at `kelvin` (Tanner Helland's fit of the CIE data), normalised, 0..1."""
    t = max(1000.0, min(40000.0, kelvin)) / 100.0
    r = 255.0 if t <= 66 else 329.698727446 * (t - 60) ** -0.1332047592
    g = 99.4708025861 * math.log(t) - 161.1195681661 if t <= 66 else 288.1221695283 * (t - 60) ** -0.0755148492
    b = 255.0 if t >= 66 else (0.0 if t <= 19 else 138.5177312231 * math.log(t - 10) - 305.0447927307)
    return tuple(min(255.0, max(0.0, c)) / 255.0 for c in (r, g, b))


def blackbody_colours(low_k: float = 900.0, high_k: float = 3800.0, stops: int = 6) -> list:
    """Stops from dark red heat to yellow-white, each dimmed by how much a body that hot glows (so the cool end is
    near black, as embers are): the ramp fire is drawn with."""
    out = []
    for i in range(stops):
        k = low_k + (high_k - low_k) * i / (stops - 1)
        glow = (i / (stops - 1)) ** 1.4 * 0.95 + 0.05 * (i > 0)
        out.append(tuple(c * glow for c in kelvin_rgb(k)))
    return out
