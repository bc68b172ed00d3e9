"""Image quality metrics: PSNR, RMSE, SSIM (numpy or torch inputs), sharpness.

Layout convention: numpy arrays are channel-last ((H,W), (H,W,C), (N,H,W,C)),
as produced by OpenCV/imageio; torch tensors are channel-first ((C,H,W) or
(N,C,H,W)). Values are floats in [0, 1]; uint8 inputs are divided by 255.
All metrics are averaged over every pixel, channel and image, computed in float64.

SSIM: Gaussian window 11x11, sigma 1.5, per channel, C1=(0.01)^2, C2=(0.03)^2,
mean of the SSIM map over the *valid* region (no padding), i.e. the same
definition as pytorch-msssim's `ssim` (used by losses.py). Note that the
original CompenNeSt++ evaluation code zero-pads ("same" convolution), which
gives slightly different (border-affected) values.
"""
import math

import numpy as np
import torch
from torch.nn import functional as F

from .psnr import masked_psnr as masked_psnr_numpy, psnr_from_mse

SSIM_WIN_SIZE = 11
SSIM_SIGMA = 1.5
SSIM_K = (0.01, 0.03)


def to_nchw(img) -> torch.Tensor:
    """numpy (channel-last) or torch (channel-first) image(s) -> float64 NCHW tensor."""
    if isinstance(img, torch.Tensor):
        t = img.detach()
        if t.dim() == 2:
            t = t[None, None]
        elif t.dim() == 3:
            t = t[None]
    else:
        a = np.asarray(img)
        if a.ndim == 2:
            a = a[..., None]
        if a.ndim == 3:
            a = a[None]
        t = torch.from_numpy(np.ascontiguousarray(a)).permute(0, 3, 1, 2)
    if t.dim() != 4:
        raise ValueError(f"expected 2-4 dimensional image(s), got shape {tuple(t.shape)}")
    scale = 255.0 if t.dtype == torch.uint8 else 1.0
    return t.to(torch.float64) / scale


def _pair(pred, target):
    p, t = to_nchw(pred), to_nchw(target)
    if p.shape != t.shape:
        raise ValueError(f"shape mismatch: {tuple(p.shape)} vs {tuple(t.shape)}")
    return p, t.to(p.device)


def gaussian_window(size: int = SSIM_WIN_SIZE, sigma: float = SSIM_SIGMA, dtype=torch.float64,
                    device=None) -> torch.Tensor:
    """Normalised 1-D Gaussian (the 2-D window is its outer product)."""
    c = torch.arange(size, dtype=dtype, device=device) - size // 2
    g = torch.exp(-(c ** 2) / (2 * sigma ** 2))
    return g / g.sum()


def ssim_torch(x: torch.Tensor, y: torch.Tensor, data_range: float = 1.0,
               win_size: int = SSIM_WIN_SIZE, sigma: float = SSIM_SIGMA, k=SSIM_K,
               reduce: bool = True) -> torch.Tensor:
    """Differentiable mean SSIM of NCHW tensors (valid region), in the input dtype; reduce=False: the
    SSIM map itself (N, C, H - win_size + 1, W - win_size + 1)."""
    n, c, h, w = x.shape
    if min(h, w) < win_size:
        raise ValueError(f"SSIM needs images at least {win_size}px, got {h}x{w}")
    g = gaussian_window(win_size, sigma, x.dtype, x.device)
    gh = g.view(1, 1, 1, -1).repeat(c, 1, 1, 1)  # separable: rows then columns
    gv = g.view(1, 1, -1, 1).repeat(c, 1, 1, 1)

    def blur(z):
        return F.conv2d(F.conv2d(z, gh, groups=c), gv, groups=c)

    c1, c2 = (k[0] * data_range) ** 2, (k[1] * data_range) ** 2
    mx, my = blur(x), blur(y)
    sxx = blur(x * x) - mx * mx
    syy = blur(y * y) - my * my
    sxy = blur(x * y) - mx * my
    smap = ((2 * mx * my + c1) * (2 * sxy + c2)) / ((mx * mx + my * my + c1) * (sxx + syy + c2))
    return smap.mean() if reduce else smap


