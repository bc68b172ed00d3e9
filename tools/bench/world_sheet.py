# SPDX-License-Identifier: GPL-3.0-or-later
"""The contact sheet of the world's materials, family by family (docs/looks-of-the-world.md shows it):
    .venv/bin/python -m lapig.tools.bench.world_sheet docs/world_materials.jpg
(run from the repository's parent with the repository importable as `lapig`, or through the test conftest)."""
from __future__ import annotations

import sys


def render_sheet(path: str, cell: int = 120) -> str:
    import cv2
    import numpy as np
    import torch

    from ...lapig_core.common.sheets import labelled_grid
    from ...lapig_core.lgst.world.catalog import FAMILIES, materials
    from ...lapig_core.lgst.world.compose import compose
    from ...lapig_core.lgst.world.stage import world_stage

    images, labels = [], []
    x = torch.zeros(1, 3, 150, 200)
    for family in FAMILIES:
        for m in [m for m in materials() if m.family == family]:
            with torch.no_grad():
                y = world_stage(compose(m.words[0]))(x, x)
            images.append(y[0].permute(1, 2, 0).numpy())
            labels.append(f"{family}: {m.words[0]}")
    grid = labelled_grid(images, labels, columns=10, cell=cell, title="LAPIG looks of the world: one prompt word "
                                                                       "per material (tools/bench/world_sheet.py)")
    img = grid if grid.dtype == np.uint8 else (np.clip(grid, 0, 1) * 255).astype(np.uint8)
    cv2.imwrite(path, cv2.cvtColor(img, cv2.COLOR_RGB2BGR), [cv2.IMWRITE_JPEG_QUALITY, 82])
    return path


if __name__ == "__main__":
    print(render_sheet(sys.argv[1] if len(sys.argv) > 1 else "docs/world_materials.jpg"))
