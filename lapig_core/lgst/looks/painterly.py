"""Painters' signatures the neural styles cannot show (issue 30): broken impressionist strokes,
pointillist dots of pure colour, colour fields, a primary-colour grid with black lines, gold leaf with
ornament, chiaroscuro, cubist facets, stained glass and poured lines.

Each is a Stage: the palette (dark to light) and every strength are parameters PSA moves; the patterns
(strokes, dots, pieces, fields) are fixed in shares of the image, so they read the same at any size.
The image under the look stays in it: its tones choose the inks, and a `detail` share of its own
colour is kept, so the projected object is still recognisable.
"""
from __future__ import annotations

import torch

from .graphic import ink_lines
from .ops import (blur, cell_grid, cell_ids, fixed_noise, keep_detail, luminance, px, ramp, region_mean, saturate,
                  soft_steps, stretched_luminance)
from .patterns import (INK_SCALES, coords, directional_noise, goldness, palette_inks, per_region, ranked_tone,
                       sorted_palette, tile_coords, unit_coords, veins, voronoi)
from .stage import Stage, tensor

# default palettes (when a prompt names the look but no colours): the lexicon's main entry for each
MONET = ((0.58, 0.69, 0.55), (0.78, 0.64, 0.78), (0.68, 0.8, 0.92), (1.0, 0.75, 0.8), (1.0, 0.99, 0.82))
SEURAT = ((1.0, 0.65, 0.0), (0.39, 0.58, 0.93), (0.31, 0.78, 0.47), (1.0, 0.87, 0.0), (0.78, 0.64, 0.78))
ROTHKO = ((0.5, 0.0, 0.0), (0.86, 0.08, 0.24), (1.0, 0.55, 0.05))
MONDRIAN = ((0.97, 0.96, 0.92), (0.87, 0.1, 0.1), (0.98, 0.84, 0.1), (0.1, 0.25, 0.65), (0.06, 0.06, 0.07))
KLIMT = ((1.0, 0.84, 0.0), (0.85, 0.65, 0.13), (0.31, 0.55, 0.4), (0.06, 0.06, 0.06), (1.0, 0.99, 0.82))
REMBRANDT = ((0.04, 0.03, 0.02), (0.39, 0.32, 0.28), (0.54, 0.2, 0.14), (0.8, 0.47, 0.13), (1.0, 0.87, 0.0))
CUBISM = ((0.39, 0.32, 0.28), (0.44, 0.5, 0.56), (0.44, 0.51, 0.22), (0.8, 0.47, 0.13), (0.95, 0.92, 0.82))
GLASS = ((0.88, 0.07, 0.37), (0.0, 0.28, 0.67), (0.31, 0.78, 0.47), (1.0, 0.87, 0.0), (0.54, 0.17, 0.89))
POLLOCK = ((0.05, 0.05, 0.05), (0.95, 0.95, 0.92), (0.8, 0.47, 0.13), (0.44, 0.5, 0.56), (0.0, 0.5, 0.5))


def _palette(colours, default):
    return tensor(sorted_palette(colours, default))


# -- broken strokes (Impressionism) ----------------------------------------------------------------------
def broken_strokes(x, p, surface=None):
    h, w = x.shape[-2:]
    smooth = blur(x, px(x, 0.005))
    strokes = directional_noise(h, w, seed=21, share=0.006, length=0.02, device=x.device)
    tone = (ranked_tone(smooth) + p["jitter"] * 0.25 * strokes).clamp(0, 1)
    cs = p["colours"].clamp(0, 1)
    ink = palette_inks(saturate(smooth, 1.3).clamp(0, 1), tone, cs, p["sharpness"], p["hue_weight"])
    return keep_detail(ink, smooth, p) * (1 + p["relief"] * 0.3 * strokes.clamp(-1.5, 1.5))


