"""The scalar fields materials are made of, by name: each takes the coordinates (u, v: shares of the image's longer
side, v downwards), the material's scale (features per longer side), a seed and its options, and gives
  t      0..1, looked up in the material's colour ramp (stop 0 is the joint, crack or gap colour where there is one),
  light  a shading multiplied in (1: none), from the pattern's relief,
  cover  where the material lies when it is laid over another (1: everywhere), soft-edged.
Every field is torch, differentiable in the coordinates."""
from __future__ import annotations

import math

import torch

from . import cells, growth, noise, shapes, tilings


def _smooth(e0, e1, x):
    t = ((x - e0) / (e1 - e0)).clamp(0, 1)
    return t * t * (3 - 2 * t)


def _u01(n):
    return (n * 0.5 + 0.5).clamp(0, 1)


def _out(t, light=None, cover=None):
    return {"t": t.clamp(0, 1), "light": light if light is not None else torch.ones_like(t),
            "cover": cover if cover is not None else torch.ones_like(t)}


def speckle(u, v, s, seed, o):
    """Granite: grains of a few minerals (cells of their own shade) in a mottled ground."""
    c = cells.worley(u * s, v * s, seed, jitter=1.0)
    mottle = _u01(noise.fbm(u * s / 6, v * s / 6, seed + 1, 4))
    fine = _u01(noise.gradient_noise(u * s * 3, v * s * 3, seed + 2))
    return _out(0.55 * c.cell_id + 0.3 * mottle + 0.15 * fine)


def veins(u, v, s, seed, o):
    """Marble: warped bands whose thin crossings are the veins (t 0 on a vein, 1 in the stone)."""
    x, y = noise.warp(u * s, v * s, seed, amount=o.get("warp", 1.6), octaves=5)
    band = torch.sin(2 * math.pi * (x * 0.7 + y * 0.3) * 0.5)
    vein = band.abs() ** o.get("thinness", 0.35)
    cloud = _u01(noise.fbm(u * s * 2, v * s * 2, seed + 3, 4))
    return _out(0.8 * vein + 0.2 * cloud)


def strata(u, v, s, seed, o):
    """Layered rock (sandstone, slate): horizontal bands of shade, bent a little, with grain."""
    x, y = noise.warp(u * s * 0.3, v * s, seed, amount=o.get("warp", 0.5), octaves=3)
    bands = _u01(noise.fbm(y * 1.0, x * 0.05, seed + 4, 4))
    grain = _u01(noise.fbm(u * s * 8, v * s * 8, seed + 5, 3))
    return _out(0.75 * bands + 0.25 * grain)


def stones(u, v, s, seed, o):
    """Cobbles, pebbles, boulders: rounded stones of their own shade, dark gaps between them."""
    c = cells.worley(u * s, v * s, seed, jitter=o.get("jitter", 0.85))
    # the joint's width in cell units, but never wider than a share of the frame: huge boulders keep sharp joints
    gap = min(o.get("gap", 0.12), 0.025 * s)
    # rounded stones: the joint, and the rim of each stone falling away into it (r: 0 at its point, 1 at its border)
    r = c.f1 / (c.f1 + 0.5 * c.edge + 1e-6)
    rim = min(o.get("round", 0.1), 0.04 * s)  # the rim too stays narrow in the frame
    stone = _smooth(gap * 0.5, gap * 1.5, c.edge) * _smooth(1.0, 1.0 - rim, r)
    # the stone's own surface: mottled at its own size, and pitted and weathered at a size of the frame's, so a
    # boulder the frame's size is rough rock, not a smooth blur
    fine = max(s * 3, 30.0)
    mottle = 0.6 * _u01(noise.fbm(u * s * 3, v * s * 3, seed + 6, 4)) + \
        0.4 * _u01(noise.fbm(u * fine, v * fine, seed + 5, 4, gain=0.6))
    t = stone * (0.3 + 0.45 * c.cell_id + 0.25 * mottle)
    # big stones (a few across the frame) show their fissures: thin dark lines where ridged noise crests
    big = min(1.0, max(0.0, (6.0 - s) / 4.0))
    if big > 0:
        f = max(s * 2.5, 7.0)
        fx, fy = noise.warp(u * f, v * f, seed + 3, amount=0.3, octaves=2)
        fissure = _smooth(0.93, 0.99, 1 - noise.fbm(fx, fy, seed + 4, 3, gain=0.45).abs())
        t = t * (1 - 0.6 * big * fissure)
    return _out(t, 0.5 + 0.8 * _dome_light(c) * stone)


LIGHT_FROM = (-0.45, -0.55, 0.7)  # the light a relief is shaded by: from the upper left, in front (x right, y down)


