"""A world composition as a look Stage: the base material through its colour ramp and relief, a second base mixed in
by a ragged mask, the overlays laid where their pattern covers, then the weathering (dirt gathering where the base
is low: joints, cracks, crevices; wet: darker, deeper colour, glints; glow: light of its own).

theta (what PSA moves, each with its typical size): every layer's colour stops, contrast and relief, each overlay's
coverage, the dirt, and an exposure. The scale and the seed are not theta: PSA changes how the look is lit and
coloured, not where its stones are."""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import torch

from ..looks.stage import Stage, tensor
from . import cells, moving, noise
from .catalog import Material
from .moving import Clock
from ...look_parameters import LookParameters
from .compose import Composition
from .patterns import PATTERNS, _smooth, _u01
from .ramps import fire_colours, ramp


def coordinates(h: int, w: int, device=None) -> tuple[torch.Tensor, torch.Tensor]:
    """u, v: pixel centres as shares of the longer side (v downwards)."""
    long_side = float(max(h, w))
    v = (torch.arange(h, dtype=torch.float32, device=device) + 0.5) / long_side
    u = (torch.arange(w, dtype=torch.float32, device=device) + 0.5) / long_side
    return u.view(1, -1).expand(h, w), v.view(-1, 1).expand(h, w)


def stops(material: Material) -> list:
    return fire_colours() if material.ramp == "blackbody" else [list(c) for c in material.colours]


def already_has(material: Material, rgb) -> bool:
    """Whether the material's own ramp holds this colour: a chromatic one within 40 degrees of hue of a saturated
    stop, a grey one within 0.2 of lightness of a stop ("red roses", "blue denim" and "white marble" keep their
    own shades)."""
    import colorsys

    h, l, s = colorsys.rgb_to_hls(*rgb)
    for stop in stops(material):
        sh, sl, ss = colorsys.rgb_to_hls(*stop)
        if s < 0.25 and abs(l - sl) < 0.2 and (ss < 0.35 or l > 0.85):
            return True
        if s >= 0.25 and ss >= 0.25 and min(abs(h - sh), 1 - abs(h - sh)) * 360 < 40 and abs(l - sl) < 0.35:
            return True
    return False


def named_stops(material: Material, colours: list) -> list:
    """The ramp in the prompt's colours: the first named colour at the material's dominant end, the others towards
    the other end, each stop keeping the lightness step of the material's own ramp (the structure stays)."""
    own = torch.tensor(stops(material), dtype=torch.float32)
    n = own.shape[0]
    lum = own @ torch.tensor([0.299, 0.587, 0.114])
    rel = (lum / lum.mean().clamp_min(1e-3)).clamp(0.3, 1.8) ** 0.5
    named = torch.tensor([list(c) for c in colours], dtype=torch.float32)
    if material.dominant == "high":
        named = named.flip(0)  # the first named ends at t = 1
    pos = torch.linspace(0, 1, n) * (named.shape[0] - 1)
    lo = pos.floor().long().clamp(max=named.shape[0] - 1)
    hi = (lo + 1).clamp(max=named.shape[0] - 1)
    f = (pos - lo.float()).unsqueeze(1)
    base = named[lo] * (1 - f) + named[hi] * f
    if named.shape[0] == 1:
        base = base * rel.unsqueeze(1)
    return base.clamp(0, 1).tolist()


def _distorted(u, v, features: float, seed: int, amount: float):
    """The coordinates warped by noise at the pattern's own scale (Blender's Noise Distortion); 0: as they are."""
    if not amount:
        return u, v
    k = max(features * 0.5, 1e-6)
    du = noise.fbm(u * k + 5.3, v * k, seed + 401, 3)
    dv = noise.fbm(u * k, v * k + 9.1, seed + 402, 3)
    return u + amount * 0.5 * du / k, v + amount * 0.5 * dv / k


