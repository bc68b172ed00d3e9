"""Graphic media: posterise, line art, comic outlines, woodblock, halftone, mosaic.

All are differentiable in their parameters and in the image under them: steps are sigmoids, edges
are Sobel magnitudes of a blurred luminance, cells are means per cell.
"""
from __future__ import annotations

import torch

from .ops import (blur, cell_average, cell_grid, fixed_noise, luminance, normalised_edges, px, saturate,
                  soft_steps)
from .palette import flat_bands, ramp_colours
from .stage import Stage, tensor

# -- posterise --------------------------------------------------------------------------------------
POSTER_LEVELS = 3


def posterise(x, p, surface=None):
    smooth = blur(x, px(x, 0.004))
    return saturate(soft_steps(smooth.clamp(0, 1), POSTER_LEVELS, p["sharpness"]), p["saturation"])


def posterise_stage() -> Stage:
    return Stage("posterise", "medium", posterise, {"sharpness": tensor(10.0), "saturation": tensor(1.4)},
                 {"sharpness": 4.0, "saturation": 0.3}, note=f"{POSTER_LEVELS} levels per channel")


# -- lines ------------------------------------------------------------------------------------------
def ink_lines(x, threshold, softness, sigma_share=0.006):
    edges = normalised_edges(x, px(x, sigma_share))
    return torch.sigmoid((edges - threshold) / softness.clamp_min(0.02))


def line_art(x, p, surface=None):
    ink = ink_lines(x, p["threshold"], p["softness"])
    paper = p["paper"].view(1, 3, 1, 1)
    wash = p["wash"].clamp(0, 1)
    ground = paper * (1 - wash) + wash * paper * x  # a faint wash of the image's colour on the paper
    return ground * (1 - ink) + p["ink"].view(1, 3, 1, 1) * ink


def line_art_stage(colours=None) -> Stage:
    ink = colours[0] if colours else (0.08, 0.07, 0.07)
    return Stage("line_art", "medium", line_art,
                 {"threshold": tensor(0.6), "softness": tensor(0.12), "ink": tensor(ink),
                  "paper": tensor((0.97, 0.95, 0.9)), "wash": tensor(0.18)},
                 {"threshold": 0.1, "softness": 0.05, "ink": 0.2, "paper": 0.2, "wash": 0.2})


def comic(x, p, surface=None):
    flat = saturate(soft_steps(blur(x, px(x, 0.005)).clamp(0, 1), 3, p["sharpness"]), p["saturation"])
    ink = ink_lines(x, p["threshold"], tensor(0.08).to(x.device), sigma_share=0.008)
    return flat * (1 - ink) + 0.05 * ink


def comic_stage() -> Stage:
    return Stage("comic_outlines", "medium", comic,
                 {"sharpness": tensor(9.0), "saturation": tensor(1.45), "threshold": tensor(0.6)},
                 {"sharpness": 4.0, "saturation": 0.3, "threshold": 0.1})


# -- woodblock ------------------------------------------------------------------------------------------
# ukiyo-e inks: key-block black, Prussian blue, pale sky blue, vermilion, ochre, sage green, paper
UKIYOE = ((0.1, 0.09, 0.1), (0.12, 0.22, 0.4), (0.55, 0.7, 0.78), (0.78, 0.26, 0.18), (0.86, 0.64, 0.3),
          (0.45, 0.55, 0.36), (0.94, 0.9, 0.8))


def nearest_inks(x, p):
    """Each pixel painted the ink nearest its colour (softly: a softmax over colour distances)."""
    smooth = saturate(blur(x, px(x, 0.006)), 1.3).clamp(0, 1)
    cs = p["colours"].clamp(0, 1)
    d = ((smooth.unsqueeze(1) - cs.view(1, -1, 3, 1, 1)) ** 2).sum(2)  # (1,K,H,W)
    w = torch.softmax(-d * p["sharpness"] * 4, dim=1)
    return torch.einsum("bkhw,kc->bchw", w, cs)