def _dome_light(c) -> torch.Tensor:
    """Lambert's shading 0..1 of each cell drawn as a rounded dome (a stone, a scale, a dent's rim), lit from the
    upper left: r goes from 0 at the cell's point to 1 at its border, the dome's normal leans out along r."""
    r = (c.f1 / (c.f1 + 0.5 * c.edge + 1e-6)).clamp(0, 0.999)
    tilt = r ** 3  # flat-topped: the slope is in the outer rim, so a big stone's shading stays at its edge
    h = torch.sqrt(1 - tilt * tilt)
    d = torch.sqrt(c.to_centre_x ** 2 + c.to_centre_y ** 2 + 1e-9)
    nx, ny = c.to_centre_x / d * tilt, c.to_centre_y / d * tilt
    lx, ly, lz = LIGHT_FROM
    norm = math.sqrt(lx * lx + ly * ly + lz * lz)
    return ((nx * lx + ny * ly + h * lz) / norm).clamp(0, 1)


def cracks(u, v, s, seed, o):
    """Dry earth, crazed ice, lava crust: plates split by thin cracks (t 0 in the crack)."""
    x, y = noise.warp(u * s, v * s, seed, amount=0.25, octaves=3)
    c = cells.worley(x, y, seed, jitter=1.0)
    width = o.get("width", 0.06)
    crack = _smooth(0.0, width, c.edge)
    plate = 0.45 + 0.35 * c.cell_id + 0.2 * _u01(noise.fbm(u * s * 4, v * s * 4, seed + 7, 3))
    t = crack * plate
    if o.get("glow_in_cracks"):
        t = 1 - crack * (1 - plate * 0.32)  # lava: the cracks are the hot end of the ramp, the crust dark red heat
    return _out(t)


def clouds(u, v, s, seed, o):
    """fBm shaped into clouds (or moss, mud, concrete, frost: any mottled field): `threshold` and `softness` make
    billows with sky between, `stretch` draws it out along x."""
    st = o.get("stretch", 1.0)
    x, y = u * s / st, v * s
    if o.get("warp"):
        x, y = noise.warp(x, y, seed, amount=o["warp"], octaves=4)
    n = _u01(noise.fbm(x, y, seed + 8, int(o.get("octaves", 6)), gain=o.get("gain", 0.55)))
    th, soft = o.get("threshold", 0.0), o.get("softness", 1.0)
    t = _smooth(th, th + soft, n) if (th or soft != 1.0) else n
    cover = t if o.get("cover_by_t") else None
    if o.get("sparkle"):  # snow and frost glint: ice crystals catching the light
        t = (t + o["sparkle"] * shapes.stars(u * s * 12, v * s * 12, seed + 5, density=0.3, size=0.09)).clamp(0, 1)
    return _out(t, cover=cover)


def mud(u, v, s, seed, o):
    """Mud: lumpy wet ground (warped fBm as its height, shaded by its slope, clods and grit on it) with puddles in
    its hollows, smooth and dark, shining where they mirror the sky (t 0 the puddle's depth, 1 the drier tops)."""
    x, y = noise.warp(u * s, v * s, seed, amount=o.get("warp", 0.6), octaves=4)

    def height(dx, dy):
        return _u01(noise.fbm(x + dx, y + dy, seed + 8, 5, gain=0.55))

    h = height(0.0, 0.0)
    lx, ly, _ = LIGHT_FROM
    slope = (height(0.04 * lx, 0.04 * ly) - h) / 0.04  # rising towards the light: lit
    clods = cells.worley(u * s * 5, v * s * 5, seed + 2, jitter=1.0)
    lumpy = 0.25 * (_dome_light(clods) - 0.5)
    water = o.get("puddles", 0.42)
    puddle = _smooth(water + 0.03, water - 0.03, h)
    ground = (0.35 + 0.65 * _smooth(water - 0.05, 0.8, h)).clamp(0, 1)
    sky = _u01(noise.fbm(u * 2, v * 2, seed + 9, 3))  # what the still water mirrors
    t = ground * (1 - puddle) + puddle * (0.12 + 0.2 * sky)
    sheen = 0.7 * _smooth(0.2, 0.55, slope)  # mud is wet: the slopes facing the light shine
    light = (1 + 0.9 * slope.clamp(-0.6, 0.6) + lumpy + sheen) * (1 - puddle) + puddle * (0.9 + 0.7 * sky ** 2)
    return _out(t, light)


def drifts(u, v, s, seed, o):
    """Snow: soft drifts (a smooth warped height, its slopes turned from the light in blue shade: t through the
    ramp's cold end), a fine crust, and crystals glinting."""
    x, y = noise.warp(u * s, v * s * 1.6, seed, amount=0.5, octaves=3)

    def height(dx, dy):
        return _u01(noise.fbm(x + dx, y + dy, seed + 8, 4, gain=0.45))

    h = height(0.0, 0.0)
    lx, ly, _ = LIGHT_FROM
    slope = (height(0.05 * lx, 0.05 * ly) - h) / 0.05
    crust = _u01(noise.fbm(u * s * 10, v * s * 10, seed + 3, 3))
    t = 0.72 + 0.9 * slope.clamp(-0.6, 0.4) + 0.12 * (crust - 0.5)
    t = t + o.get("sparkle", 1.0) * shapes.stars(u * s * 14, v * s * 14, seed + 5, density=0.3, size=0.09)
    # over another material it lies thick where it drifted and thin to nothing on the crests between
    return _out(t, cover=_smooth(0.3, 0.48, h))


