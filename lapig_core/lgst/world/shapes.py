"""Shapes drawn as signed distance fields and scattered on a jittered grid, each with its own size, angle and
shade: leaves, flowers of petals, drops, bubbles, snowflakes, and point stars. `scatter` gives the coverage
(0..1, antialiased), the covering shape's random value, and the depth inside it (0 at its edge, 1 deep inside).
Coordinates in grid units; `density` is the share of grid cells that hold a shape."""
from __future__ import annotations

import math

import torch

from .noise import random01


def leaf(px, py):
    """A pointed leaf along x: the intersection of two discs (a vesica), about 1 long, 0.45 wide."""
    r, off = 0.62, 0.42
    d1 = torch.sqrt(px * px + (py - off) ** 2 + 1e-9) - r
    d2 = torch.sqrt(px * px + (py + off) ** 2 + 1e-9) - r
    return torch.maximum(d1, d2)


def flower(px, py, petals=5):
    """Petals round a centre: a polar rose, radius 0.5 at the petals' tips."""
    rho = torch.sqrt(px * px + py * py + 1e-9)
    theta = torch.atan2(py, px)
    edge = 0.18 + 0.32 * torch.cos(petals * theta / 2).abs() ** 0.7
    return rho - edge


def disc(px, py):
    return torch.sqrt(px * px + py * py + 1e-9) - 0.45


def drop(px, py):
    """A drop: a disc drawn out upwards into a point."""
    k = (py.clamp(-0.5, 0.5) + 0.5)  # 0 at the bottom, 1 at the top
    return torch.sqrt(px * px / (1 - 0.8 * k) ** 2 + (py + 0.1) ** 2 + 1e-9) - 0.38


def snowflake(px, py):
    """Six arms with side branches (distance to the nearest arm segment)."""
    rho = torch.sqrt(px * px + py * py + 1e-9)
    theta = torch.atan2(py, px)
    sector = torch.remainder(theta + math.pi / 6, math.pi / 3) - math.pi / 6
    ax, ay = rho * torch.cos(sector), (rho * torch.sin(sector)).abs()
    arm = torch.where(ax < 0.48, ay, torch.sqrt((ax - 0.48) ** 2 + ay * ay))
    branch_x = torch.remainder(ax, 0.16) - 0.08
    branch = ((ay - branch_x.abs() * 1.2).abs() * 0.7).where((ax > 0.12) & (ax < 0.45) & (ay < 0.14),
                                                              torch.full_like(ax, 9.0))
    return torch.minimum(arm, branch) - 0.035


def _ellipse(px, py, cx, cy, rx, ry):
    return (torch.sqrt(((px - cx) / rx) ** 2 + ((py - cy) / ry) ** 2 + 1e-9) - 1) * min(rx, ry)


def _capsule(px, py, ax, ay, bx, by, r):
    """The distance to the segment a-b, less r."""
    dx, dy = bx - ax, by - ay
    h = (((px - ax) * dx + (py - ay) * dy) / (dx * dx + dy * dy)).clamp(0, 1)
    return torch.sqrt((px - ax - h * dx) ** 2 + (py - ay - h * dy) ** 2 + 1e-9) - r


def beast(px, py):
    """A four-legged animal in profile, as the cave painters drew bison and horses: a heavy body with a hump, a
    low head, horns, legs and a tail; about 1 long, facing +x."""
    d = _ellipse(px, py, 0.0, 0.0, 0.4, 0.15)
    d = torch.minimum(d, _ellipse(px, py, 0.16, -0.08, 0.2, 0.13))   # the hump over the shoulders
    d = torch.minimum(d, _ellipse(px, py, 0.4, 0.04, 0.11, 0.08))    # the head, held low
    d = torch.minimum(d, _capsule(px, py, 0.42, -0.04, 0.5, -0.14, 0.02))  # a horn
    for x0, x1 in ((-0.26, -0.3), (-0.16, -0.12), (0.16, 0.2), (0.25, 0.24)):
        d = torch.minimum(d, _capsule(px, py, x0, 0.1, x1, 0.36, 0.035))
    return torch.minimum(d, _capsule(px, py, -0.35, -0.02, -0.45, 0.16, 0.018))  # the tail