def broken_strokes_stage(colours=None) -> Stage:
    return Stage("broken_strokes", "medium", broken_strokes,
                 {"colours": _palette(colours, MONET), "jitter": tensor(0.55), "sharpness": tensor(7.0),
                  "hue_weight": tensor(0.25), "detail": tensor(0.15), "relief": tensor(0.35)},
                 {**INK_SCALES, "jitter": 0.2, "relief": 0.15},
                 note="named colours" if colours else "Monet's lilac, blue, green and pink")


# -- pointillist dots (Seurat) ---------------------------------------------------------------------------
DOT_CELL = 0.02


def pointillist_dots(x, p, surface=None):
    h, w = x.shape[-2:]
    cell = px(x, DOT_CELL, 2.0)
    smooth = blur(x, px(x, 0.006))
    dist, *_ = cell_grid(h, w, cell, device=x.device)
    ids, n = cell_ids(h, w, cell, device=x.device)
    mean = region_mean(smooth, ids, n)
    # every dot one pure colour: the tone of its spot, shifted by a fixed amount per dot, so neighbouring
    # dots take neighbouring colours and mix in the eye
    tone = (ranked_tone(mean) + p["jitter"] * 0.3 * per_region(ids, n, seed=31)).clamp(0, 1)
    cs = p["colours"].clamp(0, 1)
    ink = palette_inks(saturate(mean, 1.4).clamp(0, 1), tone, cs, p["sharpness"], p["hue_weight"])
    # dots a little irregular in size
    radius = p["radius"].clamp(0.2, 0.7) * (1 + 0.15 * per_region(ids, n, seed=32))
    cover = torch.sigmoid((radius - dist.view(1, 1, h, w)) / 0.07)
    ground = keep_detail(p["ground"].view(1, 3, 1, 1), smooth, p)
    return ground * (1 - cover) + ink * cover


def pointillist_dots_stage(colours=None) -> Stage:
    return Stage("pointillist_dots", "medium", pointillist_dots,
                 {"colours": _palette(colours, SEURAT), "jitter": tensor(0.8), "sharpness": tensor(10.0),
                  "hue_weight": tensor(0.15), "radius": tensor(0.5), "ground": tensor((0.96, 0.93, 0.85)),
                  "detail": tensor(0.25)},
                 {**INK_SCALES, "jitter": 0.2, "radius": 0.1, "ground": 0.2},
                 note="named colours" if colours else "Seurat's pure colours")


# -- colour fields (Rothko) ----------------------------------------------------------------------------------
def colour_fields(x, p, surface=None):
    """Soft-edged rectangles stacked on a ground: the palette's darkest colour is the ground, the
    others the fields, top to bottom from light to dark; the image's tones breathe through them."""
    h, w = x.shape[-2:]
    t, s = unit_coords(h, w, x.device)
    wobble = 0.012 * fixed_noise(h, w, seed=41, share=0.03, device=x.device)
    cs = p["colours"].clamp(0, 1)
    ground, fields = cs[0], cs.flip(0)[:-1] if cs.shape[0] > 1 else cs
    k = fields.shape[0]
    m = p["margin"].clamp(0.01, 0.25)
    gap = p["gap"].clamp(0.0, 0.2)
    soft = p["feather"].clamp(0.003, 0.1)
    across = torch.sigmoid((s - m + wobble) / soft) * torch.sigmoid((1 - m - s + wobble) / soft)
    span = (1 - 2 * m - (k - 1) * gap) / k
    lum = luminance(blur(x, px(x, 0.01)))
    breathe = 1 + p["detail"] * (lum - lum.mean()) * 2
    wash = 1 + p["wash"] * fixed_noise(h, w, seed=42, share=0.06, device=x.device)
    out = ground.view(1, 3, 1, 1) * (1 + 0.5 * p["detail"] * (lum - lum.mean())) * wash
    for i in range(k):
        top = m + i * (span + gap)
        band = torch.sigmoid((t - top + wobble) / soft) * torch.sigmoid((top + span - t + wobble) / soft) * across
        colour = fields[i].view(1, 3, 1, 1) * breathe * wash
        out = out * (1 - band) + colour * band
    return out


