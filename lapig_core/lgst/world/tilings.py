"""Regular tilings: bricks in running bond, hexagons, checkers, an over-under weave, wooden planks, circuit
traces and overlapping scales. Each gives a joint mask (1 on the mortar, grout or gap, soft-edged), a random
value per tile and, where it helps, a shading across the tile. Coordinates in tile units (a brick's height)."""
from __future__ import annotations

import math

import torch

from .noise import random01


def _soft_band(distance: torch.Tensor, half_width: float, softness: float = 0.35) -> torch.Tensor:
    """1 within half_width of a line, falling to 0 over softness x half_width (antialiased, differentiable)."""
    edge = max(half_width * softness, 1e-3)
    return torch.sigmoid((half_width - distance) / edge * 2.5)


def bricks(x, y, seed=0, ratio=2.2, mortar=0.08) -> dict:
    """Running bond: rows of bricks `ratio` times as long as they are high, every other row shifted by half."""
    row = torch.floor(y)
    xs = x / ratio + 0.5 * (row.long() % 2).float()
    col = torch.floor(xs)
    fx, fy = xs - col, y - row
    dist = torch.minimum(torch.minimum(fx, 1 - fx) * ratio, torch.minimum(fy, 1 - fy))
    return {"joint": _soft_band(dist, mortar), "id": random01(col.long(), row.long(), seed),
            "shade": fy, "across": fx}


def hexagons(x, y, seed=0, grout=0.06) -> dict:
    """Pointy hexagons of unit width, from the nearest of two offset lattices of centres."""
    sq3 = math.sqrt(3.0)
    ax, ay = x, y / sq3
    c1x, c1y = torch.floor(ax) + 0.5, torch.floor(ay) + 0.5
    c2x, c2y = torch.floor(ax + 0.5), torch.floor(ay + 0.5)
    d1 = (ax - c1x) ** 2 + ((ay - c1y) * sq3) ** 2
    d2 = (ax - c2x) ** 2 + ((ay - c2y) * sq3) ** 2
    first = d1 < d2
    cx, cy = torch.where(first, c1x, c2x), torch.where(first, c1y, c2y)
    px, py = (ax - cx).abs(), ((ay - cy) * sq3).abs()
    # distance to the hexagon's border (flat-topped in these axes), 0 at the border, 0.5 at the centre
    inside = 0.5 - torch.maximum(px, (px * 0.5 + py * sq3 / 2))
    ids = random01((cx * 2).long(), (cy * 2).long(), seed)
    return {"joint": _soft_band(inside.clamp_min(0), grout), "id": ids, "shade": (0.5 - inside) * 2}


def checker(x, y, seed=0, grout=0.03) -> dict:
    ix, iy = torch.floor(x), torch.floor(y)
    fx, fy = x - ix, y - iy
    dist = torch.minimum(torch.minimum(fx, 1 - fx), torch.minimum(fy, 1 - fy))
    parity = ((ix.long() + iy.long()) % 2).float()
    return {"joint": _soft_band(dist, grout), "id": parity, "shade": fy,
            "jitter": random01(ix.long(), iy.long(), seed)}


def weave(x, y, seed=0, gap=0.08) -> dict:
    """Over-under strips: warp threads run vertically, weft horizontally, each crossing showing the one on top."""
    ix, iy = torch.floor(x), torch.floor(y)
    fx, fy = x - ix, y - iy
    warp_on_top = ((ix.long() + iy.long()) % 2) == 0
    along = torch.where(warp_on_top, fy, fx)  # along the strip on top: its bulge
    across = torch.where(warp_on_top, fx, fy)
    bulge = torch.sin(math.pi * along) * torch.sin(math.pi * across).clamp_min(0) ** 0.5
    dist = torch.minimum(across, 1 - across)
    return {"joint": _soft_band(dist, gap), "id": warp_on_top.float(), "shade": bulge}


def planks(x, y, seed=0, ratio=8.0, gap=0.03) -> dict:
    """Long boards side by side, each row's joints at its own offset; `along` runs the length of a board."""
    row = torch.floor(y)
    offset = random01(row.long(), row.long() * 3, seed, 3) * ratio
    xs = (x + offset) / ratio
    col = torch.floor(xs)
    fx, fy = xs - col, y - row
    dist = torch.minimum(torch.minimum(fx, 1 - fx) * ratio, torch.minimum(fy, 1 - fy))
    return {"joint": _soft_band(dist, gap), "id": random01(col.long(), row.long(), seed), "along": xs, "across": fy}


def circuit(x, y, seed=0, width=0.12) -> dict:
    """Traces on a grid: every cell carries a horizontal or vertical segment (some both, some none), joined at the
    cell corners, with round pads where a trace ends; `joint` is 1 on copper."""
    ix, iy = torch.floor(x), torch.floor(y)
    fx, fy = x - ix - 0.5, y - iy - 0.5
    r0 = random01(ix.long(), iy.long(), seed, 0)
    r1 = random01(ix.long(), iy.long(), seed, 1)
    horizontal = _soft_band(fy.abs(), width) * (r0 < 0.55).float()
    vertical = _soft_band(fx.abs(), width) * (r1 < 0.45).float()
    pad = _soft_band(torch.sqrt(fx * fx + fy * fy), width * 2.2) * ((r0 > 0.8) | (r1 > 0.85)).float()
    copper = torch.maximum(torch.maximum(horizontal, vertical), pad)
    return {"joint": copper, "id": r0, "pad": pad}


def scales(x, y, seed=0, overlap=0.55) -> dict:
    """Overlapping round scales in offset rows (fish, snake, roof tiles): each pixel belongs to the scale of the
    lowest row whose disc covers it; `shade` is the distance from the scale's centre (0 centre, 1 rim)."""
    best_d = best_id = None
    for k in (0, 1, 2):
        row = torch.floor(y) - k
        xs = x + 0.5 * (row.long() % 2).float()
        col = torch.floor(xs) + 0.5
        dx, dy = xs - col, (y - row) / (1 + overlap)
        d = torch.sqrt(dx * dx + dy * dy + 1e-9) / 0.72
        rid = random01(col.long(), row.long(), seed)
        covers = d < 1.0
        if best_d is None:
            best_d, best_id = torch.where(covers, d, torch.ones_like(d)), rid
        else:
            take = covers & (best_d >= 1.0)
            best_d, best_id = torch.where(take, d, best_d), torch.where(take, rid, best_id)
    return {"joint": _soft_band((1.0 - best_d).clamp_min(0), 0.08), "id": best_id, "shade": best_d.clamp(0, 1)}
