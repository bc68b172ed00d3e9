"""A stylization result on disk: the images the add-on previews and exports, and a JSON summary.

Folder layout (working size, projector-registered):
  target.png / target_nopsa.png          what the viewer should see, with and without PSA
  projector.png / projector_nopsa.png    the compensated projector images (working square)
  simulated.png / simulated_nopsa.png    PCNet's prediction of the capture
  rendered.png / rendered_nopsa.png      the Cycles capture of the projection (when rendered)
  compensability.png                     L_ps + L_cs per pixel over the surface, as a heat map
  comparison.png                         with and without PSA side by side
  result.json                            prompt, backend, styles, PSA settings, metrics
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ..common.imageio import atomic_write_bytes, read_image, write_png
from ..common.sheets import labelled_grid

IMAGES = ("target", "projector", "simulated", "rendered", "compensability")


def heat_overlay(surface: np.ndarray, values: np.ndarray, scale: float | None = None) -> np.ndarray:
    """Surface in gray with the problem areas in yellow-to-red on top (values (H, W) >= 0)."""
    v = np.asarray(values, np.float32)
    scale = scale or max(float(np.percentile(v, 99)), 1e-4)
    t = np.clip(v / scale, 0, 1)[..., None]
    gray = np.repeat(np.asarray(surface, np.float32).mean(-1, keepdims=True), 3, -1) * 0.6
    hot = np.concatenate([np.ones_like(t), 1 - t, np.zeros_like(t)], -1)  # yellow -> red
    alpha = np.clip(t * 1.5, 0, 0.85)
    return gray * (1 - alpha) + hot * alpha


def write_result(folder, images: dict, summary: dict) -> Path:
    """images: name -> (H, W, 3) in [0,1] (names from IMAGES, with '_nopsa' variants)."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    for name, img in images.items():
        write_png(folder / f"{name}.png", img)
    tiles = [(images.get(n), lab) for n, lab in (
        ("target_nopsa", "target without PSA"), ("simulated_nopsa", "simulated without PSA"),
        ("rendered_nopsa", "rendered without PSA"), ("target", "target with PSA"),
        ("simulated", "simulated with PSA"), ("rendered", "rendered with PSA"))]
    tiles = [(im, lab) for im, lab in tiles if im is not None]
    if tiles:
        cols = 3 if len(tiles) == 6 else 2
        write_png(folder / "comparison.png", labelled_grid([t for t, _ in tiles], [lab for _, lab in tiles],
                                                           columns=cols, cell=256, title=summary.get("prompt", "")))
    atomic_write_bytes(folder / "result.json", json.dumps(summary, indent=2, default=_json).encode("utf-8"))
    return folder


def _json(value):
    if isinstance(value, (np.floating, np.integer)):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    return str(value)


def read_summary(folder) -> dict:
    path = Path(folder) / "result.json"
    if not path.is_file():
        raise FileNotFoundError(f"no stylization result in {folder}: generate one first")
    return json.loads(path.read_text(encoding="utf-8"))


def read_result_image(folder, name: str) -> np.ndarray:
    path = Path(folder) / f"{name}.png"
    if not path.is_file():
        raise FileNotFoundError(f"the result has no '{name}' image ({path.name}): generate or render it first")
    return read_image(path)
