"""Flat colour with fine outlines (miniatures, children's books, paper cut-outs) and crafts (pixel art,
glazed tiles, blueprint, batik, woven thread) for the art lexicon (issue 30).

As in painterly.py, the palette (dark to light) and every strength are parameters; patterns are fixed
in shares of the image.
"""
from __future__ import annotations

import torch

from .graphic import ink_lines
from .ops import blur, cell_average, cell_grid, fixed_noise, keep_detail, luminance, px, ramp, saturate
from .patterns import INK_SCALES, coords, goldness, palette_inks, ranked_tone, sorted_palette, tile_coords, veins
from .stage import Stage, tensor

INDIAN = ((0.89, 0.26, 0.2), (0.96, 0.77, 0.19), (0.31, 0.78, 0.47), (0.15, 0.38, 0.61), (1.0, 0.84, 0.0),
          (1.0, 0.99, 0.82))
STORYBOOK = ((1.0, 0.8, 0.64), (0.53, 0.81, 0.92), (0.61, 0.69, 0.53), (1.0, 0.87, 0.0), (1.0, 0.5, 0.31),
             (1.0, 0.99, 0.82))
CUTOUTS = ((0.07, 0.04, 0.56), (0.89, 0.26, 0.2), (1.0, 0.87, 0.0), (0.31, 0.78, 0.47), (0.05, 0.05, 0.05),
           (1.0, 1.0, 1.0))
PIXELS = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.5), (0.86, 0.08, 0.24), (1.0, 0.65, 0.0), (1.0, 0.87, 0.0),
          (0.2, 0.8, 0.2), (0.53, 0.81, 0.92), (1.0, 1.0, 1.0))
AZULEJO = ((0.0, 0.0, 0.5), (0.0, 0.28, 0.67), (0.53, 0.81, 0.92), (1.0, 1.0, 1.0))
BLUEPRINT = ((0.0, 0.19, 0.33), (1.0, 1.0, 1.0))
BATIK = ((0.29, 0.0, 0.51), (0.25, 0.16, 0.08), (0.44, 0.26, 0.08), (0.72, 0.25, 0.05), (1.0, 0.99, 0.82))
TAPESTRY = ((0.0, 0.0, 0.5), (0.86, 0.08, 0.24), (0.8, 0.47, 0.13), (0.61, 0.69, 0.53), (1.0, 0.99, 0.82))


# -- flat colour with fine outlines ---------------------------------------------------------------------
def _with_paper(tone, ground, k):
    """The lightest `ground` share of the tones (a parameter) goes to the palette's lightest colour (the paper,
    the white glaze), the other tones spread over its other colours."""
    g = ground.clamp(0.05, 0.9)
    paper = torch.sigmoid((tone - (1 - g)) * 25)
    return paper + (1 - paper) * (tone / (1 - g)).clamp(0, 1) * (k - 2) / max(1, k - 1)


def _flat(x, p, simplify, wobble=0.0):
    h, w = x.shape[-2:]
    smooth = blur(x, px(x, simplify))
    tone = ranked_tone(smooth)
    if wobble:
        tone = (tone + wobble * fixed_noise(h, w, seed=111, share=0.02, device=x.device)).clamp(0, 1)
    cs = p["colours"].clamp(0, 1)
    if "ground" in p:
        tone = _with_paper(tone, p["ground"], cs.shape[0])
    flat = palette_inks(saturate(smooth, 1.3).clamp(0, 1), tone, cs, p["sharpness"], p["hue_weight"])
    return keep_detail(flat, smooth, p)


def _border(x, p):
    """A painted border: a band of the border colour between two fine rules, with a row of dots."""
    h, w = x.shape[-2:]
    ys, xs = coords(h, w, x.device)
    hh, ww = h / max(h, w), w / max(h, w)
    inset = torch.minimum(torch.minimum(ys, hh - ys), torch.minimum(xs, ww - xs))  # distance to the edge
    width = p["border"].clamp(0.0, 0.15)
    band = torch.sigmoid((width - inset) / 0.002)
    rule = (torch.sigmoid((0.0025 - (inset - width).abs()) / 0.001)
            + torch.sigmoid((0.002 - (inset - width * 0.35).abs()) / 0.001))
    along = torch.where((ys - hh / 2).abs() / hh > (xs - ww / 2).abs() / ww, xs, ys)
    spot = torch.sqrt(((along / 0.025) % 1 - 0.5) ** 2 + ((inset - width * 0.67) / 0.025) ** 2)
    dots = torch.sigmoid((0.28 - spot) / 0.05)
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


