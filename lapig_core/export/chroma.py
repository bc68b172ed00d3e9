# SPDX-License-Identifier: GPL-3.0-or-later
"""4:2:0 chroma: what halving the colour resolution costs a projector image, and a conversion that costs less.

    to_yuv420(rgb, depth=8) -> (H*3/2, W) planes     BT.709, limited range, 4:2:0, luma-corrected (below)
    linear_psnr(a, b), edge_psnr(a, b, mask=None, linear=False)
                                                     PSNR of two RGB images in linear light, and on their edges
    edge_mask(rgb, fraction=0.1)                     the pixels whose Sobel gradient (luma) is in the top fraction

Why the correction: 4:2:0 keeps one Cb, Cr pair per 2x2 pixels. Where a saturated colour meets another (a red
line on green, coloured text) the decoder's interpolated chroma is wrong on both sides of the edge, and with
the luma unchanged the decoded pixels come out too dark or too bright in linear light (Y' is a gamma-encoded
sum, so wrong chroma moves the light): fringes beside every coloured edge. The encoder cannot fix the chroma,
but it can choose each pixel's Y' knowing the chroma the decoder will interpolate there: the Y' whose decoded
pixel has the source's luminance in linear light. The chroma itself is the 2x2 mean (a box low-pass, so no
aliasing), sited at the centre of the four pixels (the stream says so), and the decoder's interpolation is
modelled as bilinear. The idea is libwebp's "sharp YUV" and the luma adjustment of HDR 4:2:0 coding;
bench video reports the figures with and without it.

Pure numpy and OpenCV (cv2.resize), no av: the writer hands the planes to PyAV as a yuv420p frame.
"""
from __future__ import annotations

import cv2
import numpy as np

KR, KB = 0.2126, 0.0722  # BT.709
KG = 1.0 - KR - KB


def _to_float(rgb: np.ndarray) -> np.ndarray:
    scale = 255.0 if rgb.dtype == np.uint8 else 65535.0 if rgb.dtype == np.uint16 else 1.0
    return rgb.astype(np.float32) / np.float32(scale)


def _chroma_of(rgb: np.ndarray):
    y = KR * rgb[..., 0] + KG * rgb[..., 1] + KB * rgb[..., 2]
    cb = (rgb[..., 2] - y) / np.float32(2 * (1 - KB))
    cr = (rgb[..., 0] - y) / np.float32(2 * (1 - KR))
    return y, cb, cr


# from RGB in [0, 1]: Y', Cb, Cr (BT.709)
_B, _A = 2 * (1 - KB), 2 * (1 - KR)  # decoded B = Y' + _B Cb, R = Y' + _A Cr
_TO_YCBCR = np.array([[KR, KG, KB], [-KR / _B, -KG / _B, (1 - KB) / _B], [(1 - KR) / _A, -KG / _A, -KB / _A]],
                     np.float32)


