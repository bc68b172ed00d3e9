"""Flat colour with fine outlines (miniatures, children's books, paper cut-outs) and crafts (pixel art,
glazed tiles, blueprint, batik, woven thread) for the art lexicon (issue 30).

As in painterly.py, the palette (dark to light) and every strength are parameters; patterns are fixed
in shares of the image.
"""
from __future__ import annotations

import colorsys

import torch

from .graphic import ink_lines
from .ops import blur, cell_average, equalised_luminance, fixed_noise, luminance, px, ramp, saturate
from .patterns import coords, palette_inks, sorted_palette, tile_coords, veins
from .stage import Stage, tensor

INK_SCALES = {"colours": 0.2, "sharpness": 4.0, "hue_weight": 0.2, "detail": 0.15}

INDIAN = ((0.89, 0.26, 0.2), (0.96, 0.77, 0.19), (0.31, 0.78, 0.47), (0.15, 0.38, 0.61), (1.0, 0.84, 0.0),
          (1.0, 0.99, 0.82))
STORYBOOK = ((1.0, 0.8, 0.64), (0.53, 0.81, 0.92), (0.61, 0.69, 0.53), (1.0, 0.87, 0.0), (1.0, 0.5, 0.31),
             (1.0, 0.99, 0.82))
CUTOUTS = ((0.25, 0.0, 1.0), (0.89, 0.26, 0.2), (1.0, 0.87, 0.0), (0.31, 0.78, 0.47), (0.05, 0.05, 0.05),
           (1.0, 1.0, 1.0))
PIXELS = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.5), (0.86, 0.08, 0.24), (1.0, 0.65, 0.0), (1.0, 0.87, 0.0),
          (0.2, 0.8, 0.2), (0.53, 0.81, 0.92), (1.0, 1.0, 1.0))
AZULEJO = ((0.0, 0.0, 0.5), (0.0, 0.28, 0.67), (0.53, 0.81, 0.92), (1.0, 1.0, 1.0))
BLUEPRINT = ((0.0, 0.19, 0.33), (1.0, 1.0, 1.0))
BATIK = ((0.29, 0.0, 0.51), (0.25, 0.16, 0.08), (0.44, 0.26, 0.08), (0.72, 0.25, 0.05), (1.0, 0.99, 0.82))
TAPESTRY = ((0.0, 0.0, 0.5), (0.86, 0.08, 0.24), (0.8, 0.47, 0.13), (0.61, 0.69, 0.53), (1.0, 0.99, 0.82))


def _palette(colours, default):
    return tensor(sorted_palette(colours, default))


# -- flat colour with fine outlines ---------------------------------------------------------------------
def _flat(x, p, simplify, wobble=0.0):
    h, w = x.shape[-2:]
    smooth = blur(x, px(x, simplify))
    tone = equalised_luminance(smooth)
    if wobble:
        tone = (tone + wobble * fixed_noise(h, w, seed=111, share=0.02, device=x.device)).clamp(0, 1)
    cs = p["colours"].clamp(0, 1)
    flat = palette_inks(saturate(smooth, 1.3).clamp(0, 1), tone, cs, p["sharpness"], p["hue_weight"])
    d = p["detail"].clamp(0, 1)
    return flat * (1 - d) + d * smooth


def _border(x, p):
    """A painted border: a band of the border colour between two fine rules, with a row of dots."""
    h, w = x.shape[-2:]
    ys, xs = coords(h, w, x.device)
    hh, ww = h / max(h, w), w / max(h, w)
    inset = torch.minimum(torch.minimum(ys, hh - ys), torch.minimum(xs, ww - xs))  # distance to the edge
    width = p["border"].clamp(0.0, 0.15)
    band = torch.sigmoid((width - inset) / 0.002)
    rule = torch.sigmoid((0.0025 - (inset - width).abs()) / 0.001) + torch.sigmoid((0.002 - (inset - width * 0.35).abs()) / 0.001)
    along = torch.where((ys - hh / 2).abs() / hh > (xs - ww / 2).abs() / ww, xs, ys)
    dots = torch.sigmoid((0.28 - torch.sqrt(((along / 0.025) % 1 - 0.5) ** 2 + ((inset - width * 0.67) / 0.025) ** 2)) / 0.05)
    return band.view(1, 1, h, w), rule.clamp(0, 1).view(1, 1, h, w), (dots * band).view(1, 1, h, w)