def cutout_fields(h, w, k, device=None):
    """k fixed smooth fields (k,H,W) whose contours are curved, organic shapes: a broad noise for the
    body of each shape and a finer one for its lobes (leaves, fronds, seaweed), the same in the picture
    at any resolution."""
    return torch.cat([fixed_noise(h, w, seed=113 + i, share=0.11, device=device)
                      + 0.45 * fixed_noise(h, w, seed=213 + i, share=0.035, device=device) for i in range(k)], 1)[0]


def paper_cutouts(x, p, surface=None):
    """Shapes cut with scissors from sheets of painted paper and laid on white: the image's darker
    tones are cut paper, its lighter ones the white ground, and more shapes float on the ground
    (`scatter`). The colour boundaries are curved: each colour owns the places where its own fixed
    organic field is highest, weighted by `share` (the palette's leading colour most) and nudged
    towards the image's own colour; the cut edges are crisp and lobed, never straight."""
    h, w = x.shape[-2:]
    smooth = blur(x, px(x, 0.012))
    tone = (ranked_tone(smooth) + 0.04 * fixed_noise(h, w, seed=111, share=0.02, device=x.device)).clamp(0, 1)
    cs = p["colours"].clamp(0, 1)
    paper, inks = cs[-1], cs[:-1]
    k = inks.shape[0]
    fields = cutout_fields(h, w, k, x.device).unsqueeze(0)  # (1,k,H,W)
    broad = torch.cat([fixed_noise(h, w, seed=313 + i, share=0.16, device=x.device) for i in range(k)], 1)
    sat = saturate(smooth, 1.5).clamp(0, 1)
    own = -((sat.unsqueeze(1) - inks.view(1, k, 3, 1, 1)) ** 2).sum(2) * 2 * p["hue_weight"].clamp(0, 1)
    # which colour: large curved areas (the broad fields, their edges lobed a little by the fine ones)
    logits = (torch.log(p["share"].clamp(1e-3, 1)).view(1, k, 1, 1) + 2.0 * broad + 0.5 * fields + own) \
        * p["sharpness"].clamp(1, 50)
    sheet = torch.einsum("bkhw,kc->bchw", torch.softmax(logits, dim=1), inks)
    cut = 1 - torch.sigmoid((tone - (1 - p["ground"].clamp(0.05, 0.9))) * 40)  # cut edges: crisp
    out = paper.view(1, 3, 1, 1) * (1 - cut) + sheet * cut
    # shapes of each colour floating on the white, where its own field rises above `scatter`'s level
    # (the leading colour's level is lower: more of its shapes)
    level = 1.1 - p["scatter"].clamp(0, 1) - 0.35 * torch.log(p["share"].clamp(1e-3, 1) * k)
    for i in range(k):
        shape = torch.sigmoid((fields[:, i:i + 1] - level[i]) * 30) * (1 - cut)
        out = out * (1 - shape) + inks[i].view(1, 3, 1, 1) * shape
    return out


def _frame_colour(cs):
    """The border of a miniature: the palette's gold if it has one, else its darkest colour."""
    best = min(cs, key=goldness)
    return best if goldness(best) < 1.2 else cs[0]


def miniature_stage(colours=None) -> Stage:
    cs = sorted_palette(colours, INDIAN)
    return Stage("miniature", "medium", miniature,
                 {"colours": tensor(cs), "sharpness": tensor(14.0), "hue_weight": tensor(0.25), "detail": tensor(0.08),
                  "line": tensor(0.9), "threshold": tensor(0.55), "outline": tensor((0.12, 0.08, 0.06)),
                  "border": tensor(0.055), "frame": tensor(_frame_colour(cs))},
                 {**INK_SCALES, "line": 0.2, "threshold": 0.1, "outline": 0.15, "border": 0.02, "frame": 0.2},
                 note="named colours" if colours else "vermilion, saffron, emerald, lapis, gold")


def storybook_stage(colours=None) -> Stage:
    return Stage("storybook", "medium", storybook,
                 {"colours": tensor(sorted_palette(colours, STORYBOOK)), "sharpness": tensor(10.0),
                  "hue_weight": tensor(0.7), "detail": tensor(0.15), "line": tensor(0.75),
                  "threshold": tensor(0.6), "outline": tensor((0.3, 0.22, 0.18))},
                 {**INK_SCALES, "line": 0.2, "threshold": 0.1, "outline": 0.15},
                 note="named colours" if colours else "peach, sky blue, sage, yellow, coral")