def turbulent(u, v, s, seed, o):
    """Billows of |noise| (smoke, storm clouds, velvet's sheen)."""
    x, y = noise.warp(u * s, v * s, seed, amount=o.get("warp", 0.6), octaves=3)
    return _out(noise.turbulence(x, y, seed + 9, 6))


def ridges(u, v, s, seed, o):
    """Ridged noise: crests like frost ferns, veins of bark, mountain ranges."""
    st = o.get("stretch", 1.0)
    r = noise.ridged(u * s / st, v * s * (st if o.get("vertical") else 1.0), seed + 10, 6)
    return _out(_smooth(o.get("threshold", 0.3), 1.0, r))


def bark(u, v, s, seed, o):
    """Tree bark: vertical ridges and furrows, broken into plates."""
    x, y = noise.warp(u * s, v * s * 0.25, seed, amount=0.4, octaves=3)
    r = noise.ridged(x, y, seed + 11, 5)
    c = cells.worley(u * s * 0.6, v * s * 0.2, seed + 1, jitter=1.0, stretch_y=0.4)
    furrow = _smooth(0.0, 0.12, c.edge)
    t = (0.7 * r + 0.3 * c.cell_id) * (0.35 + 0.65 * furrow)
    return _out(t, light=0.7 + 0.5 * r)


def woodgrain(u, v, s, seed, o):
    """Wood: growth rings seen along the board (stretched, warped sine of the distance to a far-off pith), in
    planks when `planks` is set."""
    x, y = u * s, v * s
    board = None
    if o.get("planks"):
        board = tilings.planks(x, y, seed, ratio=o.get("ratio", 7.0), gap=0.04)
        x = board["along"] * 2.0 + board["id"] * 13
        y = board["across"] + board["id"] * 7
    wx, wy = noise.warp(x * 0.15, y, seed, amount=0.35, octaves=3)
    rings = torch.sin(2 * math.pi * (wy * o.get("rings", 3.0) + 0.8 * noise.fbm(wx, wy * 0.5, seed + 12, 3)))
    grain = _u01(noise.fbm(x * 0.5, y * 12, seed + 13, 3))
    t = 0.25 + 0.45 * _u01(rings) ** 1.5 + 0.3 * grain
    if board is not None:
        t = (1 - board["joint"]) * (t * (0.8 + 0.4 * board["id"]))
    return _out(t)


def masonry(u, v, s, seed, o):
    """Bricks (or stone blocks) in running bond: stop 0 is the mortar, the others the bricks' own shades."""
    b = tilings.bricks(u * s, v * s, seed, ratio=o.get("ratio", 2.2), mortar=o.get("mortar", 0.08))
    mottle = _u01(noise.fbm(u * s * 3, v * s * 3, seed + 14, 4))
    t = (1 - b["joint"]) * (0.35 + 0.4 * b["id"] + 0.25 * mottle)
    light = 1.0 - 0.18 * (b["shade"] - 0.5)
    return _out(t, light, cover=1 - b["joint"])


def plates(u, v, s, seed, o):
    """Riveted steel plates (a ship's hull, a boiler, a bridge): plates in staggered rows, each a shade of its own
    and mottled, dark seams, and a row of domed rivets inside each long seam (t 0 in the seams)."""
    ratio = o.get("ratio", 3.0)
    b = tilings.bricks(u * s, v * s, seed, ratio=ratio, mortar=o.get("seam", 0.025))
    fx, fy = b["across"], b["shade"]  # 0..1 along and down the plate
    pitch = o.get("rivets", 10.0)  # rivets along a plate's length
    dx = (torch.remainder(fx * pitch, 1.0) - 0.5) / pitch * ratio  # from the nearest rivet, in plate heights
    dy = torch.where(fy < 0.5, fy - 0.09, fy - 0.91)
    r = 0.045
    rivet = torch.sigmoid((r - torch.sqrt(dx * dx + dy * dy + 1e-9)) / 0.01)
    facing = (-(dx * 0.6 + dy * 0.8) / r).clamp(-1, 1)  # the dome lit on its upper left
    mottle = _u01(noise.fbm(u * s * 2, v * s * 2, seed + 14, 4))
    t = (1 - b["joint"]) * (0.4 + 0.3 * b["id"] + 0.3 * mottle) + 0.3 * rivet
    light = (1.0 - 0.12 * fy) * (1 + 1.2 * rivet * facing)  # each plate's lap shades its lower edge
    return _out(t, light)