def colour_fields_stage(colours=None) -> Stage:
    return Stage("colour_fields", "medium", colour_fields,
                 {"colours": _palette(colours, ROTHKO), "margin": tensor(0.08), "gap": tensor(0.06),
                  "feather": tensor(0.02), "detail": tensor(0.3), "wash": tensor(0.06)},
                 {"colours": 0.2, "margin": 0.04, "gap": 0.03, "feather": 0.01, "detail": 0.15, "wash": 0.04},
                 note="named colours" if colours else "Rothko's maroon, crimson and orange")


# -- primary grid (Mondrian) ---------------------------------------------------------------------------------
GRID_X = (0.2, 0.36, 0.72, 0.9)
GRID_Y = (0.26, 0.6, 0.82)
# which rectangles are coloured, before the image has its say: (row, column) -> share of the plan
GRID_PLAN = (0.9, 0.2, 0.15, 0.85, 0.3,     # rows top to bottom, columns left to right: about 40% of the
             0.25, 0.1, 0.95, 0.2, 0.8,     # area is planned as colour blocks (the big centre block, a few
             0.85, 0.3, 0.15, 0.35, 0.1,    # small ones at the edges), as in Mondrian's compositions
             0.2, 0.15, 0.9, 0.8, 0.25)


def primary_grid(x, p, surface=None):
    """Black lines (their positions are parameters) cut the image into rectangles; each is the ground
    colour or one of the block colours: the plan and the rectangle's own colour choose."""
    h, w = x.shape[-2:]
    t, s = unit_coords(h, w, x.device)
    cs = p["colours"].clamp(0, 1)
    ground, line, blocks = cs[-1], cs[0], cs[1:-1] if cs.shape[0] > 2 else cs
    gx, gy = p["grid_x"].clamp(0.02, 0.98), p["grid_y"].clamp(0.02, 0.98)
    half = p["line_width"].clamp(0.003, 0.05) / 2
    on_x = torch.sigmoid((half - (s - gx.view(-1, 1, 1)).abs()) / 0.003).amax(0)   # (1,W)->(H?)
    on_y = torch.sigmoid((half - (t - gy.view(-1, 1, 1)).abs()) / 0.003).amax(0)
    lines = torch.maximum(on_x.expand(h, w), on_y.expand(h, w)).view(1, 1, h, w)
    # rectangles: index by the (fixed at this step) line positions
    col = (s > gx.detach().view(-1, 1, 1)).sum(0).expand(h, w)
    row = (t > gy.detach().view(-1, 1, 1)).sum(0).expand(h, w)
    ids = row * (len(GRID_X) + 1) + col
    n = (len(GRID_Y) + 1) * (len(GRID_X) + 1)
    mean = region_mean(blur(x, px(x, 0.01)), ids, n)
    plan = torch.tensor(GRID_PLAN[:n], device=x.device)[ids].view(1, 1, h, w)
    chroma = mean.amax(1, keepdim=True) - mean.amin(1, keepdim=True)
    coloured = torch.sigmoid((plan + 0.6 * chroma - p["white_share"]) * 25)
    # which block colour: nearest to the rectangle's own colour (saturated), softly
    sat = saturate(mean, 2.0).clamp(0, 1)
    k = blocks.shape[0]
    d = ((sat.unsqueeze(1) - blocks.view(1, k, 3, 1, 1)) ** 2).sum(2)
    rnd = ((per_region(ids, n, seed=51)[0, 0] + 1) / 2 * k).long().clamp(0, k - 1)
    prefer = torch.nn.functional.one_hot(rnd, k).permute(2, 0, 1).unsqueeze(0).float()
    pick = torch.softmax(-d * 20 + 8.0 * prefer, dim=1)  # one block colour, not a blend of two
    block = torch.einsum("bkhw,kc->bchw", pick, blocks)
    flat = ground.view(1, 3, 1, 1) * (1 - coloured) + block * coloured
    lum = luminance(blur(x, px(x, 0.008)))
    flat = flat * (1 - p["detail"] * (lum.mean() - lum).clamp(-0.5, 0.5))
    return flat * (1 - lines) + line.view(1, 3, 1, 1) * lines