def paper_cutouts_stage(colours=None) -> Stage:
    given = list(colours) if colours else list(CUTOUTS)
    cs = sorted_palette(given, CUTOUTS)
    if len(cs) < 2:
        cs = list(cs) + [(1.0, 1.0, 1.0)]
    # each colour's share of the sheets: the first named (the leading colour) three times the others
    order = [min(range(len(given)), key=lambda i: sum((a - b) ** 2 for a, b in zip(given[i], c))) for c in cs[:-1]]
    share = [3.0 if i == 0 else 1.0 for i in order]
    share = [v / sum(share) for v in share]
    return Stage("paper_cutouts", "medium", paper_cutouts,
                 {"colours": tensor(cs), "share": tensor(share), "sharpness": tensor(20.0),
                  "hue_weight": tensor(0.3), "ground": tensor(0.45), "scatter": tensor(0.35)},
                 {"colours": 0.2, "share": 0.1, "sharpness": 5.0, "hue_weight": 0.2, "ground": 0.1, "scatter": 0.15},
                 note="named colours" if colours else "ultramarine, red, yellow, green on white")


# -- pixel art -------------------------------------------------------------------------------------------------
PIXEL = 0.022
BAYER = ((0, 8, 2, 10), (12, 4, 14, 6), (3, 11, 1, 9), (15, 7, 13, 5))


def pixel_art(x, p, surface=None):
    """Big square pixels, each one colour of a small palette (by its tone and its own colour), in-between
    tones dithered in a Bayer pattern, with a dark outline where the image has an edge."""
    h, w = x.shape[-2:]
    cell = px(x, PIXEL, 2.0)
    mean = cell_average(x, cell)
    # ordered (Bayer) dithering, as 1980s graphics made in-between tones from a few colours
    _, iy, ix, _, _ = cell_grid(h, w, cell, device=x.device)
    bayer = torch.tensor(BAYER, device=x.device)[iy.view(-1, 1) % 4, ix.view(1, -1) % 4] / 16 - 0.47
    tone = (ranked_tone(mean) + p["dither"] * bayer.view(1, 1, h, w)).clamp(0, 1)
    cs = p["colours"].clamp(0, 1)
    ink = palette_inks(saturate(mean, 1.5).clamp(0, 1), tone, cs, p["sharpness"], p["hue_weight"])
    edges = cell_average(ink_lines(x, p["threshold"], tensor(0.1).to(x.device), 0.01), cell)
    outline = torch.sigmoid((edges - 0.35) * 14) * p["outline"].clamp(0, 1)
    return ink * (1 - outline) + cs[0].view(1, 3, 1, 1) * outline


def pixel_art_stage(colours=None) -> Stage:
    return Stage("pixel_art", "medium", pixel_art,
                 {"colours": tensor(sorted_palette(colours, PIXELS)), "sharpness": tensor(16.0),
                  "hue_weight": tensor(0.35), "threshold": tensor(0.6), "outline": tensor(0.8), "dither": tensor(0.1)},
                 {"colours": 0.2, "sharpness": 5.0, "hue_weight": 0.2, "threshold": 0.1, "outline": 0.2, "dither": 0.1},
                 note="named colours" if colours else "a 1980s 8-colour palette")


# -- glazed tiles (azulejo, Delft, porcelain) --------------------------------------------------------------
TILE = 0.1


def glazed_tiles(x, p, surface=None):
    """Square glazed tiles: the image painted in the palette's blues on white (dark to light), a
    quatrefoil ornament in each tile, light grout and a glossy sheen."""
    h, w = x.shape[-2:]
    smooth = blur(x, px(x, 0.004))
    tone = ranked_tone(smooth)
    cs = p["colours"].clamp(0, 1)
    tone = _with_paper(tone, p["ground"], cs.shape[0])  # the white glaze: the lightest tones
    painted = ramp(tone.clamp(1e-4, 1) ** p["gamma"].clamp(0.3, 3.0), cs)
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
                 {"colours": tensor(sorted_palette(colours, AZULEJO)), "gamma": tensor(1.0), "ground": tensor(0.4),
                  "ornament": tensor(0.8), "sheen": tensor(0.08), "grout": tensor((0.86, 0.85, 0.82))},
                 {"colours": 0.2, "gamma": 0.25, "ground": 0.1, "ornament": 0.2, "sheen": 0.05, "grout": 0.15},
                 note="named colours" if colours else "cobalt on white")