def hex_tiles(u, v, s, seed, o):
    h = tilings.hexagons(u * s, v * s, seed, grout=o.get("grout", 0.06))
    t = (1 - h["joint"]) * (0.55 + 0.25 * h["id"] + 0.2 * (1 - h["shade"]) * o.get("dome", 0.0))
    light = 1.0 - o.get("dome", 0.0) * 0.5 * h["shade"]
    return _out(t, light)


def checker(u, v, s, seed, o):
    c = tilings.checker(u * s, v * s, seed, grout=o.get("grout", 0.03))
    t = (1 - c["joint"]) * (0.35 + 0.6 * c["id"] + 0.05 * c["jitter"])
    return _out(t)


def weave(u, v, s, seed, o):
    """Basketry, burlap, denim: strips over and under each other (t 0 in the gaps)."""
    w = tilings.weave(u * s, v * s, seed, gap=o.get("gap", 0.1))
    fibre = _u01(noise.fbm(u * s * 6, v * s * 6, seed + 15, 3))
    t = (1 - w["joint"]) * (0.3 + 0.5 * w["shade"] + 0.2 * fibre)
    return _out(t)


def twill(u, v, s, seed, o):
    """Denim: diagonal twill lines of dyed warp over white weft, faded in patches."""
    x, y = u * s, v * s
    lines = _u01(torch.sin(2 * math.pi * (x + y)))
    slub = _u01(noise.fbm(x * 0.05, y * 3, seed + 16, 3))
    fade = _u01(noise.fbm(u * 4, v * 4, seed + 17, 4))
    return _out(0.2 + 0.45 * lines * (0.6 + 0.4 * slub) + 0.35 * fade)


def knit(u, v, s, seed, o):
    """Knitting: columns of V-shaped stitches, each a rounded loop."""
    x, y = u * s, v * s * 1.4
    fx = torch.remainder(x, 1.0) - 0.5
    fy = torch.remainder(y + fx.abs() * 0.8, 1.0)
    loop = torch.sin(math.pi * fy) * torch.cos(math.pi * fx) ** 2
    return _out(0.15 + 0.85 * loop, light=0.6 + 0.6 * loop)


def tartan(u, v, s, seed, o):
    """Tartan: the same sequence of coloured bands across and along, crossed (t picks the band's colour)."""
    def bands(z):
        phase = torch.remainder(z, 1.0)
        return torch.floor(phase * 6) / 5  # six bands a repeat, each one stop of the ramp
    a, b = bands(u * s), bands(v * s)
    diagonal = torch.remainder(torch.floor((u + v) * s * 16), 2)  # the twill shows where they cross
    return _out(torch.where(diagonal > 0, a, b))


def circuit(u, v, s, seed, o):
    c = tilings.circuit(u * s, v * s, seed)
    sub = _u01(noise.fbm(u * s * 0.5, v * s * 0.5, seed + 18, 3))
    t = 0.1 + 0.15 * sub + 0.75 * c["joint"] * (0.8 + 0.2 * c["pad"])
    return _out(t)


def scales(u, v, s, seed, o):
    c = tilings.scales(u * s, v * s, seed)
    t = 0.15 + 0.55 * (1 - c["shade"]) + 0.3 * c["id"]
    return _out((1 - c["joint"]) * t, light=0.7 + 0.5 * (1 - c["shade"]))


def hammered(u, v, s, seed, o):
    """Hammered metal: overlapping round dents, each catching the light on one side."""
    c = cells.worley(u * s, v * s, seed, jitter=0.8)
    light = 0.8 + 0.45 * (-c.to_centre_x - c.to_centre_y).clamp(-1, 1)
    return _out(0.45 + 0.35 * c.cell_id + 0.2 * (1 - c.f1.clamp(0, 1)), light)


def brushed(u, v, s, seed, o):
    """Brushed steel: fine streaks along x, a soft sheen across."""
    streak = _u01(noise.fbm(u * s * 0.03, v * s * 3, seed + 19, 4))
    sheen = _u01(noise.fbm(u * 2, v * 1, seed + 20, 2))
    return _out(0.55 * streak + 0.45 * sheen)


def corrugated(u, v, s, seed, o):
    wave = torch.sin(2 * math.pi * u * s)
    dirt = _u01(noise.fbm(u * s * 0.5, v * s * 0.5, seed + 21, 4))
    return _out(0.35 + 0.35 * _u01(wave) + 0.3 * dirt, light=0.75 + 0.35 * torch.cos(2 * math.pi * u * s))


