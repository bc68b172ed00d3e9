"""Differentiable image operations the looks are built from: (1,3,H,W) in [0,1], float32, any size.

Sizes are given as a share of the image's longer side, so a look rendered at the working frame and at
the projector's native frame has the same cells, lines and blur in the picture.
"""
from __future__ import annotations

import math

import torch
import torch.nn.functional as F

LUMA = (0.299, 0.587, 0.114)


def px(x: torch.Tensor, share: float, minimum: float = 1.0) -> float:
    """A length given as a share of the longer side, in pixels of x."""
    return max(minimum, share * max(x.shape[-2:]))


def luminance(x: torch.Tensor) -> torch.Tensor:
    w = torch.tensor(LUMA, dtype=x.dtype, device=x.device).view(1, 3, 1, 1)
    return (x * w).sum(1, keepdim=True)


def blur(x: torch.Tensor, sigma: float) -> torch.Tensor:
    """Separable Gaussian blur with reflect padding; sigma in pixels."""
    if sigma < 0.3:
        return x
    radius = max(1, int(math.ceil(2.5 * sigma)))
    radius = min(radius, min(x.shape[-2:]) - 1) if min(x.shape[-2:]) > 1 else 0
    if radius < 1:
        return x
    t = torch.arange(-radius, radius + 1, dtype=x.dtype, device=x.device)
    k = torch.exp(-0.5 * (t / sigma) ** 2)
    k = k / k.sum()
    c = x.shape[1]
    x = F.pad(x, (radius, radius, 0, 0), mode="reflect")
    x = F.conv2d(x, k.view(1, 1, 1, -1).repeat(c, 1, 1, 1), groups=c)
    x = F.pad(x, (0, 0, radius, radius), mode="reflect")
    return F.conv2d(x, k.view(1, 1, -1, 1).repeat(c, 1, 1, 1), groups=c)


def gradient_magnitude(gray: torch.Tensor) -> torch.Tensor:
    """Sobel magnitude of a (1,1,H,W) image (smooth near 0, so it has gradients everywhere)."""
    kx = torch.tensor([[-1.0, 0.0, 1.0], [-2.0, 0.0, 2.0], [-1.0, 0.0, 1.0]], dtype=gray.dtype,
                      device=gray.device) / 8.0
    g = F.pad(gray, (1, 1, 1, 1), mode="replicate")
    gx = F.conv2d(g, kx.view(1, 1, 3, 3))
    gy = F.conv2d(g, kx.t().contiguous().view(1, 1, 3, 3))
    return torch.sqrt(gx * gx + gy * gy + 1e-8)


def normalised_edges(x: torch.Tensor, sigma: float, levels: int = 4) -> torch.Tensor:
    """Line strength about 1 on the image's edges and on its iso-tone contours, in any image.

    Soft images (blurred blobs) have weak, wide gradients: the luminance is also cut into `levels`
    soft steps and the steps' edges are taken, so soft shapes get thin contours too. Both are divided
    by the height of a blurred step of 1/(levels-1) (a constant of sigma), so thresholds do not depend
    on the resolution."""
    lum = blur(luminance(x), sigma)
    stepped = soft_steps(stretched_luminance(lum), levels, 12.0)
    step = (1.0 / (levels - 1)) / (sigma * math.sqrt(2 * math.pi)) / 2
    plain = gradient_magnitude(lum) / (0.6 * step)
    contour = gradient_magnitude(blur(stepped, max(0.5, sigma * 0.5))) / (2 * step)
    return torch.maximum(plain, contour)


