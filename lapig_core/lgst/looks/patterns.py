"""Building blocks of the named looks (issue 30): palette inks, Voronoi pieces, stroke fields and tile
coordinates. Patterns are fixed by a seed and given in shares of the image's longer side, so a look
has the same pieces, strokes and tiles at the working frame and at the projector's native frame; the
colours and strengths laid on them are the looks' parameters (theta)."""
from __future__ import annotations

import colorsys
import functools
import math

import torch
import torch.nn.functional as F

from .ops import fixed_noise, luminance
from .palette import ramp_colours

# how far the named looks equalise the image's tones before choosing inks by tone: most, so every
# colour of a palette gets its share even on a surface of nearly one tone
EQUALISE = 0.8
# the typical sizes (PSA's style-retention scales) of the parameters the palette-ink looks share
INK_SCALES = {"colours": 0.2, "sharpness": 4.0, "hue_weight": 0.2, "detail": 0.15}


def ranked_tone(x: torch.Tensor, knots: int = 16, share: float = EQUALISE) -> torch.Tensor:
    """Luminance -> its rank in the image (piecewise linear through its quantiles, constants), mixed
    with the stretched luminance (1 - share) so gradients always flow. Unlike a plain equalisation, a
    tone many pixels share exactly (a blank wall) goes to the middle of its ranks, not to their start."""
    from .ops import stretched_luminance

    lum = luminance(x)
    flat = lum.detach().flatten()[:: max(1, lum.numel() // 200_000)]
    q = torch.quantile(flat, torch.linspace(0, 1, knots + 1, device=x.device))
    v = lum.detach().flatten()
    lo = torch.searchsorted(q, v, right=False)           # first knot >= v
    hi = torch.searchsorted(q, v, right=True)            # first knot > v
    tied = hi - lo >= 2                                   # v equals two knots or more: a run of ties
    i = (hi - 1).clamp(0, knots - 1)
    q0, q1 = q[i], q[(i + 1).clamp(max=knots)]
    base = torch.where(tied, (lo + hi - 1).float() / 2 / knots, i.float() / knots)
    slope = torch.where(tied | (q1 <= q0), torch.zeros_like(v), 1.0 / ((q1 - q0).clamp_min(1e-6) * knots))
    offset = torch.where(tied, torch.zeros_like(v), q0)
    # rank = base + slope * (lum - offset): linear in lum, so the image's gradient flows through it
    rank = (base.view_as(lum) + slope.view_as(lum) * (lum - offset.view_as(lum))).clamp(0, 1)
    return share * rank + (1 - share) * stretched_luminance(x)


def sorted_palette(colours, default) -> list:
    """The named colours dark to light (one colour gets a shade and a tint), or the look's own."""
    return ramp_colours(list(colours) if colours else list(default))


def goldness(c) -> float:
    """How far an RGB colour is from gold (0 gold itself; a palette's colour under 1.2 can stand for gold)."""
    hh, ll, ss = colorsys.rgb_to_hls(*c)
    return abs(hh * 360 - 48) / 60 + (1 - ss) + abs(ll - 0.5)


def palette_inks(colour: torch.Tensor, tone: torch.Tensor, cs: torch.Tensor, sharpness, hue_weight) -> torch.Tensor:
    """Each pixel painted one of the palette's colours (softly: a softmax), chosen by its tone (the
    palette is dark to light, so every colour gets its band of tones) and, with hue_weight, by its
    own colour (a red area stays the palette's red)."""
    k = cs.shape[0]
    pos = torch.linspace(0, 1, k, dtype=tone.dtype, device=tone.device).view(1, k, 1, 1)
    tone_d = ((tone - pos) * max(1, k - 1)) ** 2
    col_d = ((colour.unsqueeze(1) - cs.view(1, k, 3, 1, 1)) ** 2).sum(2) * 4
    hw = hue_weight.clamp(0, 1)
    w = torch.softmax(-sharpness.clamp_min(0.5) * ((1 - hw) * tone_d + hw * col_d), dim=1)
    return torch.einsum("bkhw,kc->bchw", w, cs)


def coords(h: int, w: int, device=None):
    """Pixel centres in shares of the longer side: (ys (H,1), xs (1,W))."""
    side = max(h, w)
    ys = ((torch.arange(h, dtype=torch.float32, device=device) + 0.5) / side).view(-1, 1)
    xs = ((torch.arange(w, dtype=torch.float32, device=device) + 0.5) / side).view(1, -1)
    return ys, xs


def unit_coords(h: int, w: int, device=None):
    """Pixel centres in shares of the image's height (t (H,1), down) and width (s (1,W), across), each 0..1."""
    ys, xs = coords(h, w, device)
    return ys / (h / max(h, w)), xs / (w / max(h, w))


@functools.lru_cache(maxsize=16)
def _voronoi(h: int, w: int, share: float, seed: int):
    side = max(h, w)
    ny, nx = int(math.ceil(h / side / share)) + 1, int(math.ceil(w / side / share)) + 1
    g = torch.Generator().manual_seed(seed)
    jit = 0.12 + 0.76 * torch.rand(ny + 2, nx + 2, 2, generator=g)   # one seed per grid cell, with a border
    ys = ((torch.arange(h, dtype=torch.float32) + 0.5) / side / share).view(-1, 1)
    xs = ((torch.arange(w, dtype=torch.float32) + 0.5) / side / share).view(1, -1)
    iy, ix = torch.floor(ys).long(), torch.floor(xs).long()
    d1 = torch.full((h, w), 1e9)
    d2 = torch.full((h, w), 1e9)
    ids = torch.zeros((h, w), dtype=torch.long)
    oy = torch.zeros((h, w))
    ox = torch.zeros((h, w))
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            cy, cx = (iy + dy).clamp(-1, ny), (ix + dx).clamp(-1, nx)
            j = jit[cy + 1, cx + 1]  # (H,W,2) by broadcasting (H,1) and (1,W)
            sy, sx = cy.float() + j[..., 0], cx.float() + j[..., 1]
            d = torch.sqrt((ys - sy) ** 2 + (xs - sx) ** 2)
            cid = (cy + 1) * (nx + 2) + (cx + 1)
            closer = d < d1
            d2 = torch.where(closer, d1, torch.minimum(d2, d))
            d1 = torch.where(closer, d, d1)
            ids = torch.where(closer, cid.expand(h, w), ids)
            oy = torch.where(closer, (ys - sy).expand(h, w), oy)
            ox = torch.where(closer, (xs - sx).expand(h, w), ox)
    # renumber the pieces present 0..n-1
    keys, ids = torch.unique(ids, return_inverse=True)
    return ids, (d2 - d1) * share, oy * share, ox * share, int(keys.numel()), keys


def voronoi(h: int, w: int, share: float, seed: int, device=None):
    """Irregular pieces about `share` of the longer side across: (piece index (H,W), distance to the
    nearest border between two pieces, offset from the piece's seed (y, x), in shares; piece count; each
    piece's key, the same at any resolution, for per_region)."""
    ids, edge, oy, ox, n, keys = _voronoi(h, w, float(share), int(seed))
    return ids.to(device), edge.to(device), oy.to(device), ox.to(device), n, keys


def region_lots(n: int, seed: int, keys: torch.Tensor | None = None, columns: int = 1) -> torch.Tensor:
    """Fixed uniform random numbers (n, columns) per region; with the regions' keys the same region gets
    the same numbers at any resolution (a generator's first numbers do not depend on how many follow)."""
    g = torch.Generator().manual_seed(seed)
    if keys is None:
        return torch.rand(n, columns, generator=g)
    return torch.rand(int(keys.max()) + 1, columns, generator=g)[keys.cpu()]


def per_region(ids: torch.Tensor, n: int, seed: int, keys: torch.Tensor | None = None) -> torch.Tensor:
    """A fixed random value in [-1, 1] per region, as a map (1,1,H,W)."""
    values = (region_lots(n, seed, keys)[:, 0] * 2 - 1).to(ids.device)
    return values[ids].view(1, 1, *ids.shape)


def directional_noise(h: int, w: int, seed: int, share: float, length: float, device=None) -> torch.Tensor:
    """Short strokes: fine noise smeared along x in some places and along y in others (1,1,H,W),
    about [-1, 1]; `share` is the stroke width, `length` its length (shares of the longer side)."""
    fine = fixed_noise(h, w, seed, share, device)
    side = max(h, w)
    sigma = max(0.5, length * side / 3)
    along_x = _blur_1d(fine, sigma, dim=-1)
    along_y = _blur_1d(fixed_noise(h, w, seed + 1, share, device), sigma, dim=-2)
    choose = torch.sigmoid(fixed_noise(h, w, seed + 2, 0.08, device) * 6)
    field = choose * along_x + (1 - choose) * along_y
    return field / field.abs().mean().clamp_min(1e-4) * 0.5


def _blur_1d(x: torch.Tensor, sigma: float, dim: int) -> torch.Tensor:
    radius = max(1, int(math.ceil(2.5 * sigma)))
    size = x.shape[dim]
    radius = min(radius, size - 1)
    if radius < 1:
        return x
    t = torch.arange(-radius, radius + 1, dtype=x.dtype, device=x.device)
    k = torch.exp(-0.5 * (t / sigma) ** 2)
    k = k / k.sum()
    if dim in (-1, 3):
        return F.conv2d(F.pad(x, (radius, radius, 0, 0), mode="reflect"), k.view(1, 1, 1, -1))
    return F.conv2d(F.pad(x, (0, 0, radius, radius), mode="reflect"), k.view(1, 1, -1, 1))


def veins(h: int, w: int, seed: int, share: float, width: float, device=None) -> torch.Tensor:
    """Thin meandering lines (1,1,H,W) in [0,1]: where a smooth noise crosses zero (cracks, drips)."""
    n = fixed_noise(h, w, seed, share, device)
    # |n| near zero along a line; divide by its local slope so lines keep their width
    gy = n[..., 1:, :] - n[..., :-1, :]
    gx = n[..., :, 1:] - n[..., :, :-1]
    gy = F.pad(gy, (0, 0, 0, 1), mode="replicate")
    gx = F.pad(gx, (0, 1, 0, 0), mode="replicate")
    slope = torch.sqrt(gx * gx + gy * gy) * max(h, w) + 1e-3
    dist = n.abs() / slope  # in shares of the longer side
    return torch.sigmoid((width - dist) / (width * 0.35))


def tile_coords(h: int, w: int, share: float, device=None):
    """Position inside square tiles of `share` (fy, fx in [-0.5, 0.5)) and the tile indices."""
    ys, xs = coords(h, w, device)
    ty, tx = ys / share, xs / share
    return ty - torch.floor(ty) - 0.5, tx - torch.floor(tx) - 0.5, torch.floor(ty).long(), torch.floor(tx).long()