def primary_grid_stage(colours=None) -> Stage:
    cs = sorted_palette(colours, MONDRIAN)
    if colours and len(cs) < 3:  # named block colours only: white ground and black lines added
        cs = [(0.06, 0.06, 0.07)] + list(cs) + [(0.97, 0.96, 0.92)]
    return Stage("primary_grid", "medium", primary_grid,
                 {"colours": tensor(cs), "grid_x": tensor(GRID_X), "grid_y": tensor(GRID_Y),
                  "line_width": tensor(0.018), "white_share": tensor(0.55), "detail": tensor(0.12)},
                 {"colours": 0.2, "grid_x": 0.05, "grid_y": 0.05, "line_width": 0.008, "white_share": 0.15,
                  "detail": 0.15},
                 note="named colours" if colours else "white, red, yellow, blue, black")


# -- gold leaf with ornament (Klimt) ---------------------------------------------------------------------
def gold_leaf(x, p, surface=None):
    """The image's lighter tones become beaten gold leaf (square leaves, each a slightly different
    gold) printed with ornament: rings and spirals in the darkest colour, small squares and dots in the
    others; its darkest tones stay flat paint in the palette's other colours."""
    h, w = x.shape[-2:]
    smooth = blur(x, px(x, 0.006))
    tone = ranked_tone(smooth)
    cs = p["colours"].clamp(0, 1)
    leaf = p["leaf"].clamp(0, 1).view(1, 3, 1, 1)
    # leaves: squares of 4% with their own tint, and a fine beaten texture
    fy, fx, ty, tx = tile_coords(h, w, 0.04, x.device)
    g = torch.Generator().manual_seed(61)
    tint = (torch.rand(int(ty.max()) + 1, int(tx.max()) + 1, generator=g) - 0.5).to(x.device)
    tint = tint[ty.view(-1, 1).clamp_min(0), tx.view(1, -1).clamp_min(0)].view(1, 1, h, w)
    beaten = fixed_noise(h, w, seed=62, share=0.004, device=x.device)
    # metal: darker and warmer where the image is darker, a pale sheen where it is light
    gold = leaf * (0.6 + 0.4 * tone) * (1 + p["shimmer"] * (1.2 * tint + 0.35 * beaten))
    gold = gold + 0.25 * torch.relu(tone - 0.75) * leaf.mean()
    # ornament: rings on a 9% grid, small squares on a 5% grid offset, dots in between
    ry, rx, oy_i, ox_i = tile_coords(h, w, 0.09, x.device)
    r = torch.sqrt(ry ** 2 + rx ** 2)
    ring = p["ring"].clamp(0.01, 0.1)
    rings = (torch.sigmoid((ring - (r - 0.3).abs()) / 0.01)
             + torch.sigmoid((ring * 0.85 - (r - 0.14).abs()) / 0.01)).clamp(0, 1)
    sy, sx, _, _ = tile_coords(h, w, 0.05, x.device)
    squares = torch.sigmoid((0.2 - torch.maximum(sy.abs(), sx.abs())) / 0.02) - \
        torch.sigmoid((0.12 - torch.maximum(sy.abs(), sx.abs())) / 0.02)
    odd = ((oy_i + ox_i) % 2 == 0).float()  # (H,W): rings on every other ornament cell
    dark_orn = (rings * odd).view(1, 1, h, w)
    light_orn = (squares.clamp(0, 1) * (1 - odd)).view(1, 1, h, w)
    accent = cs[1] if cs.shape[0] > 2 else cs[0]
    o = p["ornament"].clamp(0, 1)
    gold = gold * (1 - o * dark_orn) + cs[0].view(1, 3, 1, 1) * o * dark_orn
    gold = gold * (1 - o * light_orn) + accent.view(1, 3, 1, 1) * o * light_orn
    # the darkest parts: flat paint in the palette (without the leaf colour)
    # the darkest parts: flat paint in the palette, its whole range over the tones below the gilding
    paint_tone = (tone / p["threshold"].clamp(0.05, 0.95)).clamp(0, 1)
    paint = palette_inks(saturate(smooth, 1.2).clamp(0, 1), paint_tone, cs, tensor(8.0).to(x.device),
                         tensor(0.4).to(x.device))
    paint = keep_detail(paint, smooth, p)
    gilded = torch.sigmoid((tone - p["threshold"]) * 12)
    return paint * (1 - gilded) + gold * gilded


