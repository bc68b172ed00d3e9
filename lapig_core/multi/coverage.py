# SPDX-License-Identifier: GPL-3.0-or-later
"""How much of the object the projectors reach, all together and each one (the panel's list)."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from .camera_map import CameraMap


@dataclass
class Coverage:
    """Shares of the camera-visible object: reached by some projector, by each, by two or more."""

    object_pixels: int
    reached: float
    per_projector: tuple[float, ...]
    overlap: float

    def lines(self, names: Sequence[str] | None = None) -> list[str]:
        names = names or [f"Projector {k + 1}" for k in range(len(self.per_projector))]
        out = [f"All projectors: {100 * self.reached:.0f}% of the object ({100 * self.overlap:.0f}% by two or more)"]
        out += [f"{name}: {100 * share:.0f}%" for name, share in zip(names, self.per_projector)]
        return out


def coverage(maps: Sequence[CameraMap], object_mask: np.ndarray) -> Coverage:
    """Shares of `object_mask` (H,W bool: the object as the camera sees it) each projector's reach covers."""
    obj = np.asarray(object_mask, bool)
    n = int(obj.sum())
    if n == 0:
        raise ValueError("the object mask is empty: the camera sees no object")
    reached = np.stack([np.asarray(m.valid, bool) & obj for m in maps])
    count = reached.sum(axis=0)
    return Coverage(n, float((count >= 1).sum() / n), tuple(float(r.sum() / n) for r in reached),
                    float((count >= 2).sum() / n))