def _layer(material: Material, u, v, seed: int, scale: float, density: float, p: dict, key: str,
           look: LookParameters | None = None, clock: Clock | None = None):
    look = look or LookParameters()
    density = density + moving.density_offset(material, clock)  # what grows, grows over the loop
    options = dict(material.options)
    if "density" in options or material.pattern in ("leaves", "flowers", "drops", "snowflakes"):
        options["density"] = max(0.1, min(1.0, options.get("density", 0.8) + density))
    if "threshold" in options:  # denser: the pattern's patches grow
        options["threshold"] = options["threshold"] - 0.4 * density
    features = material.scale * scale
    u, v = _distorted(u, v, features, seed, look.distortion)
    detail = options.get("detail", 0.18) * look.detail
    fields = []
    for su, sv, weight in moving.samples(material, u, v, features, seed, clock):  # one, at rest
        f = PATTERNS[material.pattern](su, sv, features, seed, options)
        t = f["t"]
        if detail:  # the material's own fine detail, in its own colours (pores, fibres, grains, flicker)
            fine_scale = max(features * 8, 90.0)
            t = t + detail * noise.fbm(su * fine_scale, sv * fine_scale, seed + 97, 3) * (0.4 + t)
        fields.append((weight, t, f))
    if len(fields) == 1:
        _, t, f = fields[0]
    else:  # a flow's two copies, faded into each other
        t = sum(w * t for w, t, _ in fields)
        f = {k: sum(w * g[k] for w, _, g in fields) for k in ("t", "light", "cover")}
    t = (0.5 + (t - 0.5) * p[f"{key}_contrast"]).clamp(0, 1)
    rgb = ramp(t, p[f"{key}_colours"].clamp(0, 1))
    light = 1 + p[f"{key}_relief"] * (f["light"] - 1)
    sheen = moving.light(material, u, v, seed, clock)
    if sheen is not None:  # light passing over it, or a fire's breath
        light = light * sheen
    return rgb * light, f, t


def hue_saturation(rgb: torch.Tensor, hue_degrees: float, saturation: float) -> torch.Tensor:
    """(3, h, w) turned round the grey axis by `hue_degrees` and its colour scaled by `saturation` about its
    luminance (Blender's Hue/Saturation node, in the look's own values); (0, 1): as it is."""
    if hue_degrees:
        from ...show.motion import hue_rotation

        rgb = torch.einsum("ij,jhw->ihw", hue_rotation(math.radians(hue_degrees), rgb), rgb)
    if saturation != 1.0:
        lum = (rgb * torch.tensor([0.299, 0.587, 0.114], dtype=rgb.dtype, device=rgb.device).view(3, 1, 1)).sum(0)
        rgb = lum + saturation * (rgb - lum)
    return rgb


GROWTH_PATTERNS = ("leaves", "clouds", "reaction", "grass")   # what grows: it starts in joints and crevices
SETTLES_ON_TOPS = ("snow", "snowflakes", "frost")               # what falls and stays on what faces up
RUNS_DOWNHILL = ("rust", "patina", "raindrops", "dust")          # what water carries down the surface


def _smear_downhill(field: torch.Tensor, downhill: torch.Tensor, steps: int = 20, step_px: float | None = None):
    """Each pixel takes the strongest of what lies upstream of it, fading with the distance: streaks that run
    down the surface from where the field is (drips, rust stains), about a sixth of the frame long.
    field (h, w); downhill (h, w, 2) in pixels."""
    h, w = field.shape
    step_px = step_px or max(1.0, max(h, w) / 120.0)
    ys, xs = torch.meshgrid(torch.arange(h, dtype=torch.float32, device=field.device),
                            torch.arange(w, dtype=torch.float32, device=field.device), indexing="ij")
    src = field.view(1, 1, h, w)
    out = field
    for k in range(1, steps + 1):
        x = xs - k * step_px * downhill[..., 0]
        y = ys - k * step_px * downhill[..., 1]
        grid = torch.stack([2 * (x + 0.5) / w - 1, 2 * (y + 0.5) / h - 1], -1).unsqueeze(0)
        up = torch.nn.functional.grid_sample(src, grid, mode="bilinear", padding_mode="border", align_corners=False)
        out = torch.maximum(out, up[0, 0] * (0.93 ** k))
    return out