def gold_leaf_stage(colours=None) -> Stage:
    if colours:  # the named colour nearest gold is the leaf, the others paint and ornament
        leaf = min(colours, key=goldness)
        rest = [c for c in colours if c is not leaf] or [(0.06, 0.06, 0.06)]
        cs = sorted_palette(rest, KLIMT)
    else:
        leaf, cs = KLIMT[0], sorted_palette(KLIMT[1:], KLIMT)
    return Stage("gold_leaf", "medium", gold_leaf,
                 {"leaf": tensor(leaf), "colours": tensor(cs), "threshold": tensor(0.3), "ornament": tensor(0.85),
                  "ring": tensor(0.035), "shimmer": tensor(0.3), "detail": tensor(0.2)},
                 {"leaf": 0.15, "colours": 0.2, "threshold": 0.1, "ornament": 0.2, "ring": 0.015, "shimmer": 0.15,
                  "detail": 0.15},
                 note="named colours" if colours else "Klimt's gold, emerald and black")


# -- chiaroscuro (Rembrandt, Caravaggio, Vermeer) ------------------------------------------------------
WARM = (1.0, 0.78, 0.45)


def side_light(h, w, p, device):
    """Light from one side (1,1,H,W) in [0,1]: full on the near side of a line through (light_x, light_y),
    reaching `reach` further in the direction `light_angle` (radians, 0 = light from the left, going
    right; positive turns it downwards) and falling off over `soften`, and slowly across it, so it is a
    raking light with an edge, not a disc;
    `blinds` casts the stripes of a venetian blind across it."""
    t, s = unit_coords(h, w, device)
    a = p["light_angle"]
    along = (s - p["light_x"]) * torch.cos(a) + (t - p["light_y"]) * torch.sin(a)
    across = -(s - p["light_x"]) * torch.sin(a) + (t - p["light_y"]) * torch.cos(a)
    reach = p["reach"].clamp(0.08, 1.5)
    soft = p["soften"].clamp(0.02, 0.5)
    light = torch.sigmoid((reach - along) / soft) * torch.exp(-across ** 2 / (2 * (3 * reach) ** 2))
    if "blinds" in p:
        slats = torch.sigmoid(torch.sin(2 * 3.1416 * (along * 0.6 + across) / 0.07) * 6)
        light = light * (1 - p["blinds"].clamp(0, 1) * slats)
    return light.view(1, 1, h, w)