def patches(u, v, s, seed, o):
    """Rust, patina, peeling paint, tarnish: patches of one colour over another, ragged at the rims
    (t near 0: the base metal or paint, near 1: the patch)."""
    n = _u01(noise.fbm(u * s, v * s, seed + 22, 6, gain=0.6))
    th = o.get("threshold", 0.45)
    t = _smooth(th - 0.06, th + 0.06, n) * 0.7 + 0.3 * _u01(noise.fbm(u * s * 6, v * s * 6, seed + 23, 3))
    return _out(t, cover=_smooth(th - 0.06, th + 0.06, n))


def chainmail(u, v, s, seed, o):
    x, y = u * s, v * s
    best = None
    for ox, oy in ((0.0, 0.0), (0.5, 0.5)):
        fx, fy = torch.remainder(x + ox, 1.0) - 0.5, torch.remainder(y + oy, 1.0) - 0.5
        d = (torch.sqrt(fx * fx + fy * fy + 1e-9) - 0.38).abs()
        best = d if best is None else torch.minimum(best, d)
    ring = torch.sigmoid((0.09 - best) / 0.02)
    return _out(0.1 + 0.9 * ring, light=0.6 + 0.6 * ring)


def leaves(u, v, s, seed, o):
    """Leaves scattered thick (ivy, foliage, autumn leaves, a canopy): t 0 in the shade between them."""
    sc = shapes.scatter(u * s, v * s, o.get("shape", "leaf"), seed, density=o.get("density", 0.9),
                        size=o.get("size", 1.1), turn=o.get("turn", 1.0))
    vein = _u01(noise.gradient_noise(u * s * 6, v * s * 6, seed + 24))
    t = sc["coverage"] * (0.3 + 0.4 * sc["id"] + 0.2 * sc["depth"] + 0.1 * vein)
    return _out(t, cover=sc["coverage"])


def flowers(u, v, s, seed, o):
    """Blossoms (cherry, roses, sunflowers): petals of the flower's colour, a darker heart; t 0 between them."""
    sc = shapes.scatter(u * s, v * s, "flower", seed, density=o.get("density", 0.8), size=o.get("size", 1.0))
    heart = _smooth(0.55, 0.9, sc["depth"]) * o.get("heart", 1.0)
    t = sc["coverage"] * (0.55 + 0.35 * sc["id"]) * (1 - 0.6 * heart) + heart * 0.05
    return _out(t, cover=sc["coverage"])


def drops(u, v, s, seed, o):
    """Drops or bubbles on a pane: each lens bright at its top rim, dark at its foot."""
    sc = shapes.scatter(u * s, v * s, o.get("shape", "drop"), seed, density=o.get("density", 0.55),
                        size=o.get("size", 0.7), turn=0.05)
    ground = _u01(noise.fbm(u * 3, v * 3, seed + 25, 3)) * 0.5
    rim = sc["coverage"] * (1 - sc["depth"]) ** 2
    t = (1 - sc["coverage"]) * ground + sc["coverage"] * (0.25 + 0.75 * rim)
    return _out(t, cover=sc["coverage"])


def snowflakes(u, v, s, seed, o):
    sc = shapes.scatter(u * s, v * s, "snowflake", seed, density=o.get("density", 0.7), size=1.0)
    ground = _u01(noise.fbm(u * 4, v * 4, seed + 26, 4)) * 0.4
    return _out(torch.maximum(ground, sc["coverage"]), cover=sc["coverage"])


def grass(u, v, s, seed, o):
    """Blades of grass: thin vertical streaks of many greens, darker at the roots between them."""
    x, y = noise.warp(u * s, v * s * 0.12, seed, amount=0.15, octaves=2)
    blade = _u01(noise.fbm(x, y, seed + 27, 4, lacunarity=2.3))
    clump = _u01(noise.fbm(u * s * 0.15, v * s * 0.15, seed + 28, 3))
    t = _smooth(0.25, 0.85, blade) * (0.6 + 0.4 * clump)
    return _out(t, cover=_smooth(0.3, 0.6, blade))


def dunes(u, v, s, seed, o):
    """Sand dunes: long warped ridges, sunlit on one face and shaded on the other, ripples on top."""
    x, y = noise.warp(u * s, v * s, seed, amount=0.4, octaves=3)
    phase = torch.remainder(y * 0.5 + 0.3 * x * 0.5, 1.0)
    face = torch.where(phase < 0.7, phase / 0.7, (1 - phase) / 0.3)  # a long gentle face, a short steep one
    ripples = _u01(torch.sin(2 * math.pi * (y * 6 + noise.fbm(x * 2, y * 2, seed + 29, 2))))
    light = torch.where(phase < 0.7, torch.full_like(phase, 1.1), torch.full_like(phase, 0.65))
    return _out(0.5 * face + 0.3 * ripples + 0.2, light)


