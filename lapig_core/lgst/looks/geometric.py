"""Geometric signatures of the art lexicon (issue 30): Art Deco's sunbursts and chevrons, Suprematism's
floating shapes on white, and Kandinsky's circles and lines.

As in painterly.py, the palette (dark to light) and every strength, place and size are parameters PSA
moves; the image under the look stays in it (its tones choose the inks, or show faintly through), so the
projected object is still recognisable.
"""
from __future__ import annotations

import math

import torch

from .graphic import ink_lines
from .ops import blur, fixed_noise, luminance, px, saturate
from .patterns import goldness, palette_inks, ranked_tone, sorted_palette, unit_coords
from .stage import Stage, tensor

DECO = ((0.05, 0.05, 0.06), (0.0, 0.0, 0.5), (0.31, 0.78, 0.47), (1.0, 0.99, 0.82))
DECO_GOLD = (0.85, 0.65, 0.13)
SUPREMATISM = ((0.05, 0.05, 0.05), (0.1, 0.25, 0.65), (0.85, 0.1, 0.1), (0.98, 0.84, 0.1), (0.97, 0.96, 0.92))
KANDINSKY = ((0.05, 0.05, 0.05), (0.0, 0.28, 0.67), (0.54, 0.17, 0.89), (0.89, 0.26, 0.2), (0.31, 0.78, 0.47),
             (1.0, 0.87, 0.0), (0.97, 0.95, 0.88))


# -- Art Deco: sunbursts, chevrons, gold lines ------------------------------------------------------------
def deco_sunburst(x, p, surface=None):
    """The image's dark shapes in flat black, navy or jade with crisp gold outlines; its light ground a
    sunburst of gold rays fanning from a point (`sun_x`, `sun_y`; `rays` of them), cream between them
    near the sun and black beyond a stepped arc (`night`);
    a band of gold and black chevrons along the foot (`band` of the height)."""
    h, w = x.shape[-2:]
    t, s = unit_coords(h, w, x.device)
    smooth = blur(x, px(x, 0.005))
    tone = ranked_tone(smooth)
    cs = p["colours"].clamp(0, 1)
    gold = p["gold"].clamp(0, 1).view(1, 3, 1, 1)
    k = cs.shape[0]
    # the dark shapes: flat inks from the palette's darker colours
    thr = p["threshold"].clamp(0.05, 0.95)
    shapes = palette_inks(saturate(smooth, 1.3).clamp(0, 1), (tone / thr).clamp(0, 1) * (k - 2) / max(1, k - 1), cs,
                          tensor(12.0).to(x.device), p["hue_weight"])
    dark = torch.sigmoid((thr - tone) * 25)
    # the ground: a sunburst of cream and gold wedges
    angle = torch.atan2(t - p["sun_y"], s - p["sun_x"]).view(1, 1, h, w)
    fan = torch.sigmoid(torch.cos(angle * p["rays"].clamp(4, 60)) * 8)
    r = torch.sqrt((t - p["sun_y"]) ** 2 + (s - p["sun_x"]) ** 2).view(1, 1, h, w)
    # between the rays: cream near the sun, black beyond a stepped arc (`night`, its radius)
    step = torch.floor(angle * p["rays"].clamp(4, 60) / math.pi) % 3  # the arc steps down wedge by wedge
    far = torch.sigmoid((r - p["night"].clamp(0.1, 1.5) + 0.05 * step) / 0.003)
    between = cs[-1].view(1, 3, 1, 1) * (1 - far) + cs[0].view(1, 3, 1, 1) * far
    ground = between * (1 - fan) + gold * fan
    disc = torch.sigmoid((0.12 - r) / 0.004)  # the sun itself: a gold half-disc with a black ring
    ring = torch.sigmoid((0.006 - (r - 0.14).abs()) / 0.002)
    ground = ground * (1 - disc) + gold * disc
    ground = ground * (1 - ring) + cs[0].view(1, 3, 1, 1) * ring
    out = ground * (1 - dark) + shapes * dark
    # chevrons along the foot
    band = p["band"].clamp(0.0, 0.4)
    below = torch.sigmoid((t - (1 - band)) / 0.003).expand(h, w).reshape(1, 1, h, w)
    v = t + 0.5 * ((s / 0.08) - torch.floor(s / 0.08) - 0.5).abs() * 0.08 * 2
    stripes = torch.sigmoid(torch.sin(2 * math.pi * v / 0.035) * 8).view(1, 1, h, w)
    chevrons = gold * stripes + cs[0].view(1, 3, 1, 1) * (1 - stripes)
    out = out * (1 - below) + chevrons * below
    # crisp gold lines on the shapes' edges and along the band's top
    edge = ink_lines(x, p["line_threshold"], tensor(0.1).to(x.device), 0.004) * p["line"].clamp(0, 1)
    rule = torch.sigmoid((0.004 - (t - (1 - band)).abs()) / 0.0015).expand(h, w).reshape(1, 1, h, w) \
        * (band > 0.01).float()
    lines = torch.maximum(edge, rule)
    return out * (1 - lines) + gold * lines


