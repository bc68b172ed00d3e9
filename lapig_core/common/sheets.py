"""Comparison and contact sheets: labelled image grids saved as PNG for people to look at."""
from __future__ import annotations

import numpy as np


def _fit(img, cell_w, cell_h):
    import cv2

    img = np.asarray(img, np.float32)
    if img.dtype != np.float32 or img.max() > 1.0 + 1e-6:
        img = img / 255.0
    if img.ndim == 2:
        img = np.repeat(img[..., None], 3, -1)
    h, w = img.shape[:2]
    scale = min(cell_w / w, cell_h / h)
    resized = cv2.resize(img, (max(1, round(w * scale)), max(1, round(h * scale))),
                         interpolation=cv2.INTER_AREA if scale < 1 else cv2.INTER_LINEAR)
    out = np.full((cell_h, cell_w, 3), 0.12, np.float32)
    y0, x0 = (cell_h - resized.shape[0]) // 2, (cell_w - resized.shape[1]) // 2
    out[y0:y0 + resized.shape[0], x0:x0 + resized.shape[1]] = resized
    return out


def labelled_grid(images, labels=None, columns=4, cell=256, title=None) -> np.ndarray:
    """Images (any size, float [0,1] or uint8) in a grid with a caption under each.

    ``cell`` is the long side of every cell; cells take the first image's aspect ratio (a sheet
    usually shows one frame many times), others are letterboxed in them."""
    import cv2

    labels = list(labels or [""] * len(images))
    rows = (len(images) + columns - 1) // columns
    h0, w0 = np.shape(images[0])[:2] if len(images) else (1, 1)
    cell_w, cell_h = (cell, max(1, round(cell * h0 / w0))) if w0 >= h0 else (max(1, round(cell * w0 / h0)), cell)
    caption, header = 22, (30 if title else 0)
    sheet = np.full((header + rows * (cell_h + caption), columns * cell_w, 3), 1.0, np.float32)
    if title:
        cv2.putText(sheet, title, (8, 21), cv2.FONT_HERSHEY_SIMPLEX, 0.6, (0, 0, 0), 1, cv2.LINE_AA)
    for i, (img, label) in enumerate(zip(images, labels)):
        r, c = divmod(i, columns)
        y, x = header + r * (cell_h + caption), c * cell_w
        sheet[y:y + cell_h, x:x + cell_w] = _fit(img, cell_w, cell_h)
        cv2.putText(sheet, str(label)[:40], (x + 4, y + cell_h + 16), cv2.FONT_HERSHEY_SIMPLEX, 0.45,
                    (0, 0, 0), 1, cv2.LINE_AA)
    return sheet