def rosettes(u, v, s, seed, o):
    """Leopard: rings of dark spots round a darker-gold heart, on a golden coat (t 0 on the spots)."""
    c = cells.worley(u * s, v * s, seed, jitter=0.9)
    x, y = noise.warp(u * s, v * s, seed + 2, amount=0.2, octaves=2)
    ring = torch.sigmoid((0.12 - (c.f1 - 0.33).abs()) / 0.03)
    broken = _smooth(0.35, 0.6, _u01(noise.gradient_noise(x * 3, y * 3, seed + 30)))
    spot = ring * broken
    heart = _smooth(0.3, 0.1, c.f1)
    coat = 0.75 + 0.25 * _u01(noise.fbm(u * s * 2, v * s * 2, seed + 31, 3))
    return _out((1 - spot) * coat * (1 - 0.25 * heart))


def stripes(u, v, s, seed, o):
    """Zebra and tiger: warped bands, sharp-edged (t 0 on the stripe)."""
    x, y = noise.warp(u * s, v * s, seed, amount=o.get("warp", 0.8), octaves=4)
    band = torch.sin(2 * math.pi * (x * o.get("tilt", 1.0) + y * 0.15) * 0.5)
    return _out(_smooth(-o.get("width", 0.1), o.get("width", 0.1) + 0.15, band) * 0.85 + 0.15)


def eyes(u, v, s, seed, o):
    """Peacock feathers: concentric rings round eye spots (the ramp runs from the eye out), barbs between."""
    c = cells.worley(u * s, v * s * 0.8, seed, jitter=0.5)
    barbs = _u01(torch.sin(2 * math.pi * (u * s * 10 + 2 * noise.fbm(u * s, v * s, seed + 32, 2))))
    t = (c.f1 * 1.5).clamp(0, 1) * 0.85 + 0.15 * barbs
    return _out(t)


def honeycomb(u, v, s, seed, o):
    h = tilings.hexagons(u * s, v * s, seed, grout=0.09)
    fill = 0.5 + 0.4 * (1 - h["shade"]) + 0.1 * h["id"]
    return _out((1 - h["joint"]) * fill, light=1.0 - 0.3 * h["shade"])


def craters(u, v, s, seed, o):
    """The moon: craters of many sizes (bright rims, dark floors) on grey regolith."""
    t = 0.5 + 0.2 * noise.fbm(u * s * 2, v * s * 2, seed + 33, 5)
    for k, scale in enumerate((1.0, 2.3, 5.0)):
        c = cells.worley(u * s * scale, v * s * scale, seed + 40 + k, jitter=0.9)
        r = 0.18 + 0.2 * c.cell_id
        rim = torch.sigmoid((0.05 - (c.f1 - r).abs()) / 0.02) * (c.cell_id > 0.4).float()
        floor = torch.sigmoid((r - c.f1) / 0.03) * (c.cell_id > 0.4).float()
        t = t + 0.25 * rim - 0.15 * floor
    return _out(t)


def flames(u, v, s, seed, o):
    """Flames: tongues rising from the bottom of the frame, each reaching its own height (a wave warped by noise
    across, torn by turbulence rising), hottest at their base and cooling to their tips, a faint glow above them
    and the dark beyond; sparks carried up. t is the temperature through the ramp. height: the share of the frame
    the tallest tongues reach."""
    reach_share = o.get("height", 1.0)
    x, y = u * s, v * s
    up = 1 - v / v.max().clamp_min(1e-6)  # 0 at the bottom of the frame, 1 at the top
    wx = x + 0.5 * noise.fbm(x * 0.8, y * 0.6 - 2.0, seed + 35, 3)
    along = noise.fbm(wx * 0.7, torch.full_like(y, 1.3), seed + 36, 3)  # noise across the frame only
    wave = _u01(torch.sin(2 * math.pi * wx * 0.35)) * 0.6 + _u01(along) * 0.4
    reach = (0.3 + 0.6 * wave) * reach_share
    rise = noise.turbulence(x * 1.2, y * 0.5 + 3.0, seed + 34, 6)
    inside = (reach - up) / reach.clamp_min(1e-3) - 0.35 * (rise - 0.4)  # 1 at the base, 0 at a tongue's tip
    flame = inside.clamp(0, 1) ** o.get("gamma", 0.7)
    glow = 0.3 * torch.exp(-((up - reach).clamp_min(0) / (0.12 * reach_share)))  # the air lit above them
    t = torch.maximum(flame, glow * (1 - 0.5 * rise))
    sparks = shapes.stars(u * s * 9, (v + 0.3 * u) * s * 9, seed + 3, density=0.12, size=0.1) * up.clamp(0, 1)
    return _out((t + 0.8 * sparks * (1 - flame)).clamp(0, 1))


def embers(u, v, s, seed, o):
    c = cells.worley(u * s, v * s, seed, jitter=1.0)
    glow = torch.exp(-(c.f1 / (0.2 + 0.2 * c.cell_id)) ** 2) * (0.4 + 0.6 * c.cell_id)
    ash = 0.12 * _u01(noise.fbm(u * s * 0.5, v * s * 0.5, seed + 36, 4))
    return _out((glow + ash).clamp(0, 1))