def _woodblock(x, p, flat):
    ink = ink_lines(x, p["threshold"], tensor(0.1).to(x.device), sigma_share=0.007)
    h, w = x.shape[-2:]
    # wood grain: long streaks along x, printed as slightly uneven ink
    grain = fixed_noise(h, max(2, w // 8), seed=11, share=0.01, device=x.device)
    grain = torch.nn.functional.interpolate(grain, size=(h, w), mode="bilinear", align_corners=True)
    out = flat * (1 + p["grain"] * grain)
    return out * (1 - ink) + p["colours"][0].clamp(0, 1).view(1, 3, 1, 1) * ink


def woodblock(x, p, surface=None):
    return _woodblock(x, p, nearest_inks(x, p))


def woodblock_by_tone(x, p, surface=None):
    return _woodblock(x, p, flat_bands(x, p))


def woodblock_stage(colours=None) -> Stage:
    params = {"sharpness": tensor(14.0), "detail": tensor(0.12), "threshold": tensor(0.6), "grain": tensor(0.07)}
    if colours:
        # named inks: cut by tone, so every named colour is printed (nearest-colour could skip some)
        inks = ramp_colours(list(colours) + [(0.94, 0.9, 0.8)])  # the paper shows as the lightest ink
        params["colours"], fn = tensor(inks), woodblock_by_tone
        note = f"{len(colours)} named colour(s) + paper"
    else:
        params["colours"], fn, note = tensor(UKIYOE), woodblock, "ukiyo-e inks"
    return Stage("woodblock", "medium", fn, params,
                 {"colours": 0.2, "sharpness": 5.0, "detail": 0.2, "threshold": 0.1, "grain": 0.05}, note=note)


# -- halftone -------------------------------------------------------------------------------------------
HALFTONE_CELL = 0.03  # of the longer side


def halftone(x, p, surface=None):
    cell = px(x, HALFTONE_CELL, 3.0)
    h, w = x.shape[-2:]
    mean = cell_average(x, cell)
    dark = (1 - luminance(mean)).clamp(0, 1)
    dist, *_ = cell_grid(h, w, cell, device=x.device)
    radius = 0.75 * torch.sqrt(dark * p["dot_gain"].clamp(0.2, 3.0) + 1e-6)  # in cells; 0.71 fills a cell
    cover = torch.sigmoid((radius - dist.view(1, 1, h, w)) / (p["softness"].clamp_min(0.01)))
    ink = saturate(mean, p["saturation"]) * p["ink_depth"].clamp(0, 1.5)
    if "ink" in p:
        ink = p["ink"].view(1, 3, 1, 1) * (0.35 + 0.65 * (1 - dark))
    return p["paper"].view(1, 3, 1, 1) * (1 - cover) + ink * cover


def halftone_stage(colours=None) -> Stage:
    params = {"dot_gain": tensor(1.0), "softness": tensor(0.06), "saturation": tensor(1.4),
              "ink_depth": tensor(0.8), "paper": tensor((0.97, 0.95, 0.9))}
    note = "dots in the image's colours"
    if colours:
        params["ink"], note = tensor(colours[0]), "dots in the first named colour"
    return Stage("halftone", "medium", halftone, params,
                 {"dot_gain": 0.3, "softness": 0.03, "saturation": 0.3, "ink_depth": 0.2, "paper": 0.2,
                  "ink": 0.2}, note=note)


# -- mosaic ---------------------------------------------------------------------------------------------
MOSAIC_CELL = 0.03


def mosaic(x, p, surface=None):
    cell = px(x, MOSAIC_CELL, 3.0)
    h, w = x.shape[-2:]
    tiles = cell_average(x, cell)
    # every tessera a slightly different shade: a fixed per-cell jitter
    _, iy, ix, fy, fx = cell_grid(h, w, cell, device=x.device)
    g = torch.Generator().manual_seed(5)
    jitter = (torch.rand(int(iy.max()) + 1, int(ix.max()) + 1, generator=g).to(x.device) - 0.5)
    shade = 1 + p["jitter"] * jitter[iy.view(-1, 1), ix.view(1, -1)].view(1, 1, h, w)
    tiles = saturate(tiles, p["saturation"]) * shade
    edge = torch.maximum(fy.abs().view(-1, 1).expand(h, w), fx.abs().view(1, -1).expand(h, w))  # 0..0.5
    grout = torch.sigmoid((edge.view(1, 1, h, w) - (0.5 - p["grout_width"].clamp(0.02, 0.3))) / 0.02)
    bevel = 1 - 0.25 * (edge.view(1, 1, h, w) / 0.5) ** 4
    return (tiles * bevel) * (1 - grout) + p["grout"].view(1, 3, 1, 1) * grout


def mosaic_stage() -> Stage:
    return Stage("mosaic_tiles", "medium", mosaic,
                 {"saturation": tensor(1.3), "jitter": tensor(0.16), "grout_width": tensor(0.09),
                  "grout": tensor((0.72, 0.7, 0.66))},
                 {"saturation": 0.3, "jitter": 0.1, "grout_width": 0.05, "grout": 0.2})