def deco_sunburst_stage(colours=None) -> Stage:
    if colours:  # the named colour nearest gold is the metal, the others the inks and the ground
        leaf = min(colours, key=goldness)
        rest = [c for c in colours if c is not leaf] or [(0.05, 0.05, 0.06), (1.0, 0.99, 0.82)]
        if goldness(leaf) > 1.2:  # no gold named: keep the metal, all named colours are inks
            leaf, rest = DECO_GOLD, list(colours)
        cs = sorted_palette(rest, DECO)
        if len(cs) < 2:
            cs = [(0.05, 0.05, 0.06)] + list(cs)
    else:
        leaf, cs = DECO_GOLD, list(DECO)
    return Stage("deco_sunburst", "medium", deco_sunburst,
                 {"colours": tensor(cs), "gold": tensor(leaf), "threshold": tensor(0.4), "hue_weight": tensor(0.3),
                  "sun_x": tensor(0.5), "sun_y": tensor(0.95), "rays": tensor(28.0), "night": tensor(0.6),
                  "band": tensor(0.12),
                  "line": tensor(0.9), "line_threshold": tensor(0.55)},
                 {"colours": 0.2, "gold": 0.15, "threshold": 0.1, "hue_weight": 0.2, "sun_x": 0.1, "sun_y": 0.1,
                  "rays": 4.0, "night": 0.1, "band": 0.04, "line": 0.2, "line_threshold": 0.1},
                 note="named colours" if colours else "black, navy, jade and cream with gold")


# -- Suprematism: geometric shapes floating on white ------------------------------------------------------
# (centre t, centre s, half height, half width, angle in radians): a large black square, bars, a
# cross-bar, a small circle's stand-in (a small square) and thin lines, tilted, as Malevich set them
SUPREMATIST_SHAPES = ((0.34, 0.36, 0.17, 0.17, 0.12), (0.7, 0.62, 0.045, 0.26, -0.5), (0.2, 0.76, 0.1, 0.05, 0.3),
                      (0.78, 0.22, 0.03, 0.16, 0.25), (0.56, 0.82, 0.012, 0.2, -0.95), (0.5, 0.16, 0.07, 0.025, 0.6),
                      (0.88, 0.58, 0.05, 0.05, 0.0))
# which palette colour each shape takes, in shares of the palette's length (0 darkest .. 1 the ground)
SUPREMATIST_INKS = (0.0, 0.6, 0.3, 0.8, 0.0, 0.6, 0.3)


def floating_shapes(x, p, surface=None):
    """A white ground (the palette's lightest colour) with the image faintly in grey on it (`detail`),
    and flat squares, bars and crosses in the palette's other colours floating over it, tilted; each
    shape's place, size and tilt is a parameter (`shapes`), its colour darkened where the image under
    it is dark (`follow`), so the object still shows through the composition."""
    h, w = x.shape[-2:]
    t, s = unit_coords(h, w, x.device)
    cs = p["colours"].clamp(0, 1)
    k = cs.shape[0]
    ground, inks = cs[-1].view(1, 3, 1, 1), cs[:-1]
    smooth = blur(x, px(x, 0.006))
    lum = luminance(smooth)
    shade = (lum - lum.mean()).clamp(-0.5, 0.5)
    out = ground * (1 + p["detail"].clamp(0, 1) * shade * 1.5)
    sh = p["shapes"]
    for i in range(sh.shape[0]):
        cy, cx, hh, hw, a = sh[i, 0], sh[i, 1], sh[i, 2].abs(), sh[i, 3].abs(), sh[i, 4]
        u = (s - cx) * torch.cos(a) + (t - cy) * torch.sin(a)
        v = -(s - cx) * torch.sin(a) + (t - cy) * torch.cos(a)
        d = torch.maximum(u.abs() - hw, v.abs() - hh)
        cover = torch.sigmoid(-d / 0.002).view(1, 1, h, w)
        ink = inks[min(k - 2, int(round(SUPREMATIST_INKS[i % len(SUPREMATIST_INKS)] * (k - 2))))].view(1, 3, 1, 1)
        ink = ink * (1 + p["follow"].clamp(0, 1) * shade)
        out = out * (1 - cover) + ink * cover
    return out


def floating_shapes_stage(colours=None) -> Stage:
    cs = sorted_palette(colours, SUPREMATISM)
    if luminance(torch.tensor(cs[-1]).view(1, 3, 1, 1)).item() < 0.8:
        cs = list(cs) + [(0.97, 0.96, 0.92)]  # the white canvas the shapes float on
    return Stage("floating_shapes", "medium", floating_shapes,
                 {"colours": tensor(cs), "shapes": tensor(SUPREMATIST_SHAPES), "detail": tensor(0.35),
                  "follow": tensor(0.3)},
                 {"colours": 0.2, "shapes": 0.05, "detail": 0.15, "follow": 0.15},
                 note="named colours" if colours else "black, red, blue, yellow on white")