def stretched_luminance(x: torch.Tensor, low: float = 0.02, high: float = 0.98) -> torch.Tensor:
    """Luminance mapped so its low/high percentiles (constants) go to 0/1: a ramp uses its whole length."""
    lum = luminance(x)
    flat = lum.detach().flatten()[:: max(1, lum.numel() // 200_000)]
    lo, hi = torch.quantile(flat, low), torch.quantile(flat, high)
    return ((lum - lo) / (hi - lo).clamp_min(0.05)).clamp(0, 1)


def equalised_luminance(x: torch.Tensor, knots: int = 8, share: float = 0.5) -> torch.Tensor:
    """Luminance pushed towards its own histogram's equalisation (piecewise-linear through its quantiles,
    which are constants): a colour ramp or a set of bands then gives each of its colours a fair share of
    the image even when most of it is one tone (the light ground of a pale surface). `share` of
    equalisation, the rest the stretched luminance, so flat areas are not turned into noise."""
    lum = luminance(x)
    flat = lum.detach().flatten()[:: max(1, lum.numel() // 200_000)]
    q = torch.quantile(flat, torch.linspace(0, 1, knots + 1, device=x.device))
    q = q + torch.arange(knots + 1, device=x.device) * 1e-4  # strictly increasing
    eq = sum(((lum - q[i]) / (q[i + 1] - q[i])).clamp(0, 1) for i in range(knots)) / knots
    return share * eq + (1 - share) * stretched_luminance(x)


def saturate(x: torch.Tensor, amount) -> torch.Tensor:
    lum = luminance(x)
    return lum + amount * (x - lum)


def keep_detail(paint: torch.Tensor, own: torch.Tensor, p: dict) -> torch.Tensor:
    """The `detail` share (a parameter) of the image's own colour (`own`: smoothed, or its ramp) kept under
    the paint, so the projected object stays recognisable."""
    d = p["detail"].clamp(0, 1)
    return paint * (1 - d) + d * own


def soft_steps(v: torch.Tensor, levels: int, sharpness) -> torch.Tensor:
    """v in [0,1] -> `levels` flat steps joined by sigmoids (a posterise that has gradients)."""
    edges = (torch.arange(1, levels, dtype=v.dtype, device=v.device) - 0.5) / (levels - 1)
    steps = torch.sigmoid(sharpness * (v.unsqueeze(-1) - edges) * (levels - 1))
    return steps.sum(-1) / (levels - 1)


def band_weights(v: torch.Tensor, bands: int, sharpness) -> torch.Tensor:
    """v (1,1,H,W) in [0,1] -> (1,bands,H,W) soft one-hot of the band v falls in, summing to 1."""
    edges = torch.arange(1, bands, dtype=v.dtype, device=v.device).view(1, -1, 1, 1) / bands
    above = torch.sigmoid(sharpness * (v - edges))  # (1,bands-1,H,W): 1 where v is above edge k
    ones, zeros = torch.ones_like(v), torch.zeros_like(v)
    upper = torch.cat([ones, above], 1)
    lower = torch.cat([above, zeros], 1)
    return upper - lower


def ramp(v: torch.Tensor, colours: torch.Tensor) -> torch.Tensor:
    """v (1,1,H,W) in [0,1] -> colours (K,3) interpolated piecewise-linearly along v (a gradient map)."""
    k = colours.shape[0]
    if k == 1:
        return colours.view(1, 3, 1, 1).expand(1, 3, *v.shape[-2:])
    pos = v * (k - 1)
    centres = torch.arange(k, dtype=v.dtype, device=v.device).view(1, -1, 1, 1)
    w = (1 - (pos - centres).abs()).clamp_min(0)  # (1,K,H,W) hat functions, sum 1
    return torch.einsum("bkhw,kc->bchw", w, colours)


def cell_grid(h: int, w: int, cell: float, offset=(0.0, 0.0), device=None):
    """Distance of each pixel to its cell's centre (in cells) and the cell index maps, for a square grid."""
    ys = (torch.arange(h, dtype=torch.float32, device=device) + 0.5) / cell + offset[0]
    xs = (torch.arange(w, dtype=torch.float32, device=device) + 0.5) / cell + offset[1]
    fy, fx = ys - torch.floor(ys) - 0.5, xs - torch.floor(xs) - 0.5
    dist = torch.sqrt(fy.view(-1, 1) ** 2 + fx.view(1, -1) ** 2)
    return dist, torch.floor(ys).long(), torch.floor(xs).long(), fy, fx


def cell_ids(h: int, w: int, cell: float, offset=(0.0, 0.0), device=None):
    """Each pixel's grid cell as one index (H,W) counted from 0, and the number of cells."""
    _, iy, ix, _, _ = cell_grid(h, w, cell, offset, device)
    iy, ix = iy - iy.min(), ix - ix.min()
    ny, nx = int(iy.max()) + 1, int(ix.max()) + 1
    return iy.view(-1, 1) * nx + ix.view(1, -1), ny * nx


def region_mean(x: torch.Tensor, ids: torch.Tensor, n: int) -> torch.Tensor:
    """Each pixel gets the mean of its region (differentiable: a mean per region)."""
    b, c, h, w = x.shape
    flat = ids.flatten()
    sums = torch.zeros(b, c, n, dtype=x.dtype, device=x.device).index_add(2, flat, x.flatten(2))
    counts = torch.zeros(n, dtype=x.dtype, device=x.device).index_add(0, flat, torch.ones_like(flat, dtype=x.dtype))
    return (sums / counts.clamp_min(1))[:, :, flat].view(b, c, h, w)


def cell_average(x: torch.Tensor, cell: float, offset=(0.0, 0.0)) -> torch.Tensor:
    """Each pixel gets the mean colour of its grid cell (differentiable: mean per cell)."""
    return region_mean(x, *cell_ids(*x.shape[-2:], cell, offset, x.device))


def fixed_noise(h: int, w: int, seed: int, share: float, device=None) -> torch.Tensor:
    """Smooth value noise (1,1,H,W) in about [-1,1] with features of `share` of the longer side; the
    same seed gives the same pattern in the picture at any resolution."""
    g = torch.Generator().manual_seed(seed)
    n = max(2, int(round(1.0 / max(share, 1e-3))))
    gh, gw = max(2, round(n * h / max(h, w))), max(2, round(n * w / max(h, w)))
    coarse = torch.randn(1, 1, gh, gw, generator=g)
    return F.interpolate(coarse, size=(h, w), mode="bicubic", align_corners=True).clamp(-2.5, 2.5).to(device) / 1.5