# -- blueprint -------------------------------------------------------------------------------------------------
def blueprint(x, p, surface=None):
    """White lines traced along the image's edges on Prussian-blue paper, with a faint grid."""
    h, w = x.shape[-2:]
    ys, xs = coords(h, w, x.device)
    cs = p["colours"].clamp(0, 1)
    paper, ink = cs[0].view(1, 3, 1, 1), cs[-1].view(1, 3, 1, 1)
    lum = luminance(blur(x, px(x, 0.01)))
    mottle = 0.03 * fixed_noise(h, w, seed=131, share=0.02, device=x.device)
    ground = paper * (1 + p["detail"] * (lum - lum.mean()) + mottle)
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
STITCH = 0.02


def woven_threads(x, p, surface=None):
    """The image as rows of stitches of coloured thread: each stitch one palette colour, rounded by
    shading across the thread, alternate rows offset like a weave."""
    h, w = x.shape[-2:]
    cell = px(x, STITCH, 2.0)
    mean = cell_average(blur(x, px(x, 0.004)), cell)
    tone = ranked_tone(mean)
    cs = p["colours"].clamp(0, 1)
    thread = palette_inks(saturate(mean, 1.3).clamp(0, 1), tone, cs, p["sharpness"], p["hue_weight"])
    fy, fx, ty, _ = tile_coords(h, w, STITCH, x.device)
    shift = (ty % 2).float() * 0.5
    fxs = (fx + shift + 0.5) % 1 - 0.5
    shade = 1 - p["depth"].clamp(0, 0.6) * (4 * fxs ** 2 + 0.6 * (2 * fy.abs()) ** 3)
    return thread * shade.view(1, 1, h, w)


def woven_threads_stage(colours=None) -> Stage:
    return Stage("woven_threads", "medium", woven_threads,
                 {"colours": tensor(sorted_palette(colours, TAPESTRY)), "sharpness": tensor(14.0),
                  "hue_weight": tensor(0.25), "depth": tensor(0.3)},
                 {"colours": 0.2, "sharpness": 4.0, "hue_weight": 0.2, "depth": 0.1},
                 note="named colours" if colours else "madder red, indigo, weld yellow, green")


# -- Ben-Day dots (pop art) ------------------------------------------------------------------------------------
BEN_DAY = ((0.05, 0.05, 0.05), (0.0, 0.28, 0.67), (0.9, 0.1, 0.12), (1.0, 0.41, 0.71), (1.0, 0.92, 0.0))


def ben_day(x, p, surface=None):
    """Flat printed colours in the palette, thick black outlines, and the lighter tones printed as
    Ben-Day dots of their colour on white paper; like Lichtenstein's blown-up comic panels."""
    h, w = x.shape[-2:]
    smooth = blur(x, px(x, 0.005))
    tone = ranked_tone(smooth)
    cs = p["colours"].clamp(0, 1)
    ink = palette_inks(saturate(smooth, 1.5).clamp(0, 1), tone, cs, p["sharpness"], p["hue_weight"])
    fy, fx, _, _ = tile_coords(h, w, 0.018, x.device)
    dots = torch.sigmoid((p["dot_size"].clamp(0.15, 0.7) - torch.sqrt(fy ** 2 + fx ** 2)) / 0.05).view(1, 1, h, w)
    dotted = torch.sigmoid((tone - p["dot_from"]) * 12)
    paper = p["paper"].clamp(0, 1).view(1, 3, 1, 1)
    # the dots print a light tint as in comics: the palette's strong colour nearest the image's own
    strong = cs[1:-1] if cs.shape[0] > 2 else cs
    dot_ink = palette_inks(saturate(smooth, 2.5).clamp(0, 1), tone, strong, p["sharpness"], tone.new_tensor(1.0))
    printed = ink * (1 - dotted) + dotted * (paper * (1 - dots) + dot_ink * dots)
    lines = ink_lines(x, p["threshold"], tensor(0.1).to(x.device), 0.009) * p["line"].clamp(0, 1)
    return printed * (1 - lines) + cs[0].view(1, 3, 1, 1) * lines


def ben_day_stage(colours=None) -> Stage:
    return Stage("ben_day", "medium", ben_day,
                 {"colours": tensor(sorted_palette(colours, BEN_DAY)), "sharpness": tensor(14.0),
                  "hue_weight": tensor(0.4), "dot_size": tensor(0.4), "dot_from": tensor(0.62),
                  "paper": tensor((0.98, 0.97, 0.94)), "threshold": tensor(0.55), "line": tensor(0.95)},
                 {**INK_SCALES, "dot_size": 0.1, "dot_from": 0.1, "paper": 0.15, "threshold": 0.1, "line": 0.2},
                 note="named colours" if colours else "red, yellow, blue, pink, black")