def _geometry_maps(geometry, h: int, w: int, device):
    from .geometry import look_coordinates, resized

    g = resized(geometry, h, w)
    as_t = lambda a: torch.as_tensor(a, dtype=torch.float32, device=device)  # noqa: E731
    u, v = look_coordinates(geometry, h, w)
    # thin streaks along the downhill direction (about the image's down on walls): fine across, long along
    across = torch.as_tensor(np.abs(g.downhill[..., 1]) > np.abs(g.downhill[..., 0]))
    su, sv = coordinates(h, w)
    a, b = torch.where(across, su, sv), torch.where(across, sv, su)
    streaks = _smooth(0.45, 0.7, _u01(noise.fbm(a * 90, b * 6, 131, 3))).to(device)
    return {"u": u.to(device), "v": v.to(device), "cavity": as_t(g.cavity), "valid": as_t(g.valid),
            "streaks": streaks,
            "up": None if g.up is None else as_t(g.up), "downhill": as_t(g.downhill)}


def shaped_cover(overlay: Material, cover: torch.Tensor, geo: dict) -> torch.Tensor:
    """An overlay's cover shaped by the object: growth gathers in crevices, snow on what faces up, rust and drips
    run downhill."""
    # on a flat wall facing the projector the look stays much as it is without the object
    if overlay.name in SETTLES_ON_TOPS and geo["up"] is not None:
        tops = _smooth(0.15, 0.7, geo["up"])  # tops take it whole, walls keep some where it caught
        cover = cover * (0.6 + 0.4 * tops) + 0.6 * tops * (1 - cover.clamp(0, 1))
    elif overlay.pattern in GROWTH_PATTERNS or overlay.name == "dust":
        cover = cover.clamp(0, 1) * 0.8
        cover = cover + 0.9 * geo["cavity"] * (1 - cover)
    if overlay.name in RUNS_DOWNHILL:  # the stains run below the patches in thin streaks
        cover = cover.clamp(0, 1)
        tail = (_smear_downhill(cover, geo["downhill"]) - cover).clamp_min(0)
        cover = cover + tail * geo["streaks"]
    return cover.clamp(0, 1)


def render(comp: Composition, p: dict, h: int, w: int, seed: int = 0, device=None, geometry=None,
           geo: dict | None = None, look: LookParameters | None = None, clock: Clock | None = None) -> torch.Tensor:
    """The composition at h x w, (1, 3, h, w) in 0..1; shaped by the object where `geometry` (geometry.LookGeometry,
    as the projector sees the object) is given (geo: its maps at this size, made once by the stage).
    look: the sliders (parameters.LookParameters; its scale, density and seed stand for the composition's and
    `seed`); clock: the look's time (moving.Clock; None or t = 0: the still look)."""
    if look is not None:
        comp, seed = replace(comp, scale=look.scale, density=look.density), look.seed
    if geo is None and geometry is not None:
        geo = _geometry_maps(geometry, h, w, device)
    u, v = (geo["u"], geo["v"]) if geo is not None else coordinates(h, w, device)
    out, base_f, base_t = _layer(comp.base, u, v, seed, comp.scale, comp.density, p, "base", look, clock)
    if comp.second is not None:
        second, _, _ = _layer(comp.second, u, v, seed + 7, comp.scale, comp.density, p, "second", look, clock)
        mask = _smooth(0.42, 0.58, _u01(noise.fbm(u * 4, v * 4, seed + 61, 5, gain=0.6)))
        out = out * (1 - mask) + second * mask
    for i, overlay in enumerate(comp.overlays):
        rgb, f, _ = _layer(overlay, u, v, seed + 11 + i, comp.scale, comp.density, p, f"overlay{i}", look, clock)
        cover = f["cover"]
        if comp.base.pattern in ("masonry", "stones", "hex_tiles", "checker", "cracks", "plates") and (
                overlay.pattern in ("leaves", "clouds", "grass") or overlay.name == "rust"):
            # growth follows the joints: what grows on a wall starts in its mortar and spreads from there (lichen
            # grows on the faces of the stones themselves); rust starts at a hull's seams and rivets
            joint = _smooth(0.35, 0.0, base_t)
            cover = (cover * (0.45 + 0.9 * joint)).clamp(0, 1)
        if geo is not None:
            cover = shaped_cover(overlay, cover, geo)
        amount = (cover * p[f"overlay{i}_coverage"]).clamp(0, 1)
        out = out * (1 - amount) + rgb * amount
    grain = comp.base.options.get("grain", 0.35)
    if grain:  # grains, pores and fibres a few pixels across: cells of their own shade, not smooth noise
        # it stays where it is while the look moves: a grain a few pixels across carried by a flow would shimmer
        # from frame to frame at the working frame (cells finer than its pixels)
        fine = cells.worley(u * 150, v * 150, seed + 91, jitter=1.0).cell_id - 0.5
        out = out * (1 + p["grain"] * grain * (look.roughness if look is not None else 1.0) * fine)
    if "dirt" in comp.weathering:
        grime = _u01(noise.fbm(u * 6, v * 6, seed + 71, 5))
        crevice = _smooth(0.4, 0.0, base_t)
        if geo is not None:  # the object's own crevices hold the dirt too
            crevice = torch.maximum(crevice, geo["cavity"])
        out = out * (1 - p["dirt"] * (0.5 * grime + 0.6 * crevice)).clamp(0.2, 1)
    if "wet" in comp.weathering:
        glints = _smooth(0.82, 0.95, _u01(noise.fbm(u * 40, v * 40, seed + 81, 3)))
        # a wet relief shines where it faces the light: the crowns of cobbles, the rims of scales
        glints = torch.maximum(glints, 0.7 * _smooth(1.12, 1.3, base_f["light"]))
        if geo is not None:  # wet glints run down in drips
            glints = _smear_downhill(glints, geo["downhill"], steps=8)
        out = (out.clamp(0, 1) ** 1.35) * 0.85 + 0.5 * glints
    if "glow" in comp.weathering:
        out = out * 1.25 + 0.1 * out ** 2
    if look is not None:
        out = hue_saturation(out, look.hue, look.saturation)
    return (out * p["exposure"]).clamp(0, 1).unsqueeze(0)