def candle(u, v, s, seed, o):
    """A warm glow round a few flames low in the frame, flickering."""
    x, y = u - u.mean(), v - v.max() * 0.62
    r = torch.sqrt(x * x * 1.5 + y * y + 1e-9)
    flicker = 0.15 * noise.fbm(u * s, v * s, seed + 37, 4)
    return _out((1.0 - r * 1.6 + flicker).clamp(0, 1) ** 1.4)


def stars(u, v, s, seed, o):
    """A night sky: stars of many brightnesses, a faint band of the Milky Way."""
    light = shapes.stars(u * s, v * s, seed, density=o.get("density", 0.2))
    light = light + shapes.stars(u * s * 3, v * s * 3, seed + 1, density=o.get("faint", 0.25), size=0.08) * 0.5
    band = torch.exp(-((v - 0.35 - 0.6 * u * 0.3 - 0.05 * noise.fbm(u * 4, v * 4, seed + 38, 4)) / 0.12) ** 2)
    haze = band * _u01(noise.fbm(u * 8, v * 8, seed + 39, 5)) * o.get("milky_way", 0.35)
    return _out((0.08 + haze + light).clamp(0, 1))


def nebula(u, v, s, seed, o):
    x, y = noise.warp(u * s, v * s, seed, amount=1.2, octaves=5)
    gas = _u01(noise.fbm(x, y, seed + 40, 6, gain=0.6))
    dust = _smooth(0.45, 0.75, _u01(noise.fbm(x * 2, y * 2, seed + 41, 5)))
    star = shapes.stars(u * s * 6, v * s * 6, seed + 2, density=0.2)
    return _out((gas ** 1.6 * (1 - 0.6 * dust) + star).clamp(0, 1))


def galaxy(u, v, s, seed, o):
    """A spiral galaxy: two logarithmic arms of stars and dust round a bright core."""
    cx, cy = u - u.mean(), v - v.mean()
    r = torch.sqrt(cx * cx + cy * cy + 1e-9) * 2.2
    theta = torch.atan2(cy, cx)
    arms = torch.cos(2 * (theta - 2.6 * torch.log(r + 0.05)) + 0.6 * noise.fbm(u * s, v * s, seed + 42, 4))
    arm = _u01(arms) ** 3 * torch.exp(-r * 1.8)
    core = torch.exp(-(r / 0.12) ** 2)
    star = shapes.stars(u * s * 5, v * s * 5, seed + 3, density=0.18)
    return _out((0.04 + 0.9 * arm + core + star * 0.8).clamp(0, 1))


def aurora(u, v, s, seed, o):
    """The northern lights: curtains of light hanging over a dark sky, rippling sideways."""
    wave = 0.35 + 0.12 * noise.fbm(u * 2.5, torch.zeros_like(u) + 0.5, seed + 43, 3)
    curtain = torch.exp(-((v - wave) / 0.13) ** 2) * (v < wave + 0.05).float() + \
        torch.exp(-((v - wave) / 0.35) ** 2) * 0.5
    rays = _u01(noise.fbm(u * s * 2, v * 0.5, seed + 44, 3)) ** 2
    star = shapes.stars(u * s * 4, v * s * 4, seed + 4, density=0.1) * 0.5
    return _out((0.03 + curtain * (0.4 + 0.6 * rays) + star).clamp(0, 1))


def waves(u, v, s, seed, o):
    """The sea: rows of warped waves, dark in their troughs, foam on their crests."""
    x, y = noise.warp(u * s, v * s, seed, amount=0.7, octaves=4)
    phase = torch.sin(2 * math.pi * (y + 0.15 * x) * 0.5)
    foam = _smooth(0.8, 0.98, phase) * _u01(noise.fbm(x * 3, y * 3, seed + 45, 3))
    t = 0.15 + 0.55 * _u01(phase) + 0.3 * foam
    return _out(t, light=0.85 + 0.3 * _u01(phase))


def caustics(u, v, s, seed, o):
    """Light on the floor of a pool: a net of bright lines, the warped borders of cells (t 1 on the lines)."""
    x, y = noise.warp(u * s, v * s, seed, amount=0.45, octaves=3)
    c = cells.worley(x, y, seed, jitter=1.0)
    lines = torch.exp(-(c.edge / 0.07) ** 2)
    return _out(0.35 + 0.65 * lines)


def ripples(u, v, s, seed, o):
    """Rings spreading on a pond from a few points, interfering, over the water's own colour."""
    total = torch.zeros_like(u)
    g = torch.Generator().manual_seed(seed + 46)
    for _ in range(4):
        px, py = float(torch.rand(1, generator=g)) * float(u.max()), float(torch.rand(1, generator=g)) * float(v.max())
        r = torch.sqrt((u - px) ** 2 + (v - py) ** 2 + 1e-9)
        total = total + torch.sin(2 * math.pi * r * s) * torch.exp(-r * 3)
    return _out(_u01(total * 0.8) * 0.7 + 0.3 * _u01(noise.fbm(u * 3, v * 3, seed + 47, 3)))


