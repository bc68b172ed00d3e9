"""Procedural surface textures (the paper's hard cases: dark clouds, stripes, saturated spots).

Used for the demo scene and for synthetic setups; deterministic per seed, numpy only.
"""
from __future__ import annotations

import numpy as np

# the last three are the hard surfaces of issue 13: a mostly black one with small bright features, a
# saturated red one and a high-contrast black-and-white one
SURFACE_NAMES = ("stripe", "wood", "clouds", "sakura", "spray", "bench", "black_dots", "red", "black_white")


def _smooth_noise(rng, size, scale):
    import cv2

    coarse = rng.random((max(2, size // scale), max(2, size // scale))).astype(np.float32)
    return cv2.resize(coarse, (size, size), interpolation=cv2.INTER_CUBIC)


def _fractal(rng, size, octaves=5):
    out = np.zeros((size, size), np.float32)
    amp, total = 1.0, 0.0
    for o in range(octaves):
        out += amp * _smooth_noise(rng, size, max(2, size // (4 * 2 ** o)))
        total += amp
        amp *= 0.5
    out /= total
    return (out - out.min()) / max(np.ptp(out), 1e-6)


def make_surface(name: str, size: int = 512, seed: int = 0) -> np.ndarray:
    """An RGB float32 texture in [0,1] of the named kind."""
    if name not in SURFACE_NAMES:
        raise ValueError(f"unknown surface '{name}': choose one of {', '.join(SURFACE_NAMES)}")
    rng = np.random.default_rng([seed, SURFACE_NAMES.index(name)])
    y, x = np.mgrid[0:size, 0:size].astype(np.float32) / size
    if name == "stripe":
        band = (np.sin(2 * np.pi * (x * 6 + 0.3 * y)) > 0).astype(np.float32)
        a, b = np.array([0.85, 0.2, 0.15]), np.array([0.95, 0.9, 0.75])
        img = band[..., None] * a + (1 - band[..., None]) * b
    elif name == "wood":
        n = _fractal(rng, size)
        rings = 0.5 + 0.5 * np.sin(2 * np.pi * (12 * x + 3 * n))
        img = np.stack([0.55 + 0.3 * rings, 0.35 + 0.2 * rings, 0.18 + 0.1 * rings], -1)
    elif name == "clouds":
        n = _fractal(rng, size)
        img = np.stack([0.15 + 0.8 * n, 0.15 + 0.75 * n, 0.25 + 0.7 * n], -1) ** 1.6
    elif name == "sakura":
        img = np.ones((size, size, 3), np.float32) * np.array([0.93, 0.9, 0.85])
        for _ in range(40):
            cx, cy, r = rng.random(), rng.random(), 0.02 + 0.05 * rng.random()
            d = np.hypot(x - cx, y - cy)
            petal = np.clip(1 - d / r, 0, 1)[..., None] ** 0.5
            img = img * (1 - petal) + petal * np.array([0.95, 0.45 + 0.2 * rng.random(), 0.6])
    elif name == "spray":
        img = np.ones((size, size, 3), np.float32) * 0.85
        for _ in range(12):
            cx, cy, r = rng.random(), rng.random(), 0.05 + 0.15 * rng.random()
            colour = rng.random(3) ** 2
            d = np.hypot(x - cx, y - cy)
            blob = np.exp(-(d / r) ** 2)[..., None]
            img = img * (1 - 0.9 * blob) + 0.9 * blob * colour
    elif name == "black_dots":  # near black, with a few small pale spots and thin bright scratches
        img = np.ones((size, size, 3), np.float32) * 0.03
        for _ in range(18):
            cx, cy, r = rng.random(), rng.random(), 0.01 + 0.03 * rng.random()
            spot = np.clip(1 - np.hypot(x - cx, y - cy) / r, 0, 1)[..., None] ** 0.4
            img = img * (1 - spot) + spot * (0.6 + 0.35 * rng.random(3))
        for _ in range(4):
            a, c = rng.random() * np.pi, rng.random()
            line = np.exp(-((np.cos(a) * (x - c) + np.sin(a) * (y - c)) / 0.004) ** 2)[..., None]
            img = np.maximum(img, 0.7 * line)
    elif name == "red":  # saturated red paint with darker brush marks
        n = _fractal(rng, size)
        img = np.stack([0.75 + 0.2 * n, 0.04 + 0.05 * n, 0.05 + 0.04 * n], -1)
    elif name == "black_white":  # hard black-and-white blocks and a bold diagonal band
        cells = (np.floor(x * 5) + np.floor(y * 4)) % 2
        band = (np.abs(x - y) < 0.12).astype(np.float32)
        v = np.abs(cells - band)
        img = np.repeat((0.03 + 0.92 * v)[..., None], 3, -1)
    else:  # bench: slats with grain and dark gaps
        n = _fractal(rng, size)
        slat = ((y * 7) % 1.0 > 0.12).astype(np.float32)
        base = np.stack([0.45 + 0.25 * n, 0.3 + 0.15 * n, 0.2 + 0.1 * n], -1)
        img = base * (0.15 + 0.85 * slat[..., None])
    return np.clip(img, 0, 1).astype(np.float32)
