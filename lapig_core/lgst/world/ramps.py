"""Colour ramps: a scalar field 0..1 to colour through evenly spaced stops (Blender's Color Ramp, linear), and the
fire ramp (the temperature of flames, embers, lava and glow as they are seen) those looks are drawn with."""
from __future__ import annotations


def ramp(t: torch.Tensor, colours: torch.Tensor) -> torch.Tensor:
    """t (H, W) in 0..1 -> (3, H, W): linear between the n stops of colours (n, 3), evenly spaced.
    Differentiable in t and in the colours (PSA moves the stops)."""
    import torch  # here: the fire ramp's stops are read by the torch-free node recipe too

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


# Fire as it is seen, a light and not a surface: deep red heat, orange, yellow and a pale yellow-white core. (A black
# body's chromaticity alone, dimmed by its glow, was this ramp before: peach at 3800 K and a dim brown below, so
# flames read as smoke; flames in pictures are saturated and bright, their light overexposed towards yellow.)
FIRE_COLOURS = ((0.02, 0.0, 0.0), (0.42, 0.04, 0.0), (0.85, 0.2, 0.01), (1.0, 0.47, 0.04), (1.0, 0.74, 0.16),
                (1.0, 0.93, 0.6))


def fire_colours() -> list:
    """The ramp fire, embers, lava and glow are drawn with (the torch look and its node group alike): from near
    black (embers cooling) through red heat to the pale yellow of the hottest flame."""
    return [tuple(c) for c in FIRE_COLOURS]
