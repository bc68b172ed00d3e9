"""A sheet that shows what the two style-retention figures mean (issue 13): one look and its changes
(darker, tinted, desaturated, a dark surface's range imposed, blurred, scrambled), each captioned with
SSIM (the old figure) and structure retention (the new one). A high structure score should mean "the
same style"; SSIM also falls for the brightness and colour moves a surface forces."""
from __future__ import annotations

import torch

from ...lapig_core.common import metrics
from ...lapig_core.common.imageio import write_png
from ...lapig_core.common.sheets import labelled_grid
from ...lapig_core.common.surfaces import make_surface
from ...lapig_core.lgst import get_backend


def variants(look: torch.Tensor, surface: torch.Tensor) -> list[tuple[str, torch.Tensor]]:
    """(label, image) pairs of a look (1,3,H,W) changed the ways a surface does, and the ways it must not."""
    gray = look.mean(1, keepdim=True)
    g = torch.Generator().manual_seed(0)
    idx = torch.randperm(look.shape[-2] * look.shape[-1], generator=g)
    blur = torch.nn.functional.avg_pool2d(look, 9, 1, 4, count_include_pad=False)
    tint = torch.tensor([1.0, 0.45, 0.3]).view(1, 3, 1, 1)
    return [("the look", look), ("x 0.3", look * 0.3), ("tinted", look * tint),
            ("half saturation", gray + 0.5 * (look - gray)), ("x dark surface", look * surface),
            ("blurred", blur), ("scrambled", look.flatten(2)[:, :, idx].view_as(look))]


def structure_sheet(path, prompt="Make it a woodcut print", size=192) -> list[dict]:
    surface_img = make_surface("sakura", size=size, seed=3)
    surface = torch.from_numpy(surface_img).permute(2, 0, 1)[None].float()
    backend = get_backend("styletransfer")
    look = backend.stylize(surface, prompt).float()
    dark_surface = torch.from_numpy(make_surface("black_dots", size=size, seed=7)).permute(2, 0, 1)[None]
    rows, tiles, labels = [], [], []
    for label, image in variants(look, dark_surface.float()):
        image = image.clamp(0, 1)
        ssim, structure = metrics.ssim(image, look), metrics.structure_retention(image, look)
        rows.append({"variant": label, "ssim": round(ssim, 3), "structure": round(structure, 3)})
        tiles.append(image[0].permute(1, 2, 0).numpy())
        labels.append(f"{label}: {ssim:.2f} / {structure:.2f}")
    write_png(path, labelled_grid(tiles, labels, columns=4, cell=300,
                                  title=f"'{prompt}': SSIM (old) / structure retention (new)"))
    return rows


if __name__ == "__main__":  # pragma: no cover - run through the package loader (see BENCHMARKS.md)
    import sys

    print(structure_sheet(sys.argv[1] if len(sys.argv) > 1 else "out/structure_sheet.png"))