def chiaroscuro(x, p, surface=None):
    """One light falls from one side across the image (its place, direction and reach are parameters);
    the far side sinks towards the palette's darkest colour but keeps a `floor` of light, so a
    projector still has something to show; tones are mapped dark to light through the palette, and the
    lit side is warmed (`warmth`) as by candle or window light and its tones raised (`lift`)."""
    h, w = x.shape[-2:]
    light = side_light(h, w, p, x.device)
    smooth = blur(x, px(x, 0.004))
    floor = p["floor"].clamp(0, 1)
    shade = floor + (1 - floor) * light
    # the image's own tones through the palette, as if all of it were lit ...
    tone = stretched_luminance(smooth).clamp(1e-4, 1) ** p["gamma"].clamp(0.3, 3.0)
    tone = tone + p["lift"].clamp(0, 1) * light * (1 - tone)  # what the light falls on takes the light colours
    cs = p["colours"].clamp(0, 1)
    # soft plateaus at each colour, so most pixels are a colour of the palette, not a blend of two
    ends = soft_steps(torch.tensor([0.0, 1.0], device=x.device), cs.shape[0], 4.0)
    mapped = ramp((soft_steps(tone, cs.shape[0], 4.0) - ends[0]) / (ends[1] - ends[0]), cs)
    if "hue_weight" in p:  # the lit colours may also follow the image's own (a blue cloth stays blue)
        own = palette_inks(saturate(smooth, 1.5).clamp(0, 1), tone, cs, tone.new_tensor(8.0), p["hue_weight"])
        mapped = mapped + (own - mapped) * p["hue_weight"].clamp(0, 1) * light
    if "warmth" in p:
        warm = mapped * tensor(WARM).to(x.device).view(1, 3, 1, 1) * 1.15
        mapped = mapped + (warm - mapped) * p["warmth"].clamp(0, 1) * light
    # ... then shaded: away from the light each colour sinks into the darkest one (no rainbow of the
    # palette across the edge of the light)
    mapped = cs[0].view(1, 3, 1, 1) + (mapped - cs[0].view(1, 3, 1, 1)) * shade
    tone = tone * shade
    d = p["detail"].clamp(0, 1)
    return mapped * (1 - d) + d * smooth * tone / (luminance(smooth) + 0.05) * 0.5


def chiaroscuro_stage(colours=None) -> Stage:
    # dark to light by luminance (what a tone ramp needs: burnt sienna is lighter than gold in HLS
    # lightness, but darker to the eye, and the light must fall in gold)
    cs = sorted(sorted_palette(colours, REMBRANDT), key=lambda c: 0.299 * c[0] + 0.587 * c[1] + 0.114 * c[2])
    if luminance(torch.tensor(cs[0]).view(1, 3, 1, 1)).item() > 0.12:
        cs = [(0.03, 0.025, 0.02)] + list(cs)  # the dark the light falls out of
    return Stage("chiaroscuro", "medium", chiaroscuro,
                 {"colours": tensor(cs), "light_x": tensor(0.3), "light_y": tensor(0.3), "light_angle": tensor(0.6),
                  "reach": tensor(0.25), "soften": tensor(0.08), "floor": tensor(0.15), "gamma": tensor(1.1), "detail": tensor(0.2),
                  "hue_weight": tensor(0.0), "warmth": tensor(0.2), "blinds": tensor(0.0), "lift": tensor(0.35)},
                 {"colours": 0.2, "light_x": 0.1, "light_y": 0.1, "light_angle": 0.3, "reach": 0.08, "soften": 0.04,
                  "floor": 0.08, "gamma": 0.25, "detail": 0.15, "hue_weight": 0.2, "warmth": 0.15, "blinds": 0.2, "lift": 0.15},
                 note="named colours" if colours else "umber, ochre and gold out of black")


# -- pieces: stained glass and cubist facets --------------------------------------------------------------
def _pieces(x, share, seed):
    h, w = x.shape[-2:]
    ids, edge, oy, ox, n, keys = voronoi(h, w, share, seed, x.device)
    smooth = blur(x, px(x, 0.004))
    mean = region_mean(smooth, ids, n)
    return ids, edge, oy, ox, n, keys, smooth, mean


