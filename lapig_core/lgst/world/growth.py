"""Reaction-diffusion (Gray-Scott), grown once per (feed, kill, seed, size) and kept: Pearson's map of the feed /
kill plane gives spots (lichen, leopard), stripes and mazes (coral, brain coral), worms. No gradient flows through
the growth (PSA moves the colours laid on it, not the chemistry)."""
from __future__ import annotations

import functools

import torch
import torch.nn.functional as F

PRESETS = {"spots": (0.0367, 0.0649), "maze": (0.029, 0.057), "coral": (0.0545, 0.062), "worms": (0.078, 0.061),
           "holes": (0.039, 0.058)}


@functools.lru_cache(maxsize=16)
def _grown(feed: float, kill: float, seed: int, size: int, steps: int) -> torch.Tensor:
    g = torch.Generator().manual_seed(seed)
    u = torch.ones(1, 1, size, size)
    v = torch.zeros(1, 1, size, size)
    seeds = (torch.rand(1, 1, size // 8, size // 8, generator=g) > 0.7).float()
    v = v + F.interpolate(seeds, size=(size, size), mode="nearest") * 0.5
    u = u - v
    lap = torch.tensor([[0.05, 0.2, 0.05], [0.2, -1.0, 0.2], [0.05, 0.2, 0.05]]).view(1, 1, 3, 3)
    with torch.no_grad():
        for _ in range(steps):
            lu = F.conv2d(F.pad(u, (1, 1, 1, 1), mode="circular"), lap)
            lv = F.conv2d(F.pad(v, (1, 1, 1, 1), mode="circular"), lap)
            uvv = u * v * v
            u = u + (1.0 * lu - uvv + feed * (1 - u))
            v = v + (0.5 * lv + uvv - (feed + kill) * v)
    v = v[0, 0]
    return ((v - v.min()) / (v.max() - v.min()).clamp_min(1e-6)).contiguous()


def reaction_diffusion(x: torch.Tensor, y: torch.Tensor, kind: str = "spots", seed: int = 0, size: int = 192,
                       steps: int = 2200) -> torch.Tensor:
    """The grown pattern (0..1, tiling) sampled at (x, y) in tile units (one tile: `size` cells)."""
    feed, kill = PRESETS[kind]
    tile = _grown(feed, kill, int(seed), int(size), int(steps)).to(x.device)
    gx = torch.remainder(x, 1.0) * 2 - 1
    gy = torch.remainder(y, 1.0) * 2 - 1
    grid = torch.stack([gx, gy], -1).reshape(1, *x.shape[-2:], 2)
    return F.grid_sample(tile[None, None], grid, mode="bilinear", padding_mode="reflection",
                         align_corners=False)[0, 0]