class WorldControls:
    """What a world stage draws besides theta, set between renders: the sliders and the look's time."""

    def __init__(self, look: LookParameters, clock: Clock | None = None):
        self.look, self.clock = look, clock


def world_stage(comp: Composition, colours: list | None = None, seed: int = 0, geometry=None,
                look: LookParameters | None = None) -> Stage:
    """The look Stage of a composition (named colours, if any, recolour the base), shaped by the object's
    geometry (geometry.LookGeometry) where it is given; look: its sliders (None: the plan's, with `seed`).
    stage.world (WorldControls) holds the sliders and the clock the stage draws with."""
    controls = WorldControls(look or LookParameters.from_plan(comp, seed))
    params, scales = {}, {}

    def layer(key, material, named=None):
        params[f"{key}_colours"] = tensor(named_stops(material, named) if named else stops(material))
        params[f"{key}_contrast"], params[f"{key}_relief"] = tensor(1.0), tensor(0.6)
        scales.update({f"{key}_colours": 0.2, f"{key}_contrast": 0.3, f"{key}_relief": 0.3})

    # colours the prompt names: a dict {layer index: [rgb]} (0 the base, 1 the second, 2... the overlays), or a
    # list for the base; a material that already holds every one of them keeps its own shades
    per_layer = colours if isinstance(colours, dict) else {0: colours or []}
    layers = comp.materials()
    named = {i: (list(c) if c and not all(already_has(layers[i], rgb) for rgb in c) else None)
             for i, c in per_layer.items() if i < len(layers)}
    colours = named.get(0)
    layer("base", comp.base, colours)
    if comp.second is not None:
        layer("second", comp.second, named.get(1))
    first_overlay = 2 if comp.second is not None else 1
    for i, overlay in enumerate(comp.overlays):
        layer(f"overlay{i}", overlay, named.get(first_overlay + i))
        params[f"overlay{i}_coverage"], scales[f"overlay{i}_coverage"] = tensor(1.0 + comp.density), 0.25
    params["dirt"], scales["dirt"] = tensor(0.5), 0.2
    params["grain"], scales["grain"] = tensor(1.0), 0.3
    params["exposure"], scales["exposure"] = tensor(1.0), 0.2

    maps = {}  # the geometry's maps by size and device: made once, not at every PSA step

    def fn(x, p, surface=None):
        h, w = x.shape[-2:]
        geo = None
        if geometry is not None:
            key = (h, w, str(x.device))
            geo = maps.get(key) or maps.setdefault(key, _geometry_maps(geometry, h, w, x.device))
        return render(comp, p, h, w, seed=seed, device=x.device, geo=geo, look=controls.look, clock=controls.clock)

    note = comp.line() + (f"; shaped by the {geometry.source}" if geometry is not None else "")
    stage = Stage("world", "medium", fn, params, scales, note=note)
    stage.world = controls
    return stage