def underwater(u, v, s, seed, o):
    """Deep water: light from above fading down, shafts of it, a faint net of caustics."""
    depth = (v / v.max().clamp_min(1e-6))
    shafts = _u01(noise.fbm(u * 6 + v * 1.5, v * 0.3, seed + 48, 3)) ** 3
    c = cells.worley(*noise.warp(u * s, v * s, seed, amount=0.4, octaves=2), seed, jitter=1.0)
    net = torch.exp(-(c.edge / 0.06) ** 2) * (1 - depth)
    return _out((0.6 * (1 - depth) + 0.25 * shafts + 0.3 * net).clamp(0, 1))


def falls(u, v, s, seed, o):
    """A waterfall: white streaks falling, spray at the foot."""
    x, y = u * s, v * s * 0.06
    streak = _u01(noise.fbm(x, y, seed + 49, 5, lacunarity=2.2))
    spray = _smooth(0.7, 1.0, v / v.max().clamp_min(1e-6)) * _u01(noise.fbm(u * s * 2, v * s * 2, seed + 50, 4))
    return _out((0.45 * streak + 0.3 + 0.4 * spray).clamp(0, 1))


def reaction(u, v, s, seed, o):
    """Reaction-diffusion: lichen's spots, coral's mazes, holes (t 1 on the grown pattern)."""
    pattern = growth.reaction_diffusion(u * s / 6, v * s / 6, o.get("kind", "spots"), seed)
    th = o.get("threshold", 0.3)  # lower: the growth covers more than its spots
    cover = _smooth(th, th + 0.3, pattern)
    if o.get("colonies"):  # lichen grows in colonies: ragged patches filled with its spots
        c = o["colonies"]
        patch = _smooth(0.62 - 0.3 * c, 0.78 - 0.3 * c, _u01(noise.fbm(u * s / 3, v * s / 3, seed + 33, 5)))
        cover = torch.maximum(cover, patch)
        pattern = torch.maximum(pattern, patch * (0.6 + 0.4 * pattern))
    return _out(pattern, cover=cover)


def cave_art(u, v, s, seed, o):
    """Cave paintings: bison and horses in red and yellow ochre, outlined in charcoal, hand stencils blown round in
    ochre, and rows of dots, on rough limestone, worn away in places (t 0..0.5 the rock, above it the ochre)."""
    rock = 0.12 + 0.38 * _u01(noise.fbm(u * s * 2, v * s * 2, seed + 51, 6, gain=0.6))
    beasts = shapes.scatter(u * s * 0.8, v * s * 0.8, "beast", seed + 5, density=o.get("density", 0.7), size=1.0,
                            turn=0.08, softness=0.02)
    hands = shapes.scatter(u * s * 1.6, v * s * 1.6 + 0.5, "hand", seed + 6, density=0.25, size=0.8, turn=0.15,
                           softness=0.03)
    spray = shapes.scatter(u * s * 1.6, v * s * 1.6 + 0.5, "disc", seed + 6, density=0.25, size=1.1, turn=0.0,
                           softness=0.12)["coverage"] * (1 - hands["coverage"])  # the ochre blown round the hand
    dots = shapes.scatter(u * s * 9, v * s * 9, "disc", seed + 7, density=0.18, size=0.35, softness=0.08)["coverage"]
    worn = _smooth(0.22, 0.42, _u01(noise.fbm(u * s * 6, v * s * 6, seed + 52, 4)))
    body = beasts["coverage"]
    outline = body * (1 - _smooth(0.0, 0.25, beasts["depth"]))  # the charcoal line round each animal
    paint = torch.maximum(torch.maximum(body, 0.85 * spray), 0.9 * dots) * worn
    ochre = 0.78 + 0.22 * torch.where(body > 0.5, beasts["id"], torch.full_like(body, 0.3))  # red to yellow
    t = rock * (1 - paint) + paint * ochre
    light = 1 - 0.8 * outline * worn
    return _out(t, light)


PATTERNS = {f.__name__: f for f in (speckle, veins, strata, stones, cracks, clouds, mud, drifts, turbulent, ridges, bark, woodgrain,
                                    masonry, plates, hex_tiles, checker, weave, twill, knit, tartan, circuit, scales, hammered,
                                    brushed, corrugated, patches, chainmail, leaves, flowers, drops, snowflakes, grass,
                                    dunes, rosettes, stripes, eyes, honeycomb, craters, flames, embers, candle, stars,
                                    nebula, galaxy, aurora, waves, caustics, ripples, underwater, falls, reaction,
                                    cave_art)}