def to_yuv420(rgb: np.ndarray, depth: int = 8, correct_luma: bool = True) -> np.ndarray:
    """The yuv420p (depth 8, uint8) or yuv420p10le (depth 10, uint16) planes of an (H, W, 3) RGB image (uint8,
    uint16 or float in [0, 1]; H and W even) stacked as (H * 3 / 2, W), as PyAV's VideoFrame.from_ndarray takes
    them: BT.709 matrix, limited range, the chroma the 2x2 mean, the luma corrected (module docstring)."""
    h, w = rgb.shape[:2]
    scale = 1 << (depth - 8)
    x = _to_float(rgb)
    luma, cb, cr = cv2.split(cv2.transform(x, _TO_YCBCR))
    half = [cv2.resize(c, (w // 2, h // 2), interpolation=cv2.INTER_AREA) for c in (cb, cr)]  # the 2x2 mean
    if correct_luma:
        luma = _luminance_kept(x, luma, (cb, cr), half)
    dtype = np.uint8 if depth == 8 else np.uint16
    out = np.empty((h * 3 // 2, w), dtype)
    # limited range: luma 16-235, chroma 16-240
    y = cv2.min(cv2.max(luma, 0.0), 1.0)
    out[:h] = cv2.convertScaleAbs(y, alpha=219, beta=16) if depth == 8 else \
        np.rint(y * np.float32(219 * scale) + np.float32(16 * scale)).astype(dtype)
    quarter = (h // 2) * (w // 2)
    flat = out[h:].reshape(-1)
    for k, plane in enumerate(half):
        c = np.clip(plane * np.float32(224 * scale) + np.float32(128 * scale), 16 * scale, 240 * scale)
        flat[k * quarter:(k + 1) * quarter] = np.rint(c).astype(dtype).reshape(-1)
    return out


_LUT_STEPS = 4096  # sRGB decoding and its slope, tabled (a gather is several times faster than a power)
_GRID = np.linspace(0.0, 1.0, _LUT_STEPS + 1)
_DECODE = np.where(_GRID <= 0.04045, _GRID / 12.92, ((_GRID + 0.055) / 1.055) ** 2.4).astype(np.float32)
_SLOPE = np.where(_GRID <= 0.04045, 1 / 12.92, 2.4 / 1.055 * ((_GRID + 0.055) / 1.055) ** 1.4).astype(np.float32)


def _table(v: np.ndarray, table: np.ndarray, outside: float | None = None) -> np.ndarray:
    index = np.clip(np.rint(v * _LUT_STEPS), 0, _LUT_STEPS).astype(np.int32)
    out = table[index]
    if outside is not None:  # a clipped channel's light does not move with Y'
        out[(v <= 0.0) | (v >= 1.0)] = outside
    return out


def _luminance_kept(x, luma, source_chroma, half_chroma, steps: int = 3) -> np.ndarray:
    """Y' where the decoder's interpolated chroma differs from the source's (colour edges): chosen so the decoded
    pixel's linear-light luminance is the source's (Newton's method on the monotone luminance of Y'); elsewhere
    the plain Y'. Only those pixels are computed (a few percent of a show frame)."""
    h, w = luma.shape
    up = [cv2.resize(c, (w, h), interpolation=cv2.INTER_LINEAR) for c in half_chroma]
    difference = cv2.add(cv2.absdiff(up[0], source_chroma[0]), cv2.absdiff(up[1], source_chroma[1]))
    off = difference > np.float32(4.0 / 224)  # two code values in each of Cb and Cr
    if not off.any():
        return luma
    cb, cr = up[0][off], up[1][off]
    weights = np.array([KR, KG, KB], np.float32)
    target = _table(x[off], _DECODE) @ weights
    shifts = np.stack([_A * cr, -(_B * KB / KG) * cb - (_A * KR / KG) * cr, _B * cb], axis=1)  # R, G, B - Y'
    y = luma[off]
    for _ in range(steps):
        channels = y[:, None] + shifts
        value = _table(channels, _DECODE) @ weights - target
        slope = _table(channels, _SLOPE, 0.0) @ weights
        y = np.clip(y - np.where(slope > 1e-6, value / np.maximum(slope, 1e-6), 0.0), 0.0, 1.0).astype(np.float32)
    out = luma.copy()
    out[off] = y
    return out


def srgb_to_linear(rgb: np.ndarray) -> np.ndarray:
    x = _to_float(rgb).astype(np.float64)
    return np.where(x <= 0.04045, x / 12.92, ((x + 0.055) / 1.055) ** 2.4)


def _psnr(a: np.ndarray, b: np.ndarray, mask=None) -> float:
    diff = (a - b) ** 2
    if mask is not None:
        diff = diff[mask]
    mse = float(np.mean(diff)) if diff.size else 0.0
    return float("inf") if mse == 0 else 10 * np.log10(1.0 / mse)


def linear_psnr(a: np.ndarray, b: np.ndarray) -> float:
    """PSNR (dB, peak 1) of two sRGB-encoded images compared in linear light."""
    return _psnr(srgb_to_linear(a), srgb_to_linear(b))


def edge_mask(rgb: np.ndarray, fraction: float = 0.1) -> np.ndarray:
    """The pixels whose Sobel gradient magnitude on luma is in the top `fraction` (the image's edges)."""
    y = _chroma_of(_to_float(rgb))[0]
    gx = cv2.Sobel(y, cv2.CV_32F, 1, 0, ksize=3)
    gy = cv2.Sobel(y, cv2.CV_32F, 0, 1, ksize=3)
    # a colour edge of equal luma has no luma gradient: take the strongest of the three channels' gradients too
    x = _to_float(rgb)
    mags = [np.hypot(gx, gy)] + [np.hypot(cv2.Sobel(x[..., k], cv2.CV_32F, 1, 0, ksize=3),
                                          cv2.Sobel(x[..., k], cv2.CV_32F, 0, 1, ksize=3)) for k in range(3)]
    magnitude = np.max(np.stack(mags), axis=0)
    threshold = np.quantile(magnitude, 1.0 - fraction)
    return magnitude >= max(threshold, 1e-6)


def edge_psnr(a: np.ndarray, b: np.ndarray, mask=None, linear: bool = False) -> float:
    """PSNR (dB, peak 1) on the edges of `a` (edge_mask) only, where fringes show: of the gamma-encoded values,
    or (linear=True) in linear light."""
    mask = edge_mask(a) if mask is None else mask
    if linear:
        return _psnr(srgb_to_linear(a), srgb_to_linear(b), mask)
    return _psnr(_to_float(a).astype(np.float64), _to_float(b).astype(np.float64), mask)