def stained_glass(x, p, surface=None):
    """Irregular pieces of glass, each one colour of the palette (its tone and its own colour choose,
    neighbours differ a little), lit from behind (brighter at the piece's heart), joined by dark lead
    lines; the image's strong edges are leaded too."""
    h, w = x.shape[-2:]
    ids, edge, oy, ox, n, keys, smooth, mean = _pieces(x, 0.055, 71)
    tone = (ranked_tone(mean) + p["jitter"] * 0.25 * per_region(ids, n, 72, keys)).clamp(0, 1)
    cs = p["colours"].clamp(0, 1)
    glass = palette_inks(saturate(mean, 1.5).clamp(0, 1), tone, cs, p["sharpness"], p["hue_weight"])
    glass = saturate(glass, 1.25).clamp(0, 1)  # jewel colours: light through coloured glass
    heart = torch.exp(-(oy ** 2 + ox ** 2) / (2 * 0.02 ** 2)).view(1, 1, h, w)
    texture = fixed_noise(h, w, seed=73, share=0.01, device=x.device)
    glass = glass * (0.82 + p["glow"] * heart + 0.06 * texture)
    lead = torch.sigmoid((p["lead"].clamp(0.001, 0.02) - edge.view(1, 1, h, w)) / 0.0015)
    lead = torch.maximum(lead, ink_lines(x, p["threshold"], tensor(0.1).to(x.device), 0.008) * 0.9)
    return glass * (1 - lead) + p["lead_colour"].view(1, 3, 1, 1) * lead


def stained_glass_stage(colours=None) -> Stage:
    return Stage("stained_glass", "medium", stained_glass,
                 {"colours": _palette(colours, GLASS), "jitter": tensor(0.6), "sharpness": tensor(14.0),
                  "hue_weight": tensor(0.35), "glow": tensor(0.3), "lead": tensor(0.0045),
                  "lead_colour": tensor((0.05, 0.05, 0.06)), "threshold": tensor(0.75)},
                 {**INK_SCALES, "jitter": 0.2, "glow": 0.15, "lead": 0.002, "lead_colour": 0.15, "threshold": 0.1},
                 note="named colours" if colours else "ruby, cobalt, emerald, gold, violet")


def cubist_facets(x, p, surface=None):
    """The image broken into large angular facets: each facet one colour of a muted palette, shaded
    across itself from light to dark in its own direction, with thin dark edges."""
    h, w = x.shape[-2:]
    ids, edge, oy, ox, n, keys, smooth, mean = _pieces(x, 0.085, 81)
    # facets follow the image too: half the piece's mean, half the pixel's own tone
    tone = ranked_tone(0.5 * mean + 0.5 * smooth)
    cs = p["colours"].clamp(0, 1)
    paint = palette_inks(mean.clamp(0, 1), tone, cs, p["sharpness"], p["hue_weight"])
    angle = per_region(ids, n, 82, keys) * 3.1416
    slope = (oy.view(1, 1, h, w) * torch.sin(angle) + ox.view(1, 1, h, w) * torch.cos(angle)) / 0.085
    paint = paint * (1 - p["shade"] * (1 - slope.clamp(-1, 1)) / 2)  # each facet darkens towards one side
    line = torch.sigmoid((p["line"].clamp(0.0005, 0.01) - edge.view(1, 1, h, w)) / 0.001)
    paint = keep_detail(paint, smooth, p)
    return paint * (1 - line) + cs[0].view(1, 3, 1, 1) * 0.6 * line


def cubist_facets_stage(colours=None) -> Stage:
    return Stage("cubist_facets", "medium", cubist_facets,
                 {"colours": _palette(colours, CUBISM), "sharpness": tensor(8.0), "hue_weight": tensor(0.2),
                  "shade": tensor(0.35), "line": tensor(0.0025), "detail": tensor(0.15)},
                 {**INK_SCALES, "shade": 0.15, "line": 0.001},
                 note="named colours" if colours else "ochre, umber, olive and grey")