def mse(pred, target) -> float:
    p, t = _pair(pred, target)
    return float(((p - t) ** 2).mean())


def psnr(pred, target) -> float:
    """10 log10(1 / MSE) for data range 1; inf for identical images."""
    return psnr_from_mse(mse(pred, target))


def rmse(pred, target) -> float:
    """sqrt(C * MSE): the RMS over pixels of the per-pixel colour (RGB) Euclidean error."""
    p, t = _pair(pred, target)
    return math.sqrt(p.shape[1] * float(((p - t) ** 2).mean()))


def ssim(pred, target) -> float:
    p, t = _pair(pred, target)
    return float(ssim_torch(p, t))


def evaluate(pred, target) -> dict:
    """All three metrics at once, as plain floats."""
    return {"psnr": psnr(pred, target), "rmse": rmse(pred, target), "ssim": ssim(pred, target)}


def masked_psnr(pred, target, mask) -> float:
    """PSNR over the pixels where mask is true: (H, W), the part of the frame the projector can change,
    the same for every image; or (N, H, W), a mask per image.

    Full-frame figures include pixels that are black in every image (off the object), which
    inflates them; this one does not.
    """
    p, t = (x.permute(0, 2, 3, 1).cpu().numpy() for x in _pair(pred, target))
    return masked_psnr_numpy(p, t, mask)


def masked_ssim(pred, target, mask) -> float:
    """Mean SSIM over the windows centred on pixels where mask (H, W) is true."""
    p, t = _pair(pred, target)
    smap = ssim_torch(p, t, reduce=False)
    half = SSIM_WIN_SIZE // 2
    m = torch.as_tensor(np.asarray(mask, bool))[half:half + smap.shape[-2], half:half + smap.shape[-1]]
    return float(smap.mean(dim=1)[:, m].mean()) if m.any() else math.nan


def evaluate_on(pred, target, mask) -> dict:
    """evaluate() over the pixels where mask (H, W) is true (the object, where the frame misses part
    of it): off the object a capture is dark whatever the projector image, so counting those pixels
    measures the frame's shape, not the compensation. PSNR and RMSE count the masked pixels; SSIM the
    11x11 windows centred on them (so within 5 px of the outline a window still sees some of the
    frame around the object)."""
    p, t = _pair(pred, target)
    m = torch.as_tensor(np.asarray(mask, bool))
    err = float(((p - t) ** 2).mean(dim=1)[:, m].mean()) if m.any() else math.nan
    return {"psnr": psnr_from_mse(err), "rmse": math.sqrt(p.shape[1] * err),
            "ssim": masked_ssim(pred, target, mask)}


def sharpness(img, mask=None, sigma: float = 0.0) -> float:
    """High-frequency energy: the variance of the Laplacian of the luminance, over the pixels where
    mask (H, W) is true (all by default). One (H, W, 3) numpy image in [0, 1]. sigma > 0 first
    blurs by a Gaussian of that many pixels, so a camera's sensor noise does not count as detail."""
    import cv2

    lum = np.asarray(img, np.float64)
    lum = lum.mean(axis=-1) if lum.ndim == 3 else lum
    if sigma > 0:
        lum = cv2.GaussianBlur(lum, (0, 0), sigma)
    lap = cv2.Laplacian(lum, cv2.CV_64F)
    if mask is not None:
        lap = lap[np.asarray(mask, bool)]
    return float(lap.var()) if lap.size else math.nan