def flat_outline(x, p, surface=None, simplify=0.005, line_share=0.005, border=False, wobble=0.0, grain=0.0):
    h, w = x.shape[-2:]
    out = _flat(x, p, simplify, wobble)
    if grain:  # a gentle unevenness of the paint (gouache, watercolour)
        out = out * (1 + grain * fixed_noise(h, w, seed=112, share=0.03, device=x.device))
    if "line" in p:
        lines = ink_lines(x, p["threshold"], tensor(0.1).to(x.device), line_share) * p["line"].clamp(0, 1)
        out = out * (1 - lines) + p["outline"].clamp(0, 1).view(1, 3, 1, 1) * lines
    if border:
        band, rule, dots = _border(x, p)
        frame = p["frame"].clamp(0, 1).view(1, 3, 1, 1)
        out = out * (1 - band) + frame * band
        out = out * (1 - dots) + p["colours"][-1].clamp(0, 1).view(1, 3, 1, 1) * dots
        out = out * (1 - rule) + p["outline"].clamp(0, 1).view(1, 3, 1, 1) * rule
    return out


def miniature(x, p, surface=None):
    return flat_outline(x, p, simplify=0.004, line_share=0.004, border=True)


def storybook(x, p, surface=None):
    return flat_outline(x, p, simplify=0.007, line_share=0.006, grain=0.05)


def paper_cutouts(x, p, surface=None):
    return flat_outline(x, p, simplify=0.02, wobble=0.05)


def _frame_colour(cs):
    """The border of a miniature: the palette's gold if it has one, else its darkest colour."""
    def goldness(c):
        hh, ll, ss = colorsys.rgb_to_hls(*c)
        return abs(hh * 360 - 48) / 60 + (1 - ss) + abs(ll - 0.5)
    best = min(cs, key=goldness)
    return best if goldness(best) < 1.2 else cs[0]


def miniature_stage(colours=None) -> Stage:
    cs = sorted_palette(colours, INDIAN)
    return Stage("miniature", "medium", miniature,
                 {"colours": tensor(cs), "sharpness": tensor(9.0), "hue_weight": tensor(0.45), "detail": tensor(0.1),
                  "line": tensor(0.9), "threshold": tensor(0.55), "outline": tensor((0.12, 0.08, 0.06)),
                  "border": tensor(0.055), "frame": tensor(_frame_colour(cs))},
                 {**INK_SCALES, "line": 0.2, "threshold": 0.1, "outline": 0.15, "border": 0.02, "frame": 0.2},
                 note="named colours" if colours else "vermilion, saffron, emerald, lapis, gold")


def storybook_stage(colours=None) -> Stage:
    return Stage("storybook", "medium", storybook,
                 {"colours": tensor(sorted_palette(colours, STORYBOOK)), "sharpness": tensor(6.0),
                  "hue_weight": tensor(0.7), "detail": tensor(0.15), "line": tensor(0.75),
                  "threshold": tensor(0.6), "outline": tensor((0.3, 0.22, 0.18))},
                 {**INK_SCALES, "line": 0.2, "threshold": 0.1, "outline": 0.15},
                 note="named colours" if colours else "peach, sky blue, sage, yellow, coral")


def paper_cutouts_stage(colours=None) -> Stage:
    return Stage("paper_cutouts", "medium", paper_cutouts,
                 {"colours": tensor(sorted_palette(colours, CUTOUTS)), "sharpness": tensor(14.0),
                  "hue_weight": tensor(0.7), "detail": tensor(0.0)},
                 dict(INK_SCALES), note="named colours" if colours else "ultramarine, red, yellow, green on white")


# -- pixel art -------------------------------------------------------------------------------------------------
PIXEL = 0.022


