"""Gradient noise (Perlin's improved noise in 2D, with a seeded lattice), its sums over octaves (fBm, ridged,
turbulence) and domain warping. Inputs are coordinate tensors (..., H, W) in lattice units; outputs about -1..1
(fBm) or 0..1 (ridged, turbulence). Differentiable in the coordinates."""
from __future__ import annotations

import math

import torch

TABLE = 256


def _tables(seed: int, device) -> tuple[torch.Tensor, torch.Tensor]:
    g = torch.Generator().manual_seed(int(seed) * 7919 + 17)
    perm = torch.randperm(TABLE, generator=g)
    angles = torch.rand(TABLE, generator=g) * 2 * math.pi
    grads = torch.stack([torch.cos(angles), torch.sin(angles)], -1)
    return torch.cat([perm, perm]).to(device), grads.to(device)


_CACHE: dict = {}


def tables(seed: int, device) -> tuple[torch.Tensor, torch.Tensor]:
    key = (int(seed), str(device))
    if key not in _CACHE:
        _CACHE[key] = _tables(seed, device)
    return _CACHE[key]


def hash2(ix: torch.Tensor, iy: torch.Tensor, seed: int) -> torch.Tensor:
    """An integer hash 0..255 of integer lattice coordinates (long tensors)."""
    perm, _ = tables(seed, ix.device)
    return perm[(perm[ix & (TABLE - 1)] + iy) & (TABLE - 1)]


def random01(ix: torch.Tensor, iy: torch.Tensor, seed: int, channel: int = 0) -> torch.Tensor:
    """A value in [0, 1) per lattice cell, several independent ones by channel."""
    h = hash2(ix + 37 * channel, iy + 101 * channel, seed + channel)
    return (hash2(h, ix * 3 + iy, seed + 13).float() + 0.5) / TABLE


def _fade(t: torch.Tensor) -> torch.Tensor:
    return t * t * t * (t * (t * 6 - 15) + 10)


def gradient_noise(x: torch.Tensor, y: torch.Tensor, seed: int = 0) -> torch.Tensor:
    """Improved Perlin noise in 2D, about -1..1 (zero at lattice points)."""
    _, grads = tables(seed, x.device)
    x0, y0 = torch.floor(x), torch.floor(y)
    fx, fy = x - x0, y - y0
    ix, iy = x0.long(), y0.long()

    def corner(dx, dy):
        g = grads[hash2(ix + dx, iy + dy, seed)]
        return g[..., 0] * (fx - dx) + g[..., 1] * (fy - dy)

    u, v = _fade(fx), _fade(fy)
    a = corner(0, 0) + u * (corner(1, 0) - corner(0, 0))
    b = corner(0, 1) + u * (corner(1, 1) - corner(0, 1))
    return (a + v * (b - a)) * 1.41


def fbm(x, y, seed=0, octaves=5, lacunarity=2.0, gain=0.5) -> torch.Tensor:
    """Fractional Brownian motion: octaves of gradient noise, each finer by `lacunarity` and weaker by `gain`;
    about -1..1 (divided by the octaves' total weight)."""
    total, amp, weight = 0.0, 1.0, 0.0
    for o in range(int(octaves)):
        # each octave shifted and turned a little, so the lattice never lines up across octaves
        c, s = math.cos(0.5 * o), math.sin(0.5 * o)
        xo, yo = c * x - s * y + 17.3 * o, s * x + c * y - 9.1 * o
        total = total + amp * gradient_noise(xo, yo, seed + o)
        weight += amp
        amp *= gain
        x, y = x * lacunarity, y * lacunarity
    return total / weight


def ridged(x, y, seed=0, octaves=5, lacunarity=2.0, gain=0.5) -> torch.Tensor:
    """Ridged multifractal: sharp crests where the noise crosses zero (veins, mountains, cracks); 0..1."""
    total, amp, weight = 0.0, 1.0, 0.0
    for o in range(int(octaves)):
        n = 1.0 - gradient_noise(x + 31.7 * o, y - 11.3 * o, seed + o).abs()
        total = total + amp * n * n
        weight += amp
        amp *= gain
        x, y = x * lacunarity, y * lacunarity
    return total / weight


def turbulence(x, y, seed=0, octaves=5, lacunarity=2.0, gain=0.5) -> torch.Tensor:
    """Perlin's turbulence: the sum of |noise| over octaves (billows of smoke, fire, clouds); 0..1."""
    total, amp, weight = 0.0, 1.0, 0.0
    for o in range(int(octaves)):
        total = total + amp * gradient_noise(x + 5.9 * o, y + 23.1 * o, seed + o).abs()
        weight += amp
        amp *= gain
        x, y = x * lacunarity, y * lacunarity
    return (total / weight * 1.6).clamp(0, 1)


def warp(x, y, seed=0, amount=1.0, octaves=4) -> tuple[torch.Tensor, torch.Tensor]:
    """Domain warping: the coordinates moved by fBm of themselves (Quilez's 'noise of noise')."""
    dx = fbm(x + 1.7, y + 9.2, seed + 101, octaves)
    dy = fbm(x + 8.3, y + 2.8, seed + 202, octaves)
    return x + amount * dx, y + amount * dy