# Style retention that separates style from what a surface forbids (issue 13). SSIM's luminance and
# contrast terms pay for any darkening; a dark surface *needs* a darker look. So the look is compared
# after dividing it by its own local mean brightness (a Weber image: darkening by a factor leaves it
# as it was), and only SSIM's contrast-structure term is kept, on luminance (strokes, edges, relative
# lightness) and on two opponent colour channels (hue relations). A uniform tint or a lower
# saturation moves the opponent channels' means, not their local pattern, so they are nearly free;
# scrambling, blurring away or flattening the pattern is not.
STRUCTURE_WEIGHTS = (0.6, 0.2, 0.2)  # luminance, red-green, yellow-blue
STRUCTURE_EPS = 4.0 / 255  # brightness floor of the Weber division: below it is sensor noise
STRUCTURE_C = 0.03 ** 2 / 4  # stabiliser of the relative (Weber) statistics, as SSIM's C2 / 4


def opponent_channels(x: torch.Tensor) -> torch.Tensor:
    """NCHW RGB -> N3HW luminance, red-green, yellow-blue (linear, so gradients pass)."""
    r, g, b = x[:, 0:1], x[:, 1:2], x[:, 2:3]
    return torch.cat([0.299 * r + 0.587 * g + 0.114 * b, r - g, 0.5 * (r + g) - b], 1)


def structure_retention_map(x: torch.Tensor, y: torch.Tensor, win_size: int = SSIM_WIN_SIZE,
                            sigma: float = SSIM_SIGMA, with_weights: bool = False):
    """Differentiable per-window contrast-structure similarity of two NCHW RGB images' Weber
    images, (N,3,h,w) for the three opponent channels (valid region). with_weights: also each
    window's weight, the reference y's own relative contrast there (structure_retention_torch)."""
    n, c, h, w = x.shape
    if c != 3:
        raise ValueError(f"structure retention needs RGB images, got {c} channels")
    if min(h, w) < win_size:
        raise ValueError(f"structure retention needs images at least {win_size}px, got {h}x{w}")
    g = gaussian_window(win_size, sigma, x.dtype, x.device)
    gh, gv = g.view(1, 1, 1, -1).repeat(3, 1, 1, 1), g.view(1, 1, -1, 1).repeat(3, 1, 1, 1)

    def blur(z):
        return F.conv2d(F.conv2d(z, gh, groups=3), gv, groups=3)

    ox, oy = opponent_channels(x), opponent_channels(y)
    mx, my = blur(ox), blur(oy)
    # local brightness of each image (its luminance mean), the divisor of all three channels
    bx, by = mx[:, :1].clamp_min(0) + STRUCTURE_EPS, my[:, :1].clamp_min(0) + STRUCTURE_EPS
    vx = (blur(ox * ox) - mx * mx).clamp_min(0) / (bx * bx)
    vy = (blur(oy * oy) - my * my).clamp_min(0) / (by * by)
    cxy = (blur(ox * oy) - mx * my) / (bx * by)
    similarity = (2 * cxy + STRUCTURE_C) / (vx + vy + STRUCTURE_C)
    return (similarity, vy + STRUCTURE_C) if with_weights else similarity


def structure_retention_torch(x: torch.Tensor, y: torch.Tensor) -> torch.Tensor:
    """Differentiable scalar in [-1, 1] (1: the same strokes, edges and colour relations at any
    brightness) of x against the reference y: structure_retention_map averaged over windows
    weighted by y's own relative contrast (flat windows of y have no strokes to keep, and would
    score a look darkened to nothing as kept), then over the channels by STRUCTURE_WEIGHTS."""
    similarity, weight = structure_retention_map(x, y, with_weights=True)
    weight = weight.detach()  # the reference's contrast only weighs; it is not optimised
    m = (similarity * weight).sum(dim=(0, 2, 3)) / weight.sum(dim=(0, 2, 3))
    w = torch.tensor(STRUCTURE_WEIGHTS, dtype=m.dtype, device=m.device)
    return (m * w).sum()


def structure_retention(pred, target) -> float:
    """structure_retention_torch of numpy (channel-last) or torch images, as a float."""
    p, t = _pair(pred, target)
    return float(structure_retention_torch(p, t))