def pixel_art(x, p, surface=None):
    """Big square pixels, each one colour of a small palette (by its tone and its own colour), with
    a dark outline where the image has an edge."""
    cell = px(x, PIXEL, 2.0)
    mean = cell_average(x, cell)
    tone = equalised_luminance(mean)
    cs = p["colours"].clamp(0, 1)
    ink = palette_inks(saturate(mean, 1.5).clamp(0, 1), tone, cs, p["sharpness"], p["hue_weight"])
    edges = cell_average(ink_lines(x, p["threshold"], tensor(0.1).to(x.device), 0.01), cell)
    outline = torch.sigmoid((edges - 0.35) * 14) * p["outline"].clamp(0, 1)
    return ink * (1 - outline) + cs[0].view(1, 3, 1, 1) * outline


def pixel_art_stage(colours=None) -> Stage:
    return Stage("pixel_art", "medium", pixel_art,
                 {"colours": tensor(sorted_palette(colours, PIXELS)), "sharpness": tensor(16.0),
                  "hue_weight": tensor(0.6), "threshold": tensor(0.6), "outline": tensor(0.8)},
                 {"colours": 0.2, "sharpness": 5.0, "hue_weight": 0.2, "threshold": 0.1, "outline": 0.2},
                 note="named colours" if colours else "a 1980s 8-colour palette")


# -- glazed tiles (azulejo, Delft, porcelain) --------------------------------------------------------------
TILE = 0.1


def glazed_tiles(x, p, surface=None):
    """Square glazed tiles: the image painted in the palette's blues on white (dark to light), a
    quatrefoil ornament in each tile, light grout and a glossy sheen."""
    h, w = x.shape[-2:]
    smooth = blur(x, px(x, 0.004))
    tone = equalised_luminance(smooth)
    cs = p["colours"].clamp(0, 1)
    painted = ramp(tone.clamp(0, 1) ** p["gamma"].clamp(0.3, 3.0), cs)
    fy, fx, _, _ = tile_coords(h, w, TILE, x.device)
    r = torch.sqrt(fy ** 2 + fx ** 2)
    lobes = torch.sqrt((fy.abs() - 0.25) ** 2 + (fx.abs() - 0.25) ** 2)
    orn = (torch.sigmoid((0.02 - (r - 0.16).abs()) / 0.008) + torch.sigmoid((0.018 - (lobes - 0.12).abs()) / 0.008)
           ).clamp(0, 1).view(1, 1, h, w)
    light_area = torch.sigmoid((tone - 0.45) * 10)
    o = (p["ornament"].clamp(0, 1) * orn * light_area)
    out = painted * (1 - o) + cs[1 if cs.shape[0] > 2 else 0].view(1, 3, 1, 1) * o
    grout = torch.sigmoid((torch.maximum(fy.abs(), fx.abs()) - 0.47) / 0.008).view(1, 1, h, w)
    sheen = torch.relu(fixed_noise(h, w, seed=121, share=0.15, device=x.device)) * p["sheen"]
    out = out + sheen
    return out * (1 - grout) + p["grout"].view(1, 3, 1, 1) * grout


def glazed_tiles_stage(colours=None) -> Stage:
    return Stage("glazed_tiles", "medium", glazed_tiles,
                 {"colours": tensor(sorted_palette(colours, AZULEJO)), "gamma": tensor(0.9),
                  "ornament": tensor(0.8), "sheen": tensor(0.08), "grout": tensor((0.86, 0.85, 0.82))},
                 {"colours": 0.2, "gamma": 0.25, "ornament": 0.2, "sheen": 0.05, "grout": 0.15},
                 note="named colours" if colours else "cobalt on white")