def hand(px, py):
    """A hand with its fingers spread, fingers up (the stencils blown round a hand on the rock), about 0.8 tall."""
    d = _ellipse(px, py, 0.0, 0.12, 0.16, 0.18)
    for angle, length in ((-0.55, 0.28), (-0.2, 0.36), (0.05, 0.38), (0.3, 0.35), (0.58, 0.27)):
        tx, ty = 0.12 * math.sin(angle), 0.05 - 0.1 * math.cos(angle)
        d = torch.minimum(d, _capsule(px, py, tx, ty, tx + length * math.sin(angle), ty - length * math.cos(angle),
                                      0.045))
    return torch.minimum(d, _capsule(px, py, 0.12, 0.18, 0.32, 0.02, 0.05))  # the thumb


SHAPES = {"leaf": leaf, "flower": flower, "disc": disc, "drop": drop, "snowflake": snowflake, "beast": beast,
          "hand": hand}


def scatter(x, y, shape: str, seed=0, density=0.8, size=0.9, size_spread=0.3, turn=1.0, softness=0.04) -> dict:
    """The shape on a jittered grid of unit cells, sized `size` (x its spread) and turned by up to `turn` x pi;
    neighbours overlap, the one nearest its own centre on top."""
    sdf = SHAPES[shape]
    cx, cy = torch.floor(x), torch.floor(y)
    ix, iy = cx.long(), cy.long()
    coverage = torch.zeros_like(x)
    shape_id = torch.zeros_like(x)
    depth = torch.zeros_like(x)
    for oy in (-1, 0, 1):
        for ox in (-1, 0, 1):
            jx, jy = ix + ox, iy + oy
            present = (random01(jx, jy, seed, 4) < density).float()
            px = x - (cx + ox + 0.5 + 0.8 * (random01(jx, jy, seed, 0) - 0.5))
            py = y - (cy + oy + 0.5 + 0.8 * (random01(jx, jy, seed, 1) - 0.5))
            s = size * (1 + size_spread * (random01(jx, jy, seed, 5) - 0.5) * 2)
            a = turn * math.pi * (random01(jx, jy, seed, 6) * 2 - 1)
            ca, sa = torch.cos(a), torch.sin(a)
            lx, ly = (ca * px + sa * py) / s, (-sa * px + ca * py) / s
            d = sdf(lx, ly)
            here = torch.sigmoid(-d / softness) * present
            on_top = here > coverage
            shape_id = torch.where(on_top, random01(jx, jy, seed, 2), shape_id)
            depth = torch.where(on_top, (-d / 0.25).clamp(0, 1), depth)
            coverage = torch.maximum(coverage, here)
    return {"coverage": coverage, "id": shape_id, "depth": depth}


def stars(x, y, seed=0, density=0.15, size=0.06) -> torch.Tensor:
    """Point stars of many brightnesses on a fine grid: 0..1 light, a soft core and a faint halo."""
    cx, cy = torch.floor(x), torch.floor(y)
    ix, iy = cx.long(), cy.long()
    px = x - (cx + 0.5 + 0.8 * (random01(ix, iy, seed, 0) - 0.5))
    py = y - (cy + 0.5 + 0.8 * (random01(ix, iy, seed, 1) - 0.5))
    bright = random01(ix, iy, seed, 2) ** 3
    present = (random01(ix, iy, seed, 3) < density).float()
    r2 = (px * px + py * py) / (size * (0.5 + bright)) ** 2
    return present * (torch.exp(-r2) + 0.15 * torch.exp(-r2 / 12)) * (0.35 + 0.65 * bright)
