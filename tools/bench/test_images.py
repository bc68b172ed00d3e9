"""Images the look and prompt sheets are made on: a drawn scene (sky, sun, house, tree, ground: shapes,
edges, flat and graded areas) and the procedural surfaces of lapig_core.common.surfaces."""
from __future__ import annotations

import numpy as np

from ...lapig_core.common.surfaces import make_surface


def drawn_scene(size: int = 256) -> np.ndarray:
    y, x = np.mgrid[0:size, 0:size].astype(np.float32) / size
    img = np.zeros((size, size, 3), np.float32)
    sky = np.stack([0.45 + 0.3 * y, 0.65 + 0.2 * y, 0.95 - 0.1 * y], -1)
    ground = np.stack([0.3 + 0.1 * x, 0.55 - 0.1 * y, 0.2 + 0 * x], -1)
    img[:] = np.where((y < 0.65)[..., None], sky, ground)
    sun = (x - 0.8) ** 2 + (y - 0.2) ** 2 < 0.09 ** 2
    img[sun] = (1.0, 0.88, 0.3)
    cloud = ((x - 0.3) ** 2 / 0.04 + (y - 0.18) ** 2 / 0.004) < 1
    img[cloud] = (0.97, 0.97, 0.98)
    house = (x > 0.18) & (x < 0.48) & (y > 0.42) & (y < 0.7)
    img[house] = (0.85, 0.78, 0.62)
    roof = (y > 0.28) & (y <= 0.42) & (np.abs(x - 0.33) < (y - 0.28) * 1.1)
    img[roof] = (0.65, 0.15, 0.12)
    door = (x > 0.3) & (x < 0.36) & (y > 0.56) & (y < 0.7)
    img[door] = (0.35, 0.2, 0.1)
    window = (x > 0.22) & (x < 0.27) & (y > 0.47) & (y < 0.53)
    img[window] = (0.3, 0.5, 0.8)
    trunk = (x > 0.68) & (x < 0.72) & (y > 0.5) & (y < 0.72)
    img[trunk] = (0.4, 0.25, 0.12)
    crown = (x - 0.7) ** 2 + (y - 0.45) ** 2 < 0.1 ** 2
    img[crown] = (0.15, 0.5, 0.2)
    return img


def sheet_surfaces(size: int = 256) -> dict[str, np.ndarray]:
    return {"scene": drawn_scene(size), "sakura": make_surface("sakura", size=size, seed=7)}