# -- blueprint -------------------------------------------------------------------------------------------------
def blueprint(x, p, surface=None):
    """White lines traced along the image's edges on Prussian-blue paper, with a faint grid."""
    h, w = x.shape[-2:]
    ys, xs = coords(h, w, x.device)
    cs = p["colours"].clamp(0, 1)
    paper, ink = cs[0].view(1, 3, 1, 1), cs[-1].view(1, 3, 1, 1)
    lum = luminance(blur(x, px(x, 0.01)))
    ground = paper * (1 + p["detail"] * (lum - lum.mean()) + 0.03 * fixed_noise(h, w, seed=131, share=0.02, device=x.device))
    minor = torch.sigmoid((0.0012 - ((ys / 0.025 + 0.5) % 1 - 0.5).abs() * 0.025) / 0.0006) + \
        torch.sigmoid((0.0012 - ((xs / 0.025 + 0.5) % 1 - 0.5).abs() * 0.025) / 0.0006)
    grid = (minor.clamp(0, 1) * p["grid"]).view(1, 1, h, w)
    lines = ink_lines(x, p["threshold"], tensor(0.1).to(x.device), 0.005)
    out = ground * (1 - grid) + ink * grid
    return out * (1 - lines) + ink * lines


def blueprint_stage(colours=None) -> Stage:
    cs = sorted_palette(colours, BLUEPRINT)
    if len(cs) > 2:
        cs = [cs[0], cs[-1]]
    return Stage("blueprint", "medium", blueprint,
                 {"colours": tensor(cs), "threshold": tensor(0.55), "grid": tensor(0.25), "detail": tensor(0.2)},
                 {"colours": 0.2, "threshold": 0.1, "grid": 0.1, "detail": 0.15},
                 note="named colours" if colours else "white on Prussian blue")


# -- batik (wax resist) ---------------------------------------------------------------------------------------
def wax_resist(x, p, surface=None):
    """Flat dyes in the palette with fine crackle veins of the darkest dye where the wax broke."""
    h, w = x.shape[-2:]
    flat = _flat(x, p, 0.006)
    crackle = torch.maximum(veins(h, w, seed=141, share=0.03, width=0.0015, device=x.device),
                            veins(h, w, seed=142, share=0.07, width=0.002, device=x.device))
    light = luminance(flat).clamp(0, 1)
    c = p["crackle"].clamp(0, 1) * crackle * (0.4 + 0.6 * light)
    dyed = flat * (1 + 0.07 * fixed_noise(h, w, seed=143, share=0.04, device=x.device))
    return dyed * (1 - c) + p["colours"][0].clamp(0, 1).view(1, 3, 1, 1) * c


def wax_resist_stage(colours=None) -> Stage:
    return Stage("wax_resist", "medium", wax_resist,
                 {"colours": tensor(sorted_palette(colours, BATIK)), "sharpness": tensor(10.0),
                  "hue_weight": tensor(0.3), "detail": tensor(0.05), "crackle": tensor(0.7)},
                 {**INK_SCALES, "crackle": 0.2}, note="named colours" if colours else "indigo and soga brown on cream")


# -- woven threads (tapestry, cross-stitch, kente, carpets) -------------------------------------------------
STITCH = 0.011


def woven_threads(x, p, surface=None):
    """The image as rows of stitches of coloured thread: each stitch one palette colour, rounded by
    shading across the thread, alternate rows offset like a weave."""
    h, w = x.shape[-2:]
    cell = px(x, STITCH, 2.0)
    mean = cell_average(blur(x, px(x, 0.004)), cell)
    tone = equalised_luminance(mean)
    cs = p["colours"].clamp(0, 1)
    thread = palette_inks(saturate(mean, 1.3).clamp(0, 1), tone, cs, p["sharpness"], p["hue_weight"])
    fy, fx, ty, _ = tile_coords(h, w, STITCH, x.device)
    shift = (ty % 2).float() * 0.5
    fxs = (fx + shift + 0.5) % 1 - 0.5
    shade = 1 - p["depth"].clamp(0, 0.6) * (4 * fxs ** 2 + 0.6 * (2 * fy.abs()) ** 3)
    return thread * shade.view(1, 1, h, w)


def woven_threads_stage(colours=None) -> Stage:
    return Stage("woven_threads", "medium", woven_threads,
                 {"colours": tensor(sorted_palette(colours, TAPESTRY)), "sharpness": tensor(9.0),
                  "hue_weight": tensor(0.4), "depth": tensor(0.3)},
                 {"colours": 0.2, "sharpness": 4.0, "hue_weight": 0.2, "depth": 0.1},
                 note="named colours" if colours else "madder red, indigo, weld yellow, green")
