"""Worley's cellular noise on a jittered grid: the distances to the nearest and second nearest feature points (F1,
F2), their difference (F2 - F1: thin borders between cells, i.e. cracks, mortar, veins of crackle) and a random
value of the nearest cell (a stone's own shade, a facet's colour). Coordinates in cell units."""
from __future__ import annotations

from dataclasses import dataclass

import torch

from .noise import random01


@dataclass
class Cells:
    f1: torch.Tensor       # distance to the nearest point, in cell units (about 0..1)
    f2: torch.Tensor       # to the second nearest
    cell_id: torch.Tensor  # 0..1, constant over the nearest point's cell
    to_centre_x: torch.Tensor  # from the nearest point to here (a stone's shading, a scale's direction)
    to_centre_y: torch.Tensor

    @property
    def edge(self) -> torch.Tensor:
        return self.f2 - self.f1


def worley(x: torch.Tensor, y: torch.Tensor, seed: int = 0, jitter: float = 0.9, stretch_y: float = 1.0) -> Cells:
    """F1/F2 of the points of the cells around (x, y). `jitter` 0 puts each point at its cell's centre (a grid),
    1 anywhere in it; `stretch_y` > 1 squashes the cells vertically (strata, planks)."""
    cx, cy = torch.floor(x), torch.floor(y)
    ix, iy = cx.long(), cy.long()
    best = [None, None]
    best_id = best_dx = best_dy = None
    for oy in (-1, 0, 1):
        for ox in (-1, 0, 1):
            jx, jy = ix + ox, iy + oy
            px = cx + ox + 0.5 + jitter * (random01(jx, jy, seed, 0) - 0.5)
            py = cy + oy + 0.5 + jitter * (random01(jx, jy, seed, 1) - 0.5)
            dx, dy = x - px, (y - py) * stretch_y
            d = torch.sqrt(dx * dx + dy * dy + 1e-9)
            rid = random01(jx, jy, seed, 2)
            if best[0] is None:
                best = [d, torch.full_like(d, 9.0)]
                best_id, best_dx, best_dy = rid, dx, dy
                continue
            nearer = d < best[0]
            best[1] = torch.where(nearer, best[0], torch.minimum(best[1], d))
            best[0] = torch.where(nearer, d, best[0])
            best_id = torch.where(nearer, rid, best_id)
            best_dx, best_dy = torch.where(nearer, dx, best_dx), torch.where(nearer, dy, best_dy)
    return Cells(best[0], best[1], best_id, best_dx, best_dy)