# -- Kandinsky: circles, arcs and lines --------------------------------------------------------------------
# circles (centre t, centre s, radius): each a disc with rings of the palette inside, a halo around it
KANDINSKY_CIRCLES = ((0.24, 0.72, 0.16), (0.62, 0.26, 0.12), (0.8, 0.72, 0.08), (0.3, 0.2, 0.06), (0.55, 0.56, 0.05))
# straight lines (t0, s0, t1, s1) and arcs (centre t, centre s, radius) in black
KANDINSKY_LINES = ((0.05, 0.1, 0.95, 0.7), (0.15, 0.95, 0.7, 0.05), (0.45, 0.0, 0.4, 1.0), (0.9, 0.3, 0.6, 0.95))
KANDINSKY_ARCS = ((0.7, 0.5, 0.3), (0.1, 0.4, 0.22))


def circles_and_lines(x, p, surface=None):
    """The image in soft washes of the palette (its tones choose the colours) on a light ground, with
    circles of concentric coloured rings and dark halos floating over it, and black straight lines and
    arcs crossing the whole; circles' places and sizes (`circles`), the lines' weight (`line`) and how
    much of the image's wash shows (`wash`) are parameters."""
    h, w = x.shape[-2:]
    t, s = unit_coords(h, w, x.device)
    cs = p["colours"].clamp(0, 1)
    k = cs.shape[0]
    smooth = blur(x, px(x, 0.008))
    tone = ranked_tone(smooth)
    wash = palette_inks(saturate(smooth, 1.4).clamp(0, 1), (1 + tone * (k - 2)) / (k - 1), cs,
                        p["sharpness"], p["hue_weight"])
    a = p["wash"].clamp(0, 1)
    out = cs[-1].view(1, 3, 1, 1) * (1 - a) + wash * a
    out = out * (1 + 0.04 * fixed_noise(h, w, seed=171, share=0.05, device=x.device))
    inks = cs[1:-1] if k > 3 else cs
    m = inks.shape[0]
    circ = p["circles"]
    for i in range(circ.shape[0]):
        cy, cx, rad = circ[i, 0], circ[i, 1], circ[i, 2].abs().clamp_min(0.01)
        r = torch.sqrt((t - cy) ** 2 + (s - cx) ** 2).view(1, 1, h, w)
        halo = torch.sigmoid((rad * 1.25 - r) / 0.01) * 0.6
        out = out * (1 - halo) + cs[0].view(1, 3, 1, 1) * halo
        # rings: the disc cut into three rings, each a different ink (a fixed rotation of the palette)
        for j in range(3):
            outer = rad * (1 - j / 3)
            disc = torch.sigmoid((outer - r) / 0.0025)
            ink = inks[(i * 2 + j) % m].view(1, 3, 1, 1)
            out = out * (1 - disc) + ink * disc
    width = p["line"].clamp(0.0005, 0.02)
    lines = torch.zeros(1, 1, h, w, device=x.device)
    for t0, s0, t1, s1 in KANDINSKY_LINES:
        dt, ds = t1 - t0, s1 - s0
        n = math.hypot(dt, ds)
        d = ((t - t0) * ds - (s - s0) * dt).abs() / n
        lines = torch.maximum(lines, torch.sigmoid((width - d) / 0.0012).view(1, 1, h, w))
    for cy, cx, rad in KANDINSKY_ARCS:
        r = torch.sqrt((t - cy) ** 2 + (s - cx) ** 2)
        arc = torch.sigmoid((width * 0.8 - (r - rad).abs()) / 0.0012) * (t < cy).float()
        lines = torch.maximum(lines, arc.view(1, 1, h, w))
    return out * (1 - lines) + cs[0].view(1, 3, 1, 1) * lines


def circles_and_lines_stage(colours=None) -> Stage:
    cs = sorted_palette(colours, KANDINSKY)
    if luminance(torch.tensor(cs[-1]).view(1, 3, 1, 1)).item() < 0.8:
        cs = list(cs) + [(0.97, 0.95, 0.88)]  # the light ground
    if luminance(torch.tensor(cs[0]).view(1, 3, 1, 1)).item() > 0.15:
        cs = [(0.05, 0.05, 0.05)] + list(cs)  # the black of the lines
    return Stage("circles_and_lines", "medium", circles_and_lines,
                 {"colours": tensor(cs), "circles": tensor(KANDINSKY_CIRCLES), "line": tensor(0.003),
                  "wash": tensor(0.8), "hue_weight": tensor(0.3),
                  "sharpness": tensor(12.0)},
                 {"colours": 0.2, "circles": 0.05, "line": 0.0015, "wash": 0.15, "hue_weight": 0.2, "sharpness": 4.0},
                 note="named colours" if colours else "Kandinsky's blue, violet, red, green, yellow")