# -- poured lines (Pollock) ------------------------------------------------------------------------------------
def poured_lines(x, p, surface=None):
    """Webs of dripped and poured paint over the image: several layers of thin meandering lines, one
    per palette colour, over a ground toned to the palette."""
    h, w = x.shape[-2:]
    smooth = blur(x, px(x, 0.006))
    cs = p["colours"].clamp(0, 1)
    ground = palette_inks(smooth.clamp(0, 1), ranked_tone(smooth), cs, tensor(4.0).to(x.device),
                          tensor(0.3).to(x.device))
    out = keep_detail(ground, smooth, p)
    k = cs.shape[0]
    for i in range(k):
        layer = veins(h, w, seed=91 + i, share=0.05 + 0.02 * (i % 3), width=0.0025 + 0.0015 * (i % 2), device=x.device)
        splat = torch.sigmoid((fixed_noise(h, w, seed=101 + i, share=0.012, device=x.device) - 1.2) * 6)
        a = (p["density"].clamp(0, 1) * torch.maximum(layer, splat)).clamp(0, 1)
        out = out * (1 - a) + cs[(i * 2 + 1) % k].view(1, 3, 1, 1) * a
    return out


def poured_lines_stage(colours=None) -> Stage:
    return Stage("poured_lines", "medium", poured_lines,
                 {"colours": _palette(colours, POLLOCK), "density": tensor(0.9), "detail": tensor(0.3)},
                 {"colours": 0.2, "density": 0.15, "detail": 0.15},
                 note="named colours" if colours else "black, white, ochre, grey, teal")


# -- wavy bands (Munch) ------------------------------------------------------------------------------------
MUNCH = ((0.0, 0.19, 0.33), (0.53, 0.03, 0.03), (0.33, 0.42, 0.18), (1.0, 0.65, 0.0), (1.0, 0.87, 0.0))


def wavy_bands(x, p, surface=None):
    """Long undulating bands of the palette's colours running through the whole image, bent by its
    tones, with streaks along them; like the sky of Munch's Scream; below a wavy horizon (`horizon`) they sink
    (`fjord`) into the palette's darkest colours, the dark water under that sky."""
    h, w = x.shape[-2:]
    ys, xs = coords(h, w, x.device)
    warp = fixed_noise(h, w, seed=151, share=0.15, device=x.device)
    phase = ys * 5 + xs * 1.2 + 0.9 * warp
    # a triangle wave: every colour of the palette gets an equal band (a sine lingers at its ends)
    wave = (2 * (2 * (phase - torch.floor(phase)) - 1).abs() - 1).view(1, 1, h, w)
    smooth = blur(x, px(x, 0.006))
    swirl = p["swirl"].clamp(0, 1)
    tone = (ranked_tone(smooth) * (1 - swirl) + swirl * (0.5 + 0.5 * wave)).clamp(0, 1)
    if "fjord" in p:  # below a wavy horizon the bands sink into the darkest colour (the Scream's fjord)
        t = (ys / (h / max(h, w))).view(1, 1, h, 1)
        below = torch.sigmoid((t - p["horizon"].clamp(0.1, 0.95) + 0.04 * wave) / 0.03)
        water = (1 - p["fjord"].clamp(0, 1)) * (0.5 + 0.5 * wave)  # its own waves, in the darkest colours
        tone = tone * (1 - below) + water * below
    cs = p["colours"].clamp(0, 1)
    ink = palette_inks(saturate(smooth, 1.3).clamp(0, 1), tone, cs, p["sharpness"], p["hue_weight"])
    streaks = directional_noise(h, w, seed=152, share=0.005, length=0.03, device=x.device)
    return keep_detail(ink, smooth, p) * (1 + 0.08 * streaks.clamp(-1.5, 1.5))


def wavy_bands_stage(colours=None) -> Stage:
    return Stage("wavy_bands", "medium", wavy_bands,
                 {"colours": _palette(colours, MUNCH), "swirl": tensor(0.7), "sharpness": tensor(6.0),
                  "hue_weight": tensor(0.1), "detail": tensor(0.12), "horizon": tensor(0.58), "fjord": tensor(0.8)},
                 {**INK_SCALES, "swirl": 0.15, "horizon": 0.08, "fjord": 0.2},
                 note="named colours" if colours else "Munch's orange, red, blue and green")
