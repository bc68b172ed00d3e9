"""`python -m tools.bench.look_sheet OUT.png`: every look of the library on the sheet surfaces (for
writing and checking the catalog's descriptions)."""
from __future__ import annotations

import sys

import torch

from ...lapig_core.common.imageio import write_png
from ...lapig_core.common.sheets import labelled_grid
from ...lapig_core.lgst.looks import LOOKS, palette_stage
from .test_images import sheet_surfaces


def look_images(size: int = 256):
    images, labels = [], []
    for sname, img in sheet_surfaces(size).items():
        x = torch.from_numpy(img).permute(2, 0, 1)[None].float()
        images.append(img); labels.append(f"{sname}: input")
        for look in LOOKS:
            with torch.no_grad():
                y = look.make(None)(x, x)
            images.append(y[0].permute(1, 2, 0).numpy()); labels.append(look.name)
        for name, cs in (("deep blue + gold", [(0.0, 0.0, 0.7), (1.0, 0.84, 0.0)]),
                         ("sepia", [(0.44, 0.26, 0.08)])):
            with torch.no_grad():
                y = palette_stage(cs)(x, x)
            images.append(y[0].permute(1, 2, 0).numpy()); labels.append(f"palette: {name}")
    return images, labels


def main(path: str) -> None:
    images, labels = look_images()
    write_png(path, labelled_grid(images, labels, columns=8, cell=200, title="LAPIG looks"))


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "out/looks/looks_sheet.png")
